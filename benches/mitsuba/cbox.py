#!/usr/bin/env python3
"""Mitsuba 3 side-by-side benchmark: the measured Cornell box.

Builds the scene described in shared/data/README.md ("The measured Cornell box,
as the reference renderers set it up") as a Mitsuba dict scene, renders it K
times and prints seconds and M samples/s per run, then one JSON summary line.

    python3 benches/mitsuba/cbox.py --variant scalar_spectral --res 512 --spp 64 \
        --threads 2 --repeat 3 --out /tmp/mitsuba_cbox.exr

See benches/mitsuba/README.md for installation, meaning of the numbers and caveats.
"""

import argparse
import csv
import json
import os
import statistics
import sys
import time
from pathlib import Path

# shared/ sits beside the repository: /work/main/benches/mitsuba/cbox.py -> /work/shared
DEFAULT_DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "cornell-box"

# Luminaire spectral radiance (same numbers as cornell-box/light.csv); used only
# if light.csv is missing, so the scene can be checked against the README.
LIGHT_FALLBACK = [(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)]


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--variant", default="scalar_spectral",
                   choices=["scalar_spectral", "llvm_ad_spectral"])
    p.add_argument("--res", type=int, default=512, help="image width = height")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel")
    p.add_argument("--threads", type=int, default=os.cpu_count() or 1,
                   help="worker threads (Dr.Jit/nanothread pool, used by both variants)")
    p.add_argument("--repeat", type=int, default=3, help="number of timed renders")
    p.add_argument("--max-depth", type=int, default=6,
                   help="path length limit (1 = emitters only, 2 = direct light)")
    p.add_argument("--rr-depth", type=int, default=5,
                   help="Russian roulette starts at this depth (Mitsuba's default: 5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first run (run i uses seed+i)")
    p.add_argument("--data", type=Path, default=DEFAULT_DATA,
                   help="folder with light.csv, reflectance.csv and meshes/ (default: %(default)s)")
    p.add_argument("--out", type=Path, default=None,
                   help="write the last run's image here (EXR, linear sRGB)")
    return p.parse_args(argv)


def read_csv_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], [r for r in rows[1:] if r]
    cols = {name: [float(r[i]) for r in body] for i, name in enumerate(header)}
    return cols


def spectrum(pairs):
    """Mitsuba tabulated spectrum: linear between samples, zero outside the range."""
    return {"type": "spectrum", "value": [(float(w), float(v)) for w, v in pairs]}


def build_scene_dict(args):
    data = args.data
    refl = read_csv_columns(data / "reflectance.csv")
    nm = refl["nm"]
    light_csv = data / "light.csv"
    if light_csv.exists():
        lc = read_csv_columns(light_csv)
        light = list(zip(lc["nm"], lc["radiance"]))
    else:
        light = LIGHT_FALLBACK

    def diffuse(name):
        # One-sided diffuse, as in Mitsuba's own cbox scene: the OBJ faces are
        # wound so that their normals point into the box.
        return {"type": "diffuse", "reflectance": spectrum(zip(nm, refl[name]))}

    mesh_dir = data / "meshes"

    def obj(name, bsdf, **extra):
        d = {"type": "obj", "filename": str(mesh_dir / f"cbox_{name}.obj"), "bsdf": bsdf}
        d.update(extra)
        return d

    import mitsuba as mi  # variant already set

    white, red, green = diffuse("white"), diffuse("red"), diffuse("green")
    res = args.res
    return {
        "type": "scene",
        "integrator": {
            "type": "path",
            "max_depth": args.max_depth,
            "rr_depth": args.rr_depth,
        },
        "sensor": {
            "type": "perspective",
            "fov": 39.3077,
            "fov_axis": "y",
            "near_clip": 10.0,
            "far_clip": 2800.0,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=[278.0, 273.0, -800.0],
                target=[278.0, 273.0, -799.0],
                up=[0.0, 1.0, 0.0],
            ),
            "sampler": {"type": "independent", "sample_count": args.spp},
            "film": {
                "type": "hdrfilm",
                "width": res,
                "height": res,
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
                "component_format": "float32",
            },
        },
        "floor": obj("floor", white),
        "ceiling": obj("ceiling", white),
        "back": obj("back", white),
        "redwall": obj("redwall", red),
        "greenwall": obj("greenwall", green),
        "smallbox": obj("smallbox", white),
        "largebox": obj("largebox", white),
        "luminaire": obj(
            "luminaire",
            # 0.78 flat over the data range; the light emits only in 400-700 nm,
            # so the value outside it never contributes.
            {"type": "diffuse", "reflectance": spectrum([(400.0, 0.78), (700.0, 0.78)])},
            to_world=mi.ScalarTransform4f().translate([0.0, -0.5, 0.0]),
            # Area emitters in Mitsuba emit on the side the normal faces; the
            # luminaire's face normal points down (-y).
            emitter={"type": "area", "radiance": spectrum(light)},
        ),
    }


def channel_means(img):
    """Mean of each channel of an (H, W, C) Dr.Jit tensor, without numpy."""
    h, w, c = img.shape
    flat = list(img.array)  # interleaved, row-major
    return [sum(flat[k::c]) / (h * w) for k in range(min(c, 3))]


def main(argv=None):
    args = parse_args(argv)

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    mi.set_log_level(mi.LogLevel.Warn)
    # Mitsuba 3 parallelises both the scalar render loop and the LLVM kernels on
    # Dr.Jit's nanothread pool; N counts the calling thread (N-1 workers).
    dr.set_thread_count(args.threads)
    threads = dr.thread_count()
    is_jit = args.variant.startswith("llvm")

    t0 = time.perf_counter()
    scene = mi.load_dict(build_scene_dict(args))
    load_s = time.perf_counter() - t0
    print(f"mitsuba {mi.__version__} drjit {dr.__version__} variant {args.variant} "
          f"threads {threads} res {args.res} spp {args.spp} max_depth {args.max_depth} "
          f"rr_depth {args.rr_depth}", flush=True)
    print(f"scene load: {load_s:.3f} s (not counted)", flush=True)

    samples = args.res * args.res * args.spp
    times = []
    img = None
    for i in range(args.repeat):
        t0 = time.perf_counter()
        img = mi.render(scene, seed=args.seed + i, spp=args.spp)
        if is_jit:
            dr.eval(img)
            dr.sync_thread()
        dt = time.perf_counter() - t0
        times.append(dt)
        note = " (includes JIT compilation / kernel-cache lookup)" if is_jit and i == 0 else ""
        print(f"run {i + 1}/{args.repeat}: {dt:.3f} s, "
              f"{samples / dt / 1e6:.3f} M samples/s{note}", flush=True)

    # For the LLVM variant, the first run traces and compiles the kernels: leave it
    # out of the median when there is anything else to take the median of.
    timed = times[1:] if (is_jit and len(times) > 1) else times
    median = statistics.median(timed)

    mean_rgb = channel_means(img)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(args.out))
        print(f"wrote {args.out} (linear sRGB, float32)", flush=True)

    summary = {
        "renderer": "mitsuba3",
        "mitsuba_version": mi.__version__,
        "variant": args.variant,
        "res": args.res,
        "spp": args.spp,
        "threads": threads,
        "max_depth": args.max_depth,
        "seconds_median": round(median, 4),
        "msamples_per_s": round(samples / median / 1e6, 4),
        "first_run_seconds": round(times[0], 4),
        "runs_seconds": [round(t, 4) for t in times],
        "median_excludes_first_run": bool(is_jit and len(times) > 1),
        "scene_load_seconds": round(load_s, 4),
        "mean_linear_srgb": [round(x, 6) for x in mean_rgb],
    }
    print(json.dumps(summary), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
