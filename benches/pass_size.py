#!/usr/bin/env python3
"""What larger passes (`stokes render --pass-spp`) buy on the wall clock: renders of the
same image in passes of 1 spp and in one pass, back to back, in alternating order, and
the median and quartiles of each pair's speed ratio (one pass / passes of 1).

    python3 benches/pass_size.py [--rounds 16] [--res 256x256] [--spp 64] [--max-depth 6]
        [--threads 2] [--rays packet] [--scene scenes/cornell-box.toml] [--bin B]

Rates are the renders' own `samples_per_second` (`--stats-json`: rendering only, scene
loading and output not counted). The figures in docs/packets.md ("Passes of one sample
per pixel, counted") come from it.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile


def rate(a, pass_spp, d):
    stats = os.path.join(d, "stats.json")
    cmd = [a.bin, "render", a.scene, "--res", a.res, "--spp", str(a.spp), "--max-depth",
           str(a.max_depth), "--threads", str(a.threads), "--rays", a.rays, "--pass-spp",
           str(pass_spp), "-o", os.path.join(d, "out.exr"), "--stats-json", stats]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{p.stderr[-2000:]}")
    with open(stats) as f:
        return json.load(f)["samples_per_second"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=16)
    ap.add_argument("--res", default="256x256")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-depth", type=int, default=6)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rays", default="packet")
    ap.add_argument("--scene", default="scenes/cornell-box.toml")
    ap.add_argument("--bin", default="target/release/stokes")
    a = ap.parse_args()
    ratios = []
    with tempfile.TemporaryDirectory() as d:
        for r in range(a.rounds):
            order = [1, a.spp] if r % 2 == 0 else [a.spp, 1]
            got = {p: rate(a, p, d) for p in order}
            ratios.append(got[a.spp] / got[1])
    q1, _, q3 = statistics.quantiles(ratios, n=4)
    print(f"{a.scene} {a.res}, {a.spp} spp, depth {a.max_depth}, {a.threads} thread(s), "
          f"--rays {a.rays}: one pass / passes of 1 spp, paired median "
          f"{statistics.median(ratios):.3f} (quartiles {q1:.3f}-{q3:.3f}), {a.rounds} rounds")


if __name__ == "__main__":
    main()
