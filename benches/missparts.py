#!/usr/bin/env python3
"""Where a render's first-level data-cache misses come from, summed by part, per pixel
sample, from one run under cachegrind's cache simulation:

    python3 benches/missparts.py BIN [--scene S] [--res WxH] [--spp N] [--rays R]
                                     [--max-depth D] [--keep OUT.cg]

The render is `BIN render S --res WxH --spp N --threads 1 --rays R --max-depth D` under
`valgrind --tool=cachegrind --cache-sim=yes`; `cg_annotate --auto=no --show=Ir,D1mr,D1mw
--threshold=0` lists every function's read and write misses, and each function goes to
one part by its name:

- embree: functions without symbols (Embree's kernels) and Embree's entry points;
- spectral tables: tabulated curves, the wavelength sampling's tables, spectrum lookups;
- film: the film's weights and row sums;
- exr: the EXR writer's compression (once per render);
- tracer state: everything else inlined into the packet tracer (`Tracer`), whose loads
  and stores are mostly the groups' state;
- rest: the rest (memset, memcpy, start-up).

The parts follow the names, not the data touched: a table lookup inlined into the tracer
counts as tracer state, so that part is an upper bound.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

PARTS = [
    ("embree", lambda n: n.startswith("???") or ":rtc" in n),
    ("spectral tables", lambda n: any(k in n for k in
                                      ("Tabulated", "hwss", "eval_w", "Spectrum::eval"))),
    ("film", lambda n: any(k in n for k in ("rgb_weights", "RowSums", "render.rs"))),
    ("exr", lambda n: "miniz" in n or "exr" in n),
    ("tracer state", lambda n: "Tracer" in n),
    ("rest", lambda n: True),
]

ROW = re.compile(r"^\s*([\d,]+)\s+(?:\([^)]*\)\s+)?([\d,]+|\.)\s+(?:\([^)]*\)\s+)?"
                 r"([\d,]+|\.)\s+(?:\([^)]*\)\s+)?(\S.*)$")


def number(s):
    return 0 if s == "." else int(s.replace(",", ""))


def parts(annotated):
    """(totals, {part: [read misses, write misses]}) from cg_annotate's function list."""
    sums = {name: [0, 0] for name, _ in PARTS}
    totals = None
    for line in annotated.splitlines():
        m = ROW.match(line)
        if not m:
            continue
        read, write, name = number(m.group(2)), number(m.group(3)), m.group(4)
        if "PROGRAM TOTALS" in name:
            totals = (read, write)
            continue
        part = next(p for p, test in PARTS if test(name))
        sums[part][0] += read
        sums[part][1] += write
    if totals is None:
        sys.exit("no PROGRAM TOTALS line in cg_annotate's output")
    return totals, sums


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("binary")
    ap.add_argument("--scene", default="scenes/cornell-box.toml")
    ap.add_argument("--res", default="128x128")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--rays", default="packet")
    ap.add_argument("--max-depth", default="-1")
    ap.add_argument("--keep", help="keep cachegrind's output file here")
    a = ap.parse_args()
    w, h = (int(v) for v in a.res.split("x"))
    samples = w * h * a.spp
    with tempfile.TemporaryDirectory() as tmp:
        out = a.keep or os.path.join(tmp, "render.cg")
        cmd = ["valgrind", "--tool=cachegrind", "--cache-sim=yes",
               f"--cachegrind-out-file={out}", a.binary, "render", a.scene, "--res", a.res,
               "--spp", str(a.spp), "--threads", "1", "--rays", a.rays,
               "--max-depth", a.max_depth, "-o", os.path.join(tmp, "render.exr")]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        annotated = subprocess.run(
            ["cg_annotate", "--auto=no", "--show=Ir,D1mr,D1mw", "--sort=D1mr",
             "--threshold=0", out], check=True, capture_output=True, text=True).stdout
    (read, write), sums = parts(annotated)
    print(f"{a.scene} {a.res}, {a.spp} spp, --rays {a.rays}, --max-depth {a.max_depth}: "
          f"L1 data misses per pixel sample ({samples} samples)")
    print(f"{'part':>16} {'read':>7} {'write':>7} {'share':>6}")
    for name, (r, wr) in sums.items():
        share = 100.0 * (r + wr) / max(read + write, 1)
        print(f"{name:>16} {r / samples:7.2f} {wr / samples:7.2f} {share:5.1f}%")
    print(f"{'all':>16} {read / samples:7.2f} {write / samples:7.2f}")


if __name__ == "__main__":
    main()
