#!/usr/bin/env python3
"""The estimator's instructions per pixel sample by the source code they come from,
through inlining: each executed instruction of a callgrind run (recorded as for
`benches/opmix.py`) is charged to a source location found with `addr2line -i`.

    python3 benches/bysource.py BIN CGOUT SAMPLES [--by file|line|step] [--event E] [N]

--by file  the innermost file of this repository under src/ outside src/simd/ (a light
           sample's arithmetic counts for light.rs, not for the SIMD types it uses); the
           table "Where width 4 still costs more than width 1" in docs/packets.md
--by line  the same, file and line
--by step  the line of src/integrator/ it was inlined into (which part of the step)
--by object  the object file (the stokes binary, libembree3.so, libc, ...): Embree's
           share; BIN is then only named, not read

--event E  count another of the run's events instead of instructions (Ir), e.g. Bcm,
           mispredicted conditional branches, from a run with `--branch-sim=yes`

SAMPLES is the run's pixel samples (64 × 64 × 16 = 65536 for the runs in docs/packets.md). The
binary must carry line tables (the release profile's `debug = 1`).
"""
import collections
import re
import subprocess
import sys



def self_costs(out, event):
    """(object file, instruction address, self cost of `event`) for every cost line of a
    callgrind output recorded with `--dump-instr=yes`: lines after a `calls=` line are
    the callee's inclusive cost and are skipped, and compressed names (`ob=(3) /path`,
    then `ob=(3)`) are expanded, so `--compress-strings` may be on or off."""
    names = {}
    col, npos, current, after_call = None, 1, None, False

    def name(spec):
        m = re.match(r"\((\d+)\)\s*(.*)", spec.strip())
        if not m:
            return spec.strip()
        if m[2]:
            names[m[1]] = m[2]
        return names.get(m[1], m[1])

    with open(out) as f:
        for line in f:
            if line.startswith("positions:"):
                npos = len(line.split()) - 1
            elif line.startswith("events:"):
                events = line.split()[1:]
                if event not in events:
                    sys.exit(f"{out} has no event {event} (it has {' '.join(events)})")
                col = npos + events.index(event)
            elif line.startswith("ob="):
                current = name(line[3:])
            elif line.startswith("cob="):
                name(line[4:])
            elif line.startswith("calls="):
                after_call = True
            elif line.startswith("0x"):
                if after_call:
                    after_call = False
                    continue
                p = line.split()
                if col is not None and len(p) > col:
                    yield current, int(p[0], 16), int(p[col])


def costs(binary, out, event):
    """Self cost of `event` per instruction address in `binary` (`opmix.py` uses it too)."""
    name = binary.rsplit("/", 1)[-1]
    per = collections.Counter()
    for obj, addr, cost in self_costs(out, event):
        if obj is None or obj.endswith(name):
            per[addr] += cost
    return per


def object_costs(out, event):
    """Self cost of `event` per object file (`ob=`), by its file name."""
    per = collections.Counter()
    for obj, _, cost in self_costs(out, event):
        per[(obj or "?").rsplit("/", 1)[-1]] += cost
    return per


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
    event = args[args.index("--event") + 1] if "--event" in args else "Ir"
    if by == "object":
        totals = object_costs(out, event)
        print(f"total {sum(totals.values()) / samples:.1f} {event} per sample")
        for k, cost in totals.most_common(top):
            print(f"{cost / samples:8.1f}  {k}")
        return
    per = costs(binary, out, event)
    if not per:
        sys.exit(f"{out} holds no instructions of {binary}: record it with this binary")
    chains = inline_chains(binary, sorted(per))
    root = build_root(chains)
    totals = collections.Counter()
    for addr, cost in per.items():
        totals[key(chains.get(addr, []), by, root)] += cost
    print(f"total {sum(totals.values()) / samples:.1f} {event} per sample")
    for k, cost in totals.most_common(top):
        print(f"{cost / samples:8.1f}  {k}")


if __name__ == "__main__":
    main()
