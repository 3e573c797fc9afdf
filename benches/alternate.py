#!/usr/bin/env python3
"""Two or more `stokes` binaries against each other on the wall clock, in alternating
rounds: a shared machine's load drifts over minutes, so one run of each cannot separate
changes of a few per cent, but the spread of several interleaved rounds can.

    python3 benches/alternate.py [--rounds 8] [--seconds 1.5] [--depths 1,3,-1]
        [--rays single,packet] [--threads 1] SCENE BIN_A BIN_B [BIN ...]

Each round runs `BIN bench render SCENE --rays R --max-depth D --threads T --seconds S
--repetitions 1` for every binary, in turn, and reverses the order every other round.
Prints, per (depth, mode), each binary's median M samples/s, its range and its ratio
to BIN_A's median.

With --paired, each round runs every (depth, mode) on its own, the binaries back to back
(seconds apart instead of a whole set of modes apart), and the output adds, per binary,
the median and quartiles of the ratios of each pair: on a host whose load drifts within
a minute, the ratio of a pair is steadier than the ratio of medians.
"""
import argparse
import collections
import re
import statistics
import subprocess

LINE = re.compile(r"(\d+) threads, depth (-?\d+), (\w+) \(\w+\): ([\d.]+) M samples/s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=8)
    ap.add_argument("--seconds", default="1.5")
    ap.add_argument("--depths", default="1,3,-1")
    ap.add_argument("--rays", default="single,packet")
    ap.add_argument("--threads", default="1")
    ap.add_argument("--paired", action="store_true")
    ap.add_argument("scene")
    ap.add_argument("bins", nargs="+")
    a = ap.parse_args()
    if len(a.bins) < 2:
        ap.error("give at least two binaries")
    runs = collections.defaultdict(list)
    # Paired: one (depth, mode) per command; else every one of them in one command.
    sets = [(d, m) for d in a.depths.split(",") for m in a.rays.split(",")] if a.paired \
        else [(a.depths, a.rays)]
    for r in range(a.rounds):
        for depths, rays in sets:
            for b in a.bins if r % 2 == 0 else a.bins[::-1]:
                cmd = [b, "bench", "render", a.scene, "--rays", rays, "--max-depth", depths,
                       "--threads", a.threads, "--seconds", a.seconds, "--repetitions", "1"]
                p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                   text=True)
                if p.returncode != 0:
                    raise SystemExit(f"{' '.join(cmd)} failed:\n{p.stdout}")
                for m in LINE.finditer(p.stdout):
                    runs[(b, m.group(1), m.group(2), m.group(3))].append(float(m.group(4)))
    print(f"{a.scene}: {a.rounds} alternating rounds of {a.seconds} s; "
          "median M samples/s (range), ratio to the first binary")
    keys = sorted({k[1:] for k in runs}, key=lambda k: (int(k[0]), int(k[1]) % 1000, k[2]))
    for threads, depth, mode in keys:
        base = statistics.median(runs[(a.bins[0], threads, depth, mode)])
        cells = []
        for b in a.bins:
            v = runs[(b, threads, depth, mode)]
            med = statistics.median(v)
            cell = f"{med:.3f} ({min(v):.2f}-{max(v):.2f}) x{med / base:.3f}"
            if a.paired and b != a.bins[0] and len(v) > 1:
                # Round k of every binary ran next to round k of the first.
                ratios = [x / y for x, y in zip(v, runs[(a.bins[0], threads, depth, mode)])]
                q = statistics.quantiles(ratios, n=4)
                cell += f", pairs x{q[1]:.3f} ({q[0]:.3f}-{q[2]:.3f})"
            cells.append(cell)
        print(f"{threads} thr, depth {depth:>3}, {mode:>8}: " + " | ".join(cells))
    print("binaries: " + " | ".join(a.bins))


if __name__ == "__main__":
    main()
