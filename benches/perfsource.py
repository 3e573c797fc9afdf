#!/usr/bin/env python3
"""Where a render's *time* goes, by the source code it comes from through inlining: each
sample of a `perf record -e cpu-clock` run is charged to a source location found with
`addr2line -i`, as `benches/bysource.py` charges instructions. Instruction counts miss
what waits (a division's latency, a mispredicted branch, a cache miss); time shows it.
Use it where `perf stat` reports no hardware counters, as on these machines.

    perf record -e cpu-clock -F 20000 -o PERF.data BIN render SCENE ...
    python3 benches/perfsource.py BIN PERF.data [--by file|line] [N]

--by file  the innermost file of this repository under src/ outside src/simd/ (default)
--by line  the same, file and line

Prints the share of all samples that Embree, the kernel and other libraries took, then
the N largest source locations of BIN. The binary must carry line tables (the release
profile's `debug = 1`) and be the one perf recorded.
"""
import collections
import re
import subprocess
import sys


def exec_segment(binary):
    """(file offset, virtual address) of the binary's executable LOAD segment."""
    out = subprocess.run(["readelf", "-lW", binary], capture_output=True, text=True, check=True)
    for line in out.stdout.splitlines():
        f = line.split()
        if f and f[0] == "LOAD" and "E" in f[6:-1]:
            return int(f[1], 16), int(f[2], 16)
    sys.exit(f"{binary}: no executable LOAD segment")


def samples(binary, data):
    """Counts of samples by DSO name, and by virtual address inside `binary`."""
    name = binary.rsplit("/", 1)[-1]
    out = subprocess.run(
        ["perf", "script", "-i", data, "-F", "ip,dso", "--show-mmap-events"],
        capture_output=True, text=True, check=True,
    ).stdout
    seg_off, seg_vaddr = exec_segment(binary)
    mmap = re.compile(r"\[(0x[0-9a-f]+)\((0x[0-9a-f]+)\) @ (0x[0-9a-f]+|0) .*\]: r-xp (\S+)")
    base = None
    by_dso, by_addr = collections.Counter(), collections.Counter()
    for line in out.splitlines():
        if "PERF_RECORD_MMAP" in line:
            m = mmap.search(line)
            if m and m.group(4).endswith("/" + name):
                start, pgoff = int(m.group(1), 16), int(m.group(3), 16)
                base = (start, pgoff)
            continue
        f = line.split()
        if len(f) < 2:
            continue
        dso = f[1].strip("()").rsplit("/", 1)[-1]
        by_dso[dso] += 1
        if dso == name and base is not None:
            start, pgoff = base
            by_addr[int(f[0], 16) - start + pgoff - seg_off + seg_vaddr] += 1
    if base is None:
        sys.exit(f"{data} holds no executable mapping of {name}")
    return by_dso, by_addr


def main():
    args = sys.argv[1:]
    by = "file"
    if "--by" in args:
        i = args.index("--by")
        by = args[i + 1]
        del args[i : i + 2]
    if len(args) < 2 or by not in ("file", "line"):
        sys.exit(__doc__)
    binary, data = args[0], args[1]
    top = int(args[2]) if len(args) > 2 else 25
    by_dso, by_addr = samples(binary, data)
    total = sum(by_dso.values())
    name = binary.rsplit("/", 1)[-1]
    print(f"{total} samples")
    for dso, n in by_dso.most_common(6):
        print(f"{100 * n / total:6.2f}%  {dso}")
    addrs = sorted(by_addr)
    out = subprocess.run(
        ["addr2line", "-e", binary, "-i", "-a"] + [hex(a) for a in addrs],
        capture_output=True, text=True, check=True,
    ).stdout.splitlines()
    where = collections.Counter()
    addr, chain = None, []

    def charge():
        if addr is None:
            return
        locs = [c.split(" ")[0] for c in chain if "/src/" in c and "/src/simd/" not in c]
        locs = [c[c.index("src/"):] for c in locs if "/.cargo/" not in c and "/rustc/" not in c]
        key = locs[0] if locs else "other"
        where[key if by == "line" else key.split(":")[0]] += by_addr[addr]

    for line in out:
        if line.startswith("0x"):
            charge()
            addr, chain = int(line, 16), []
        else:
            chain.append(line)
    charge()
    print(f"-- {name} by {by}")
    for key, n in where.most_common(top):
        print(f"{100 * n / total:6.2f}%  {key}")


if __name__ == "__main__":
    main()
