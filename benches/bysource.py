#!/usr/bin/env python3
"""The estimator's instructions per pixel sample by the source code they come from,
through inlining: each executed instruction of a callgrind run (recorded as for
`benches/opmix.py`) is charged to a source location found with `addr2line -i`.

    python3 benches/bysource.py BIN CGOUT SAMPLES [--by file|line|step] [N]

--by file  the innermost file of this repository under src/ outside src/simd/ (a light
           sample's arithmetic counts for light.rs, not for the SIMD types it uses); the
           README's table "Where width 4 still costs more than width 1"
--by line  the same, file and line
--by step  the line of src/integrator/ it was inlined into (which part of the step)

SAMPLES is the run's pixel samples (64 × 64 × 16 = 65536 for the README's runs). The
binary must carry line tables (the release profile's `debug = 1`).
"""
import collections
import re
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import opmix  # noqa: E402


def inline_chains(binary, addrs):
    """For each address, its source locations from the innermost inlined frame out."""
    out = subprocess.run(
        ["addr2line", "-e", binary, "-i", "-a"] + [hex(a) for a in addrs],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    chains, current = {}, None
    for line in out.splitlines():
        if line.startswith("0x"):
            current = chains.setdefault(int(line, 16), [])
        elif current is not None:
            current.append(line.split(" (")[0])
    return chains


def build_root(chains):
    """The directory the binary was built from: the one holding `src/integrator/`."""
    for chain in chains.values():
        for loc in chain:
            m = re.match(r"(.*)/src/integrator/", loc)
            if m:
                return m.group(1) + "/"
    sys.exit("no instruction comes from src/integrator/: is this the stokes binary?")


def key(chain, by, root):
    # This repository's files as `src/...:line`; the standard library's and the crates'
    # keep their absolute paths, so they never pass for ours.
    locations = [loc[len(root):] if loc.startswith(root) else loc for loc in chain] or ["?"]
    if by == "step":
        return next((loc for loc in locations if loc.startswith("src/integrator/")), "other")
    ours = next(
        (loc for loc in locations if loc.startswith("src/") and not loc.startswith("src/simd/")),
        locations[0],
    )
    return ours.split(":")[0] if by == "file" else ours


def main():
    args = sys.argv[1:]
    if len(args) < 3:
        sys.exit(__doc__)
    binary, out, samples = args[0], args[1], float(args[2])
    by = args[args.index("--by") + 1] if "--by" in args else "file"
    top = next((int(a) for a in args[3:] if a.isdigit()), 25)
    per = opmix.costs(binary, out)
    if not per:
        sys.exit(f"{out} holds no instructions of {binary}: record it with this binary")
    chains = inline_chains(binary, sorted(per))
    root = build_root(chains)
    totals = collections.Counter()
    for addr, cost in per.items():
        totals[key(chains.get(addr, []), by, root)] += cost
    print(f"total {sum(totals.values()) / samples:.0f} instructions per sample")
    for k, cost in totals.most_common(top):
        print(f"{cost / samples:8.0f}  {k}")


if __name__ == "__main__":
    main()
