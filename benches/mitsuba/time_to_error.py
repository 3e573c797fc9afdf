#!/usr/bin/env python3
"""Mitsuba 3's error against time on the measured Cornell box, in stokes' CSV format.

Renders the Cornell box of cbox.py (the scene shared/data/README.md describes, which
`scenes/cornell-box.toml` also is) with Mitsuba 3 at the resolution of a stokes
reference, at 1, 2, 4, 8, ... samples per pixel, and measures each image against the
reference exactly as `stokes converge` does (src/tools/converge.rs), over the whole
image and the three linear-sRGB channels:

    rmse   = sqrt(mean (x - r)^2)
    relmse = mean (x - r)^2 / (r^2 + 0.01)

What is timed: for each variant, the scene is loaded and rendered once at 1 spp
*untimed* (the warm-up: it traces and compiles the LLVM kernels, or finds them in
Dr.Jit's on-disk cache, and warms the caches; its wall time is printed and written to
the summary). Then every checkpoint is a separate `mi.render(scene, spp=N, seed=k)`
call, timed on its own with the wall clock from the call until the image is evaluated
(`dr.eval` + `dr.sync_thread` for LLVM), with a new seed each time. Converting the
image to numpy and computing the error are not timed. The renders go on (spp doubling)
until the sum of their times reaches --budget seconds, so the last one takes roughly
half the budget: to read off the error "in T seconds", give a budget of about 3 T.
Mitsuba renders all N spp in one call; the `seconds` of a checkpoint is that call's
time, the analogue of stokes' seconds of progressive rendering up to that spp.

Output (--out): stokes' convergence.csv columns, one row per checkpoint, `method` =
`mitsuba-<variant>`, the method-axis and spectral columns empty, `pass` = the index of
the render (1, 2, ...), `region` = `image`. On stdout: per variant, the warm-up time,
the seconds to reach relMSE --target (interpolated log-log between checkpoints, like
converge's summary) and the relMSE reached in --at seconds; with --stokes-csv, the
same for the methods of a `stokes converge` run and the ratios to stokes' best.

With --verify SPP it renders once at SPP (in calls of --chunk-spp: LLVM keeps a whole
call's wavefront in memory) and prints the error against the reference, the part of
it that the reference's noise (from its .variance.exr) and Mitsuba's (from the spread
of the calls) account for, and what is left: the bias floor. It also prints the error
of the image flipped vertically and horizontally and the ratio of channel means, to
catch orientation or exposure mismatches.

    /work/venvs/mitsuba/bin/python benches/mitsuba/time_to_error.py \
        --reference /tmp/cbox-ref-128.exr --variants llvm_ad_spectral,scalar_spectral \
        --budget 30 --threads 2 --out /tmp/mitsuba-tte.csv

See benches/mitsuba/README.md ("Error against time").
"""

import argparse
import csv
import math
import struct
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import cbox  # noqa: E402  (the scene builder)

CSV_HEADER = ("method,spectral,shifting,tracking,rays,dispersion,pass,spp,seconds,"
              "region,rmse,relmse,spectral_rmse,spectral_relmse").split(",")


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--reference", type=Path, required=True,
                   help="stokes reference of scenes/cornell-box.toml (EXR, linear sRGB)")
    p.add_argument("--variants", default="llvm_ad_spectral,scalar_spectral",
                   help="comma-separated Mitsuba variants (default: %(default)s)")
    p.add_argument("--budget", type=float, default=10.0,
                   help="per variant: stop once the timed renders add up to this many seconds")
    p.add_argument("--max-spp", type=int, default=1 << 20, help="never render more spp than this")
    p.add_argument("--threads", type=int, default=2, help="Dr.Jit thread count (counts the caller)")
    p.add_argument("--max-depth", type=int, default=None,
                   help="path segments from the camera, -1 unbounded; default: the "
                        "reference's stokes:max_depth (an error if they differ)")
    p.add_argument("--rr-depth", type=int, default=3,
                   help="Russian roulette from this depth on; 3 = stokes' (from the third "
                        "surface hit, survival min(max throughput, 0.95))")
    p.add_argument("--seed", type=int, default=1000,
                   help="seed of the warm-up; render k uses seed + k")
    p.add_argument("--data", type=Path, default=cbox.DEFAULT_DATA,
                   help="Cornell box data folder (default: %(default)s)")
    p.add_argument("--out", type=Path, default=None, help="CSV to write (stokes' columns)")
    p.add_argument("--target", type=float, default=1e-3, help="relMSE for 'seconds to target'")
    p.add_argument("--at", type=float, default=10.0, help="seconds for 'relMSE in T s'")
    p.add_argument("--stokes-csv", type=Path, default=None,
                   help="a `stokes converge` convergence.csv to put in the table, with ratios")
    p.add_argument("--table-only", type=Path, default=None, metavar="CSV",
                   help="render nothing: print the table of this CSV (written by --out)")
    p.add_argument("--verify", type=int, default=None, metavar="SPP",
                   help="render once at SPP per variant and print the bias floor instead")
    p.add_argument("--chunk-spp", type=int, default=256,
                   help="--verify renders in calls of this many spp")
    p.add_argument("--save", type=Path, default=None,
                   help="with --verify: write the image here (variant name appended)")
    return p.parse_args(argv)


# --- the reference -------------------------------------------------------------------

def exr_text_attributes(path):
    """The string attributes of an OpenEXR file's (first) header, as a dict.

    The header is a sequence of (name NUL, type NUL, int32 size, value) ended by a
    NUL byte, after the 4-byte magic number and the 4-byte version field.
    """
    with open(path, "rb") as f:
        data = f.read(1 << 20)
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError(f"{path}: not an OpenEXR file")
    pos, attrs = 8, {}
    while data[pos] != 0:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode("latin-1")
        tend = data.index(b"\0", end + 1)
        kind = data[end + 1:tend].decode("latin-1")
        (size,) = struct.unpack_from("<i", data, tend + 1)
        value = data[tend + 5:tend + 5 + size]
        if kind == "string":
            attrs[name] = value.decode("utf-8", "replace")
        pos = tend + 5 + size
    return attrs


def read_reference(path, mi):
    """(H, W, 3) float64 linear sRGB pixels (row 0 at the top) and the text attributes."""
    bmp = mi.Bitmap(str(path))
    names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
    arr = np.array(bmp).astype(np.float64)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    want = ["R", "G", "B"]
    if not all(c in names for c in want):
        raise SystemExit(f"{path}: channels {names}, expected R, G, B")
    rgb = np.stack([arr[:, :, names.index(c)] for c in want], axis=-1)
    return rgb, exr_text_attributes(path)


def errors(img, ref):
    """(rmse, relmse) over all pixels and the three channels, as stokes converge does."""
    d2 = (img.astype(np.float64) - ref) ** 2
    return math.sqrt(d2.mean()), float((d2 / (ref * ref + 0.01)).mean())


# --- log-log reading of a curve --------------------------------------------------------

def time_to_reach(points, target):
    """Seconds at which the error first falls to `target`, interpolated log-log between
    the checkpoints around the crossing (like converge.rs's time_to_reach); None if it
    never does. `points` are (seconds, error) in order."""
    for i, (t1, e1) in enumerate(points):
        if e1 <= target:
            if i == 0:
                return t1
            t0, e0 = points[i - 1]
            if min(t0, t1, e0, e1) <= 0 or e0 == e1:
                return t1
            f = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
    return None


def error_at(points, t):
    """The error at `t` seconds, interpolated log-log between the checkpoints around it,
    and whether `t` lies past the last checkpoint (then it is extrapolated from the
    last one with error proportional to 1/time, an unbiased estimator's rate)."""
    pts = sorted(p for p in points if p[0] > 0 and p[1] > 0)
    if not pts:
        return None, False
    if t <= pts[0][0]:
        return pts[0][1], False
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if t0 <= t <= t1:
            if t1 == t0:
                return e1, False
            f = (math.log(t) - math.log(t0)) / (math.log(t1) - math.log(t0))
            return math.exp(math.log(e0) + f * (math.log(e1) - math.log(e0))), False
    tl, el = pts[-1]
    if t <= tl * 1.02:  # a budget's last pass ends just short of it
        return el, False
    return el * tl / t, True


# --- rendering -------------------------------------------------------------------------

def load_scene(mi, args, res, max_depth, spp=1):
    ns = argparse.Namespace(data=args.data, max_depth=max_depth, rr_depth=args.rr_depth,
                            res=res, spp=spp)
    return mi.load_dict(cbox.build_scene_dict(ns))


def render(mi, dr, scene, spp, seed, is_jit, cpu=None):
    """One render: (H, W, 3) float32 image, wall seconds until it is evaluated. If
    `cpu` is a list, the process's CPU seconds during the render are appended to it
    (all threads: CPU / wall near the thread count means the cores were ours)."""
    c0, t0 = time.process_time(), time.perf_counter()
    img = mi.render(scene, seed=seed, spp=spp)
    if is_jit:
        dr.eval(img)
        dr.sync_thread()
    dt = time.perf_counter() - t0
    if cpu is not None:
        cpu.append(time.process_time() - c0)
    return np.array(img, dtype=np.float32)[:, :, :3], dt


def setup_variant(variant, threads):
    import drjit as dr
    import mitsuba as mi
    mi.set_variant(variant)
    mi.set_log_level(mi.LogLevel.Warn)
    dr.set_thread_count(threads)
    return mi, dr


def run_variant(variant, args, ref, max_depth):
    """The checkpoints of one variant: dicts with pass, spp, seconds, rmse, relmse."""
    mi, dr = setup_variant(variant, args.threads)
    is_jit = variant.startswith("llvm")
    h, w, _ = ref.shape
    t0 = time.perf_counter()
    scene = load_scene(mi, args, w, max_depth)
    load_s = time.perf_counter() - t0
    _, warm_s = render(mi, dr, scene, 1, args.seed, is_jit)
    print(f"{variant}: mitsuba {mi.__version__} drjit {dr.__version__}, {w}x{h}, "
          f"threads {dr.thread_count()}, max_depth {max_depth}, rr_depth {args.rr_depth}; "
          f"scene load {load_s:.3f} s, warm-up render (1 spp) {warm_s:.3f} s, not counted",
          flush=True)
    rows, total, spp, k = [], 0.0, 1, 0
    while total < args.budget and spp <= args.max_spp:
        k += 1
        cpu = []
        img, dt = render(mi, dr, scene, spp, args.seed + k, is_jit, cpu)
        total += dt
        rmse, relmse = errors(img, ref)
        rows.append({"pass": k, "spp": spp, "seconds": dt, "rmse": rmse, "relmse": relmse})
        print(f"  spp {spp:6d}: {dt:8.3f} s  rmse {rmse:.4e}  relmse {relmse:.4e}  "
              f"({h * w * spp / dt / 1e6:.2f} M samples/s, CPU/wall {cpu[0] / dt:.2f})",
              flush=True)
        spp *= 2
    return rows, {"load": load_s, "warmup": warm_s}


def verify_variant(variant, args, ref, max_depth, ref_var=None):
    """Renders once at --verify spp (in calls of --chunk-spp) and prints the error
    against the reference, split into the two renderers' noise and what is left (the
    bias floor), and orientation and exposure checks."""
    mi, dr = setup_variant(variant, args.threads)
    is_jit = variant.startswith("llvm")
    h, w, _ = ref.shape
    scene = load_scene(mi, args, w, max_depth)
    render(mi, dr, scene, 1, args.seed, is_jit)  # warm-up
    chunk = min(args.chunk_spp, args.verify)
    chunks, secs = [], 0.0
    while sum(n for n, _ in chunks) < args.verify:
        n = min(chunk, args.verify - sum(n for n, _ in chunks))
        img, dt = render(mi, dr, scene, n, args.seed + 100000 + len(chunks), is_jit)
        chunks.append((n, img.astype(np.float64)))
        secs += dt
    done = sum(n for n, _ in chunks)
    img = sum(n * x for n, x in chunks) / done
    rmse, relmse = errors(img, ref)
    print(f"{variant}: {done} spp in {secs:.1f} s ({len(chunks)} call(s)): "
          f"rmse {rmse:.4e} relmse {relmse:.4e}")
    weight = 1.0 / (ref * ref + 0.01)
    noise = 0.0
    if ref_var is not None:
        ref_noise = float((ref_var * weight).mean())
        noise += ref_noise
        print(f"  of which the reference's own noise (its variance file): relmse {ref_noise:.4e}")
    same = [x for n, x in chunks if n == chunk]
    if len(same) >= 2:
        k = len(same)
        mean = sum(same) / k
        # variance of the mean of the k equal chunks, from their spread
        var = sum((x - mean) ** 2 for x in same) / (k * (k - 1)) * (k * chunk / done) ** 2
        mi_noise = float((var * weight).mean())
        noise += mi_noise
        print(f"  of which Mitsuba's noise (spread of its {k} chunks): relmse {mi_noise:.4e}")
    if noise > 0:
        print(f"  left for the bias between the two (measured - noise): relmse {relmse - noise:.4e}")
    for name, flipped in [("flipped vertically", img[::-1]), ("flipped horizontally", img[:, ::-1])]:
        r, e = errors(flipped, ref)
        print(f"  {name}: rmse {r:.4e} relmse {e:.4e}")
    m, mr = img.reshape(-1, 3).mean(0), ref.reshape(-1, 3).mean(0)
    print(f"  mean linear sRGB: mitsuba {m.round(5).tolist()} stokes {mr.round(5).tolist()} "
          f"ratio {(m / mr).round(4).tolist()}")
    # Scaled to stokes' mean per channel: what is left is noise and local differences.
    r, e = errors(img * (mr / m), ref)
    print(f"  after scaling each channel to stokes' mean: rmse {r:.4e} relmse {e:.4e}")
    if args.save is not None:
        out = args.save.with_name(f"{args.save.stem}-{variant}{args.save.suffix}")
        mi.Bitmap(img.astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(out))
        print(f"  wrote {out}")
    return img


# --- the CSV and the table -------------------------------------------------------------

def write_csv(path, runs):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        wr = csv.writer(f, lineterminator="\n")
        wr.writerow(CSV_HEADER)
        for variant, rows in runs:
            for r in rows:
                wr.writerow([f"mitsuba-{variant}", "", "", "", "", "", r["pass"], r["spp"],
                             f"{r['seconds']:.6f}", "image", f"{r['rmse']:.6e}",
                             f"{r['relmse']:.6e}", "", ""])


def read_curves(path, region="image"):
    """{method: [(seconds, relmse, spp), ...]} from a CSV with stokes' columns."""
    curves = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            if r["region"] == region:
                curves.setdefault(r["method"], []).append(
                    (float(r["seconds"]), float(r["relmse"]), int(r["spp"])))
    return curves


def summarize(curves, target, at):
    out = {}
    for m, c in curves.items():
        pts = [(s, e) for s, e, _ in c]
        t = time_to_reach(pts, target)
        est = None
        if t is None and pts:
            tl, el = pts[-1]
            est = tl * el / target  # relMSE ~ 1/time from the last checkpoint
        e_at, extrap = error_at(pts, at)
        out[m] = {"t": t, "t_est": est, "e_at": e_at, "extrap": extrap,
                  "t_eff": t if t is not None else est,
                  "spp": c[-1][2], "seconds": c[-1][0], "relmse": c[-1][1]}
    return out


def print_table(mitsuba, stokes, target, at, warmups=None):
    print()
    print(f"| renderer / method | last spp | its seconds | its relMSE | seconds to relMSE "
          f"{target:g} | relMSE in {at:g} s |")
    print("| --- | --- | --- | --- | --- | --- |")

    def row(name, s):
        t = f"{s['t']:.3f}" if s["t"] is not None else f"not reached (~{s['t_est']:.1f} extrapolated)"
        e = f"{s['e_at']:.3e}" + (" (extrapolated)" if s["extrap"] else "")
        print(f"| {name} | {s['spp']} | {s['seconds']:.3f} | {s['relmse']:.3e} | {t} | {e} |")

    for m, s in stokes.items():
        row(f"stokes {m}", s)
    for m, s in mitsuba.items():
        row(m, s)
    if warmups:
        print()
        for v, w in warmups.items():
            print(f"{v}: scene load {w['load']:.3f} s, warm-up render {w['warmup']:.3f} s (not counted)")
    if stokes:
        # stokes' best: the least seconds to the target (extrapolated if none reached it)
        best = min(stokes, key=lambda m: stokes[m]["t_eff"] if stokes[m]["t_eff"] else math.inf)
        b = stokes[best]
        how = "" if b["t"] is not None else f" (not reached in {b['seconds']:.1f} s: extrapolated)"
        print(f"\nstokes' best method to relMSE {target:g}: {best}, {b['t_eff']:.3f} s{how}")
        print()
        print(f"| Mitsuba variant | seconds to {target:g} | ratio to stokes' best | "
              f"relMSE in {at:g} s | ratio to stokes' best's |")
        print("| --- | --- | --- | --- | --- |")
        for m, s in mitsuba.items():
            ext = " (extrapolated)" if s["t"] is None or b["t"] is None else ""
            ratio_t = f"{s['t_eff'] / b['t_eff']:.2f}{ext}" if b["t_eff"] else "—"
            ext = " (extrapolated)" if s["extrap"] or b["extrap"] else ""
            ratio_e = f"{s['e_at'] / b['e_at']:.2f}{ext}" if b["e_at"] else "—"
            print(f"| {m} | {s['t_eff']:.3f} | {ratio_t} | {s['e_at']:.3e} | {ratio_e} |")
        print(f"\n(a ratio below 1: Mitsuba needs less time, or reaches a lower error, "
              f"than stokes' best method)")


def main(argv=None):
    args = parse_args(argv)
    stokes = summarize(read_curves(args.stokes_csv), args.target, args.at) if args.stokes_csv else {}
    if args.table_only is not None:
        print_table(summarize(read_curves(args.table_only), args.target, args.at), stokes,
                    args.target, args.at)
        return 0

    import mitsuba as mi
    mi.set_variant("scalar_rgb")  # only to read the reference
    ref, attrs = read_reference(args.reference, mi)
    h, w, _ = ref.shape
    if h != w:
        raise SystemExit(f"{args.reference} is {w}x{h}: cbox.py renders square images")
    ref_depth = attrs.get("stokes:max_depth")
    max_depth = args.max_depth
    if ref_depth is not None:
        if max_depth is None:
            max_depth = int(ref_depth)
        elif max_depth != int(ref_depth):
            raise SystemExit(f"--max-depth {max_depth} but the reference was rendered with "
                             f"stokes:max_depth {ref_depth}: the images converge to different values")
    elif max_depth is None:
        raise SystemExit(f"{args.reference} has no stokes:max_depth attribute: give --max-depth")
    print(f"reference {args.reference}: {w}x{h}, {attrs.get('stokes:spp', '?')} spp, "
          f"max_depth {ref_depth}, scene {attrs.get('stokes:scene', '?')}", flush=True)

    variants = [v for v in args.variants.split(",") if v]
    if args.verify is not None:
        var_path = args.reference.with_name(args.reference.stem + ".variance.exr")
        ref_var = read_reference(var_path, mi)[0] if var_path.exists() else None
        for v in variants:
            verify_variant(v, args, ref, max_depth, ref_var)
        return 0

    runs, warmups = [], {}
    for v in variants:
        rows, warm = run_variant(v, args, ref, max_depth)
        runs.append((v, rows))
        warmups[f"mitsuba-{v}"] = warm
    if args.out is not None:
        write_csv(args.out, runs)
        print(f"wrote {args.out}")
    curves = {f"mitsuba-{v}": [(r["seconds"], r["relmse"], r["spp"]) for r in rows]
              for v, rows in runs}
    print_table(summarize(curves, args.target, args.at), stokes, args.target, args.at, warmups)
    return 0


if __name__ == "__main__":
    sys.exit(main())
