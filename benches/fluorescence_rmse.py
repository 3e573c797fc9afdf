#!/usr/bin/env python3
"""RMSE against a high-spp reference, at 16 spp and at equal time.

--set surfaces (default): mono, HWSS-constant and HWSS-independent on the fluorescent-surfaces
scenes. The "region" columns are the RMSE over the scene's region of interest (REGIONS:
the row of fluorescent patches, the dye block, the slab).
--set tracking: mono (fluo-aware), and HWSS with classic, maximum and fluorescence-aware
tracking, e.g. on fluorescent-slab and fluorescent-volume-440nm.
--set dispersion: lane dropping and wavelength-split paths at dispersive refractions, on
scenes/prism.toml.
The reference is the last method of the set at --ref-spp. Prints a Markdown table and writes
docs/results/<scene>-16spp.png (the methods left to right, in the order above).

Run from the repository root after `cargo build --release`:
    python3 benches/fluorescence_rmse.py [--set surfaces|tracking|dispersion] [--res 256] [--ref-spp 2048] [--scenes a.toml ...]
Uses the stokes binary and OpenImageIO's oiiotool.
"""
import argparse, json, math, os, subprocess, sys, tempfile

STOKES = "target/release/stokes"
SURFACE_METHODS = [("mono", ["--spectral", "mono"]),
                   ("hwss-constant", ["--spectral", "hwss", "--shifting", "constant"]),
                   ("hwss-independent", ["--spectral", "hwss", "--shifting", "independent"])]
DISPERSION_METHODS = [("drop", ["--dispersion", "drop"]),
                      ("split", ["--dispersion", "split"])]
TRACKING_METHODS = [("mono fluo-aware", ["--spectral", "mono", "--tracking", "fluo-aware"]),
                    ("hwss classic", ["--spectral", "hwss", "--tracking", "classic"]),
                    ("hwss max", ["--spectral", "hwss", "--tracking", "max"]),
                    ("hwss fluo-aware", ["--spectral", "hwss", "--tracking", "fluo-aware"])]


def render(scene, out, res, spp, seed, extra):
    stats = out + ".json"
    subprocess.run([STOKES, "render", scene, "-o", out, "--res", f"{res}x{res}", "--spp", str(spp),
                    "--seed", str(seed), "--stats-json", stats] + extra, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return json.load(open(stats))


# Regions of interest, as fractions of the image (x0, x1, y0, y1), projected from the
# scenes' geometry: the row of fluorescent patches, the inside of the dye block, the slab.
REGIONS = {
    "fluorescent-surfaces": (0.3145, 0.6855, 0.5856, 0.6887),
    "fluorescent-surfaces-440nm": (0.3145, 0.6855, 0.5856, 0.6887),
    "fluorescent-volume": (0.33, 0.50, 0.45, 0.82),
    "fluorescent-volume-440nm": (0.33, 0.50, 0.45, 0.82),
    "fluorescent-slab": (0.15, 0.85, 0.15, 0.85),
    "fluorescent-slab-backlit": (0.15, 0.85, 0.15, 0.85),
}


def region(name, res):
    """The oiiotool crop geometry of a scene's region of interest, or None."""
    if name not in REGIONS:
        return None
    fx0, fx1, fy0, fy1 = REGIONS[name]
    x0, x1 = int(fx0 * res) + 1, int(fx1 * res) - 1
    y0, y1 = int(fy0 * res) + 1, int(fy1 * res) - 1
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
    ap.add_argument("--set", choices=["surfaces", "tracking", "dispersion"], default="surfaces",
                    help="surfaces: mono/constant/independent; tracking: classic/max/fluo-aware (+ mono); "
                         "dispersion: drop/split")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="stokes-rmse-")
    print(f"| scene | method | M samples/s | RMSE @ {a.spp} spp: image | region | spp at equal time | RMSE @ equal time: image | region |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    methods = {"surfaces": SURFACE_METHODS, "tracking": TRACKING_METHODS,
               "dispersion": DISPERSION_METHODS}[a.set]
    base = methods[-1][0]

    for scene in a.scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        crop = region(name, a.res)
        # References are cached between runs (same scene, resolution, spp and set).
        cache = os.path.join(tempfile.gettempdir(), "stokes-rmse-refs")
        os.makedirs(cache, exist_ok=True)
        ref = os.path.join(cache, f"{name}-{a.set}-{a.res}-{a.ref_spp}.exr")
        if not os.path.exists(ref):
            render(scene, ref, a.res, a.ref_spp, 999, methods[-1][1])
        rows, pngs, secs = [], [], {}
        for m, extra in methods:
            out = os.path.join(tmp, f"{name}-{m}.exr")
            st = render(scene, out, a.res, a.spp, 1, extra + ["--png"])
            secs[m] = st["seconds"]
            rows.append((m, rmse(out, ref), rmse(out, ref, crop) if crop else float("nan"),
                         st["samples_per_second"]))
            pngs.append(out[:-4] + ".png")
        budget = secs[base]
        for m, err, err_p, sps in rows:
            extra = dict(methods)[m]
            spp_eq = max(1, round(a.spp * budget / secs[m]))
            out = os.path.join(tmp, f"{name}-{m}-eq.exr")
            render(scene, out, a.res, spp_eq, 2, extra)
            eq_p = f"{rmse(out, ref, crop):.4f}" if crop else "–"
            err_p = f"{err_p:.4f}" if crop else "–"
            print(f"| {name} | {m} | {sps / 1e6:.2f} | {err:.4f} | {err_p} | {spp_eq} "
                  f"| {rmse(out, ref):.4f} | {eq_p} |")
            sys.stdout.flush()
        os.makedirs(a.png_dir, exist_ok=True)
        subprocess.run(["oiiotool"] + pngs + ["--mosaic", f"{len(pngs)}x1", "-o",
                        os.path.join(a.png_dir, f"{name}-{a.set}-{a.spp}spp.png")], check=True)


if __name__ == "__main__":
    main()
