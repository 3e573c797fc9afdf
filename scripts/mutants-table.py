#!/usr/bin/env python3
"""The mutation table of docs/mutants.md from scripts/mutants.sh's outcomes.

    python3 scripts/mutants-table.py [mutants.out]

Reads <dir>/<group>/mutants.out/outcomes.json (cargo-mutants' own record) and prints, in
Markdown, one row per source file (tried, caught, missed, timed out, unviable, and the
score = (caught + timed out) / (caught + missed + timed out), a timeout counting as
detected), a row per group, the run time of each group and the list of every missed or
timed-out mutant.
"""
import json
import sys
from collections import defaultdict
from datetime import datetime
from pathlib import Path

KINDS = {
    "CaughtMutant": "caught",
    "MissedMutant": "missed",
    "Timeout": "timeout",
    "Unviable": "unviable",
}


def score(c):
    """Detected / viable, a timeout counting as detected (the mutant made a test hang
    instead of pass), as Stryker counts it."""
    tested = c["caught"] + c["missed"] + c["timeout"]
    detected = c["caught"] + c["timeout"]
    return f"{100 * detected / tested:.0f} %" if tested else "-"


def row(name, c):
    tried = sum(c[k] for k in KINDS.values())
    cells = [name, tried, c["caught"], c["missed"], c["timeout"], c["unviable"], score(c)]
    return "| " + " | ".join(str(x) for x in cells) + " |"


def seconds(d):
    """The group's wall time (0 while it is still running)."""
    if not d.get("end_time"):
        return 0.0
    # cargo-mutants writes nanoseconds and a Z; datetime takes microseconds.
    t = [datetime.fromisoformat(d[k][:26]) for k in ("start_time", "end_time")]
    return (t[1] - t[0]).total_seconds()


def main():
    root = Path(sys.argv[1] if len(sys.argv) > 1 else "mutants.out")
    groups = sorted(p.parent for p in root.glob("*/mutants.out/outcomes.json"))
    if not groups:
        sys.exit(f"{root}: no */mutants.out/outcomes.json (run scripts/mutants.sh first)")
    print("| file | tried | caught | missed | timed out | unviable | score |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    survivors, totals, times = [], defaultdict(int), []
    for g in groups:
        d = json.loads((g / "outcomes.json").read_text())
        per_file = defaultdict(lambda: defaultdict(int))
        for o in d["outcomes"]:
            m = o["scenario"]
            if not isinstance(m, dict) or "Mutant" not in m:
                continue  # the unmutated baseline
            kind = KINDS.get(o["summary"])
            if kind is None:
                continue
            per_file[m["Mutant"]["file"]][kind] += 1
            if kind in ("missed", "timeout"):
                survivors.append((kind, m["Mutant"]["name"]))
        group_total = defaultdict(int)
        for f in sorted(per_file):
            print(row(f"`{f}`", per_file[f]))
            for k, v in per_file[f].items():
                group_total[k] += v
                totals[k] += v
        name = g.parent.name
        print(row(f"**{name}**", group_total))
        times.append((name, seconds(d)))
    print(row("**all**", totals))
    print()
    print("Run time: " + ", ".join(f"{n} {s / 60:.0f} min" for n, s in times)
          + f"; {sum(s for _, s in times) / 3600:.1f} h in all.")
    print()
    for kind, name in survivors:
        print(f"- {kind}: `{name}`")


if __name__ == "__main__":
    main()
