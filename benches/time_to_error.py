#!/usr/bin/env python3
"""Time for each method to reach a fixed relative error, from `stokes converge` CSVs.

For every docs/results/<scene>/convergence.csv given, the target is the largest final
relMSE among the methods whose fitted slope (ln RMSE on ln spp, spp >= 4) is below -0.4,
i.e. an error every unbiased method reached within its budget; each method's time to
reach it is interpolated log-log between checkpoints ("never" if it did not within its
budget). The region is the scene's first region of interest, else the whole image.
Prints one Markdown table per scene.

    python3 benches/time_to_error.py docs/results/*/convergence.csv

With `--pairs wavelengths=uniform:visible` (any axis column of the CSV, two of its values)
it instead pairs every method with the one that differs only on that axis and prints how
many times faster the second reaches the pair's own target, the larger of the two final
relMSEs (so both reached it), interpolated as above; and the same ratio from the final
checkpoints' efficiency 1/(relMSE x seconds), which uses all the samples.

    python3 benches/time_to_error.py --pairs wavelengths=uniform:visible docs/results/*/convergence.csv
"""
import csv, math, os, sys
from collections import defaultdict


def slope(pts):
    pts = [(math.log(s), math.log(e)) for s, _, e in pts if s >= 4 and e > 0]
    if len(pts) < 2:
        return float("nan")
    n = len(pts)
    mx = sum(p[0] for p in pts) / n
    my = sum(p[1] for p in pts) / n
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    return sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx


def time_to(pts, target):
    prev = None
    for spp, sec, err in pts:
        if err <= target:
            if prev is None or prev[2] <= 0 or err <= 0 or prev[1] <= 0:
                return sec
            # log-log interpolation between the two checkpoints
            f = (math.log(prev[2]) - math.log(target)) / (math.log(prev[2]) - math.log(err))
            return math.exp(math.log(prev[1]) + f * (math.log(sec) - math.log(prev[1])))
        prev = (spp, sec, err)
    return None


def region_of(rows):
    regions = [r["region"] for r in rows if r["region"] != "image"]
    return regions[0] if regions else "image"


def pairs(paths, spec):
    axis, values = spec.split("=")
    a, b = values.split(":")
    for path in paths:
        rows = list(csv.DictReader(open(path)))
        if axis not in rows[0]:
            sys.exit(f"{path}: no column {axis!r}")
        region = region_of(rows)
        curves = defaultdict(list)
        keys = {}
        for r in rows:
            if r["region"] != region or r[axis] not in (a, b):
                continue
            key = tuple((k, v) for k, v in r.items() if k in AXES and k != axis)
            curves[(key, r[axis])].append((int(r["spp"]), float(r["seconds"]), float(r["relmse"])))
            keys[(key, r[axis])] = r["method"]
        scene = os.path.basename(os.path.dirname(path))
        print(f"\n**{scene}** (region `{region}`): {b} against {a}\n")
        print(f"| method ({axis} {a} → {b}) | target relMSE | {a} (s) | {b} (s) | speed-up | efficiency ratio |")
        print("| --- | --- | --- | --- | --- | --- |")
        for (key, v), ca in curves.items():
            if v != a or (key, b) not in curves:
                continue
            cb = curves[(key, b)]
            target = max(ca[-1][2], cb[-1][2])
            ta, tb = time_to(ca, target), time_to(cb, target)
            eff = (ca[-1][2] * ca[-1][1]) / (cb[-1][2] * cb[-1][1])
            name = keys[(key, a)].replace(f"-{a}-", f"-{a}|{b}-")
            fmt = lambda t: "never" if t is None else f"{t:.2f}"
            ratio = f"{ta / tb:.2f}x" if ta and tb else "—"
            print(f"| {name} | {target:.3g} | {fmt(ta)} | {fmt(tb)} | {ratio} | {eff:.2f}x |")


AXES = ("spectral", "wavelengths", "shifting", "tracking", "rays", "dispersion")


def main(paths):
    if paths and paths[0] == "--pairs":
        return pairs(paths[2:], paths[1])
    for path in paths:
        rows = list(csv.DictReader(open(path)))
        region = region_of(rows)
        curves = defaultdict(list)
        for r in rows:
            if r["region"] == region:
                curves[r["method"]].append((int(r["spp"]), float(r["seconds"]), float(r["relmse"])))
        rmse_curves = defaultdict(list)
        for r in rows:
            if r["region"] == region:
                rmse_curves[r["method"]].append((int(r["spp"]), float(r["seconds"]), float(r["rmse"])))
        slopes = {m: slope(c) for m, c in rmse_curves.items()}
        unbiased = [m for m in curves if slopes[m] < -0.4]
        target = max(curves[m][-1][2] for m in unbiased)
        scene = os.path.basename(os.path.dirname(path))
        print(f"\n**{scene}** (region `{region}`; target relMSE {target:.3g})\n")
        print("| method | slope | final spp | final relMSE | seconds to target |")
        print("| --- | --- | --- | --- | --- |")
        for m, c in sorted(curves.items(), key=lambda kv: (time_to(kv[1], target) or 1e9)):
            t = time_to(c, target)
            print(f"| {m} | {slopes[m]:.2f} | {c[-1][0]} | {c[-1][2]:.3g} | "
                  f"{'never (in ' + format(c[-1][1], '.0f') + ' s)' if t is None else format(t, '.2f')} |")


if __name__ == "__main__":
    main(sys.argv[1:])
