#!/usr/bin/env python3
"""Instructions and simulated cache misses per pixel sample of one render, for one or more
`stokes` binaries: counts that do not depend on the machine's load, for changes whose
effect is in memory traffic rather than in instructions (which callgrind alone counts).

    python3 benches/cachesim.py [--scene S] [--res WxH] [--spp N] [--pass-spp P] [--rays R]
        [--max-depth D] BIN [BIN ...]

Each binary renders `stokes render S --res WxH --spp N --pass-spp P --threads 1 --rays R
--max-depth D` under `valgrind --tool=cachegrind --cache-sim=yes`, which simulates this machine's
first-level instruction and data caches and its last-level cache (sizes as valgrind reads
them from the CPU; it prints them). The whole process is counted, scene load and EXR
output included, so compare binaries on the same render rather than reading the
absolute figures. Passes are N spp (one pass) by default, so that a packet tracer keeps
its paths in flight as in a long render; if any binary predates `--pass-spp` (stop 50),
all render in passes of 1, as the figures of stops 43–49 in docs/packets.md were
counted (at 128 pixels a row pair then starts and drains 128 paths every 256 samples).

Columns, per pixel sample: Ir (instructions), I1 and D1 (first-level instruction and
data misses, reads and writes), LL (last-level misses), and a proxy of cycles,
Ir + 12 * (I1 + D1) + 200 * LL: an L1 miss served by L2 costs about 12 cycles on the
x86-64 machines seen here and a miss to memory about 200. The proxy ignores
out-of-order overlap, prefetching and the op cache, so it only says which way a change
that trades instructions for misses goes; the wall clock (`benches/alternate.py
--paired`) has the last word where it can resolve the difference.
"""
import argparse
import os
import subprocess
import sys
import tempfile


def totals(path):
    """The event totals of a cachegrind output file, and the caches it describes."""
    names, total, caches = None, None, []
    with open(path) as f:
        for line in f:
            if line.startswith("desc:"):
                caches.append(" ".join(line[5:].split()))
            elif line.startswith("events:"):
                names = line.split()[1:]
            elif line.startswith("summary:"):
                total = [int(x) for x in line.split()[1:]]
    if names is None or total is None:
        sys.exit(f"{path}: no events/summary line (not a cachegrind output?)")
    return dict(zip(names, total)), caches


def run(binary, a, out_dir):
    """Cachegrind's totals for one render by `binary`, and the caches it simulated."""
    out = os.path.join(out_dir, os.path.basename(binary) + ".cg")
    exr = os.path.join(out_dir, "render.exr")
    cmd = [
        "valgrind", "--tool=cachegrind", "--cache-sim=yes",
        f"--cachegrind-out-file={out}",
        binary, "render", a.scene, "--res", a.res, "--spp", str(a.spp), *a.passes,
        "--threads", "1", "--rays", a.rays, "--max-depth", str(a.max_depth), "-o", exr,
    ]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{p.stderr[-2000:]}")
    return totals(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="scenes/cornell-box.toml")
    ap.add_argument("--res", default="64x64")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--pass-spp", type=int, default=None,
                    help="samples per pixel per pass (default: --spp, one pass)")
    ap.add_argument("--rays", default="packet")
    ap.add_argument("--max-depth", type=int, default=-1)
    ap.add_argument("bins", nargs="+")
    a = ap.parse_args()
    w, h = (int(x) for x in a.res.split("x"))
    samples = w * h * a.spp
    new = all("--pass-spp" in subprocess.run([b, "render", "--help"], capture_output=True,
                                             text=True).stdout for b in a.bins)
    pass_spp = (a.pass_spp or a.spp) if new else 1
    if a.pass_spp and not new:
        sys.exit("--pass-spp: a binary does not have it (it predates stop 50)")
    a.passes = ["--pass-spp", str(pass_spp)] if new else []
    print(f"{a.scene} {a.res}, {a.spp} spp in passes of {pass_spp}, --rays {a.rays}, "
          f"--max-depth {a.max_depth}, 1 thread; per pixel sample ({samples} samples), "
          "whole process")
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for b in a.bins:
            t, caches = run(b, a, d)
            ir = t["Ir"]
            l1 = t["I1mr"], t["D1mr"] + t["D1mw"]
            ll = t["ILmr"] + t["DLmr"] + t["DLmw"]
            proxy = ir + 12 * sum(l1) + 200 * ll
            rows.append((b, ir, *l1, ll, proxy))
    print("simulated: " + "; ".join(caches))
    print(f"{'Ir':>9} {'I1':>7} {'D1':>7} {'LL':>6} {'proxy':>9} {'vs 1st':>7}  binary")
    for b, ir, i1, d1, ll, proxy in rows:
        r = proxy / rows[0][5]
        print(f"{ir / samples:9.1f} {i1 / samples:7.2f} {d1 / samples:7.2f} "
              f"{ll / samples:6.3f} {proxy / samples:9.1f} {r:7.3f}  {b}")


if __name__ == "__main__":
    main()
