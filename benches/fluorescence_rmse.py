#!/usr/bin/env python3
"""RMSE of mono, HWSS-constant and HWSS-independent against a high-spp reference, at 16 spp
and at equal time, on the fluorescent-surfaces scenes. Prints a Markdown table and writes
docs/results/<scene>-16spp.png (mono | constant | independent, left to right).

Run from the repository root after `cargo build --release`:
    python3 benches/fluorescence_rmse.py [--res 256] [--ref-spp 2048] [--scenes a.toml b.toml]
Uses the stokes binary and OpenImageIO's oiiotool.
"""
import argparse, json, math, os, subprocess, sys, tempfile

STOKES = "target/release/stokes"
METHODS = [("mono", ["--spectral", "mono"]),
           ("hwss-constant", ["--spectral", "hwss", "--shifting", "constant"]),
           ("hwss-independent", ["--spectral", "hwss", "--shifting", "independent"])]


def render(scene, out, res, spp, seed, extra):
    stats = out + ".json"
    subprocess.run([STOKES, "render", scene, "-o", out, "--res", f"{res}x{res}", "--spp", str(spp),
                    "--seed", str(seed), "--stats-json", stats] + extra, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return json.load(open(stats))


def patch_row(res):
    """The crop (oiiotool geometry) holding the three fluorescent patches: the patch row
    x in [98, 458] mm, y in [90, 190] mm on the back wall, seen by the box's camera."""
    x0, x1 = int(0.3145 * res) + 1, int(0.6855 * res) - 1
    y0, y1 = int(0.5856 * res) + 1, int(0.6887 * res) - 1
    return f"{x1 - x0}x{y1 - y0}+{x0}+{y0}"


def rmse(a, b, crop=None):
    """RMSE over pixels and channels, from oiiotool's mean of the squared difference."""
    cut = ["--cut", crop] if crop else []
    out = subprocess.run(["oiiotool", a] + cut + [b] + cut + ["--sub", "--dup", "--mul", "--printstats"],
                         check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        if "Stats Avg:" in line:
            vals = [float(v) for v in line.split(":")[1].split()[:3]]
            return math.sqrt(sum(vals) / 3)
    raise RuntimeError(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--ref-spp", type=int, default=2048)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--scenes", nargs="+",
                    default=["scenes/fluorescent-surfaces.toml", "scenes/fluorescent-surfaces-440nm.toml"])
    ap.add_argument("--png-dir", default="docs/results")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="stokes-rmse-")
    print(f"| scene | method | M samples/s | RMSE @ {a.spp} spp: image | patches | spp at equal time | RMSE @ equal time: image | patches |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    crop = patch_row(a.res)
    for scene in a.scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        ref = os.path.join(tmp, f"{name}-ref.exr")
        render(scene, ref, a.res, a.ref_spp, 999, ["--spectral", "hwss", "--shifting", "independent"])
        rows, pngs, secs = [], [], {}
        for m, extra in METHODS:
            out = os.path.join(tmp, f"{name}-{m}.exr")
            st = render(scene, out, a.res, a.spp, 1, extra + ["--png"])
            secs[m] = st["seconds"]
            rows.append((m, rmse(out, ref), rmse(out, ref, crop), st["samples_per_second"]))
            pngs.append(out[:-4] + ".png")
        budget = secs["hwss-independent"]
        for m, err, err_p, sps in rows:
            extra = dict(METHODS)[m]
            spp_eq = max(1, round(a.spp * budget / secs[m]))
            out = os.path.join(tmp, f"{name}-{m}-eq.exr")
            render(scene, out, a.res, spp_eq, 2, extra)
            print(f"| {name} | {m} | {sps / 1e6:.2f} | {err:.4f} | {err_p:.4f} | {spp_eq} "
                  f"| {rmse(out, ref):.4f} | {rmse(out, ref, crop):.4f} |")
            sys.stdout.flush()
        os.makedirs(a.png_dir, exist_ok=True)
        subprocess.run(["oiiotool"] + pngs + ["--mosaic", "3x1", "-o",
                        os.path.join(a.png_dir, f"{name}-{a.spp}spp.png")], check=True)


if __name__ == "__main__":
    main()
