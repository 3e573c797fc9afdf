#!/usr/bin/env bash
# Peak resident memory (README, "Memory") for the 100k-triangle scene and a 1M-triangle
# sphere, generated at load time and read from a 37 MB OBJ written here.
# Needs /usr/bin/time (Debian package `time`) and a release build.
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/stokes
T=${TMPDIR:-/tmp}/stokes-memory
mkdir -p "$T"
[ -x /usr/bin/time ] || { echo "install /usr/bin/time: apt-get install -y time" >&2; exit 1; }
sed 's/stacks = 160/stacks = 708/; s/slices = 318/slices = 708/' scenes/sphere-100k.toml > "$T/sphere-1m.toml"
python3 - "$T/sphere-1m.obj" <<'PY'
import math, sys
st, sl, r, c = 708, 708, 0.9, (0.0, 1.0, 0.0)
with open(sys.argv[1], "w") as f:
    f.write("o sphere\n")
    f.write(f"v {c[0]} {c[1] + r} {c[2]}\n")
    for i in range(1, st):
        th = math.pi * i / st
        for j in range(sl):
            ph = 2 * math.pi * j / sl
            f.write(f"v {c[0] + r * math.sin(th) * math.cos(ph):.6f} {c[1] + r * math.cos(th):.6f} {c[2] + r * math.sin(th) * math.sin(ph):.6f}\n")
    f.write(f"v {c[0]} {c[1] - r} {c[2]}\n")
    ring = lambda i, j: 2 + (i - 1) * sl + (j % sl)
    south = 2 + (st - 1) * sl
    for j in range(sl):
        f.write(f"f 1 {ring(1, j + 1)} {ring(1, j)}\n")
    for i in range(1, st - 1):
        for j in range(sl):
            a, b, cc, d = ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)
            f.write(f"f {a} {b} {d}\nf {a} {d} {cc}\n")
    for j in range(sl):
        f.write(f"f {south} {ring(st - 1, j)} {ring(st - 1, j + 1)}\n")
PY
python3 - "$T/sphere-1m.toml" "$T/sphere-1m-obj.toml" "$T/sphere-1m.obj" <<'PY'
import re, sys
s = open(sys.argv[1]).read()
s = re.sub(r'type = "sphere"\ncenter = \[0, 1, 0\]\nradius = 0.9\nstacks = 708\nslices = 708',
           f'type = "obj"\nfile = "{sys.argv[3]}"', s)
open(sys.argv[2], "w").write(s)
PY
peak() { /usr/bin/time -f "%M" "$@" 2>&1 >/dev/null | tail -1; }
printf "| scene | load only (KiB) | render 256², 1 spp | render 1024², 4 spp |\n| --- | --- | --- | --- |\n"
for sc in scenes/sphere-100k.toml "$T/sphere-1m.toml" "$T/sphere-1m-obj.toml"; do
    a=$(peak $S info "$sc")
    b=$(peak $S render "$sc" --res 256x256 --spp 1 -o "$T/o.exr")
    c=$(peak $S render "$sc" --res 1024x1024 --spp 4 -o "$T/o.exr")
    echo "| $(basename "$sc") | $a | $b | $c |"
done
