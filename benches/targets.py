#!/usr/bin/env python3
"""The table of where issue 14's speed targets stand, from the files benches/targets.sh
writes in OUT (a part that did not run is reported as "not measured"):

    python3 benches/targets.py OUT

Prints markdown: the CPU, one row per target (goal, what was measured, whether it is
reached), then the paired packet / single cells of part 1 with their quartiles.

The reading rule, for a shared host whose load moves a ratio by ±10–20 % from run to run:
- a figure measured as paired repetitions (packet / single, two threads / one, the
  Embree limit's paired fractions) is reached when its lower quartile is at the goal,
  missed when its upper quartile is below it, and "within noise" between the two;
- a figure measured in rounds (Mitsuba) is reached when every round is, missed when
  none is, and within noise otherwise;
- a single figure (fluorescence's cost, and the Embree limit of a binary that wrote no
  pairs) is read as it stands.
A median alone would make a noisy row pass or fail from run to run with the same code.
"""
import json
import os
import re
import statistics
import sys


def load_json(path):
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def lines(path):
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return f.read().splitlines()


def depth_name(d):
    return "unbounded" if d < 0 else f"depth {d}"


def render_cells(out):
    """(scene, threads, depth, rays) -> the bench render result, for part 1's runs."""
    cells = {}
    for scene in ("cornell-box", "sphere-100k"):
        d = load_json(os.path.join(out, f"render-{scene}.json"))
        if d is None:
            continue
        for r in d["results"]:
            cells[(scene, r["threads"], r["max_depth"], r["rays"])] = r
    return cells


YES, NOISE, NO = "yes", "within noise", "no"


def paired_verdict(ratio, goal):
    """A paired figure (median and quartiles) against a goal it must reach or exceed."""
    if ratio["q1"] >= goal:
        return YES
    return NO if ratio["q3"] < goal else NOISE


def rounds_verdict(values, goal):
    """Figures of separate rounds against a goal each must reach or exceed."""
    reached = sum(x >= goal for x in values)
    return YES if reached == len(values) else NO if reached == 0 else NOISE


def combined(verdicts):
    """A row made of several figures: reached if all are, missed if any is."""
    if NO in verdicts:
        return NO
    return NOISE if NOISE in verdicts else YES


def speedup_row(cells):
    ratios = [
        (k, r["vs_single"]) for k, r in cells.items() if k[3] == "packet" and r.get("vs_single")
    ]
    if not ratios:
        return "not measured"
    low = min(ratios, key=lambda kr: kr[1]["median"])
    high = max(ratios, key=lambda kr: kr[1]["median"])
    verdicts = [paired_verdict(v, 1.6) for _, v in ratios]
    name = lambda k: f"{k[0]} {k[1]}T {depth_name(k[2])}"
    return (
        f"paired medians {low[1]['median']:.2f}× ({name(low[0])}) to "
        f"{high[1]['median']:.2f}× ({name(high[0])}); of {len(ratios)} cells, "
        f"{verdicts.count(YES)} reached, {verdicts.count(NOISE)} within noise, "
        f"{verdicts.count(NO)} missed (quartiles against 1.6×)",
        combined(verdicts),
    )


def threads_row(out):
    d = load_json(os.path.join(out, "threads-sphere-100k.json"))
    if d is None:
        return "not measured"
    got = {
        r["rays"]: r["vs_fewest_threads"]
        for r in d["results"]
        if r["threads"] == 2 and r.get("vs_fewest_threads")
    }
    text = ", ".join(
        f"{rays} {v['median']:.2f}× ({v['q1']:.2f}–{v['q3']:.2f})" for rays, v in sorted(got.items())
    )
    return (
        f"paired medians (quartiles): {text}",
        combined([paired_verdict(v, 1.85) for v in got.values()]),
    )


def limit_row(out):
    got = {}
    for rays in ("packet", "single"):
        d = load_json(os.path.join(out, f"limit-cornell-box-{rays}.json"))
        if d is not None:
            got[rays] = d
    if not got:
        return "not measured"
    def paired(d):
        p = d.get("fraction_paired")
        return f", paired {p['median']:.2f} ({p['q1']:.2f}–{p['q3']:.2f})" if p else ""

    text = "; ".join(
        f"{rays} {d['fraction']:.2f}{paired(d)} (render {d['render_samples_per_second'] / 1e6:.3f}, "
        f"Embree alone {d['embree_samples_per_second'] / 1e6:.3f} M samples/s)"
        for rays, d in got.items()
    )
    packet = got.get("packet")
    if packet is None:
        return text, NO
    if "fraction_paired" in packet:
        return text, paired_verdict(packet["fraction_paired"], 0.6)
    return text, YES if packet["fraction"] >= 0.6 else NO


def mitsuba_rows(out):
    text = lines(os.path.join(out, "mitsuba.txt"))
    if text is None or not any(l.startswith("mitsuba ") for l in text):
        return "not measured", "not measured"
    rounds, current = [], {}
    for l in text:
        m = re.match(r"(stokes|mitsuba) (\S+) ([0-9.]+) M samples/s", l)
        if not m:
            continue
        key = f"{m[1]} {m[2]}"
        if key in current:
            rounds.append(current)
            current = {}
        current[key] = float(m[3])
    rounds.append(current)

    def row(variant, goal):
        rs = [r["stokes packet"] / r[f"mitsuba {variant}"] for r in rounds
              if "stokes packet" in r and f"mitsuba {variant}" in r]
        if not rs:
            return "not measured"
        ms = [r[f"mitsuba {variant}"] for r in rounds if f"mitsuba {variant}" in r]
        ps = [r["stokes packet"] for r in rounds if "stokes packet" in r]
        return (
            f"{', '.join(f'{x:.2f}×' for x in rs)} in {len(rs)} rounds (stokes packet "
            f"{min(ps):.2f}–{max(ps):.2f}, `{variant}` {min(ms):.2f}–{max(ms):.2f} M samples/s)",
            rounds_verdict(rs, goal),
        )

    return row("llvm_ad_spectral", 1.5), row("scalar_spectral", 3.0)


def fluorescence_row(out):
    text = lines(os.path.join(out, "fluorescence-cost.txt"))
    if text is None:
        return "not measured"
    for l in text:
        m = re.match(r"cost per sample with dyes / without: ([0-9.]+)", l)
        if m:
            x = float(m[1])
            return f"{x:.3f}× (six alternating rounds)", YES if x <= 1.3 else NO
    return "not measured"


def instructions_row(out):
    """Part 5's counts: the new build's, and with BASE set each figure's change from the
    base build counted in the same run (builds of other runs differ by a few tenths of a
    per cent with the same renderer code, so only side-by-side counts make a change)."""
    text = lines(os.path.join(out, "instructions.txt"))
    if text is None:
        return "not measured"
    new, base, base_name = {}, {}, None
    # Files of stop 50 on name their measure; older ones used passes of 1 spp.
    measure = "9 spp minus 1 spp in passes of 1"
    for l in text:
        if l.startswith("measured as: "):
            measure = l[len("measured as: "):]
            if measure.startswith("one pass of 8 spp"):
                measure = "16 spp minus 8 spp in passes of 8"
            else:
                measure = "9 spp minus 1 spp in passes of 1"
            continue
        m = re.match(r"(\S+) scenes/(\S+)\.toml (\S+): (\d+) instructions per sample", l)
        if not m:
            continue
        if m[1].startswith("base:"):
            base_name = m[1][len("base:"):]
            base[(m[2], m[3])] = int(m[4])
        else:
            new[(m[2], m[3])] = int(m[4])
    if not new:
        return "not measured"

    def figure(key, n):
        b = base.get(key)
        change = f" ({b:,} → {n:,}, {100 * (n - b) / b:+.1f} %)" if b else ""
        return f"{key[0]} {key[1]} {n:,}{change}"

    against = f"; changes from {base_name}, counted in the same run" if base_name else ""
    note = f" (callgrind, 64², {measure}, 1 thread{against})"
    return "; ".join(figure(k, n) for k, n in new.items()) + note, None


def cell(row):
    if isinstance(row, str):
        return row, "–"
    text, verdict = row
    return text, "–" if verdict is None else ("**yes**" if verdict == YES else verdict)


def main():
    out = sys.argv[1]
    machine = next(
        (d["machine"] for name in ("render-cornell-box", "render-sphere-100k",
                                   "threads-sphere-100k", "limit-cornell-box-packet")
         if (d := load_json(os.path.join(out, f"{name}.json"))) and "machine" in d),
        None,
    )
    if machine:
        family = f" (family {machine['family']}, model {machine['model']})" if machine["family"] is not None else ""
        print(f"CPU: {machine['cpu']}{family}, {machine['logical_cpus']} logical CPUs, "
              f"Embree kernels up to {machine['embree_isa']}\n")
    else:
        cpu = lines(os.path.join(out, "cpu.txt"))
        print(f"CPU: {cpu[0].split(':', 1)[1].strip() if cpu else 'unknown'}\n")
    cells = render_cells(out)
    llvm, scalar = mitsuba_rows(out)
    rows = [
        ("packet / single, depth 3 and unbounded, both scenes, 1 and 2 threads", "≥ 1.6×", speedup_row(cells)),
        ("Cornell box 256², 64 spp, depth 6, 2 threads: against Mitsuba 3 `llvm_ad_spectral`", "≥ 1.5×", llvm),
        ("the same against `scalar_spectral`", "≥ 3×", scalar),
        ("fraction of the Embree limit, Cornell box 256², 1 thread", "≥ 0.6 (packet)", limit_row(out)),
        ("fluorescent surfaces against the same scene without dyes, cost per sample", "≤ 1.3×", fluorescence_row(out)),
        ("2 threads / 1 thread at depth 1, 1024² sphere", "≥ 1.85×", threads_row(out)),
        ("callgrind instructions per sample", "reported", instructions_row(out)),
    ]
    print("| target | goal | measured | reached |")
    print("| --- | --- | --- | --- |")
    for name, goal, row in rows:
        text, ok = cell(row)
        print(f"| {name} | {goal} | {text} | {ok} |")
    if not cells:
        return
    print("\n| scene | threads | max depth | packet / single: median (quartiles) | packet8 / single | single, packet (M samples/s, medians) |")
    print("| --- | --- | --- | --- | --- | --- |")
    keys = sorted({k[:3] for k in cells}, key=lambda k: (k[0], k[1], k[2] < 0, k[2]))
    for scene, threads, depth in keys:
        def ratio(rays):
            r = cells.get((scene, threads, depth, rays))
            v = r and r.get("vs_single")
            return f"{v['median']:.2f}× ({v['q1']:.2f}–{v['q3']:.2f})" if v else "–"
        rate = lambda rays: cells[(scene, threads, depth, rays)]["samples_per_second"] / 1e6
        print(
            f"| {scene} | {threads} | {depth_name(depth)} | {ratio('packet')} | "
            f"{ratio('packet8')} | {rate('single'):.3f}, {rate('packet'):.3f} |"
        )
    spread = [
        r["vs_single"]["q3"] - r["vs_single"]["q1"]
        for k, r in cells.items() if k[3] == "packet" and r.get("vs_single")
    ]
    if spread:
        print(f"\nMedian interquartile range of packet / single: {statistics.median(spread):.2f}")


if __name__ == "__main__":
    main()
