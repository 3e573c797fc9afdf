#!/usr/bin/env bash
# The cost of a texture lookup: a diffuse quad that fills the view, lit by a point light
# (direct lighting only, --max-depth 2: one reflectance lookup per sample), rendered with
# a constant RGB reflectance, a 1024² 8-bit RGB image texture (bilinear, upsampled per
# lookup) and a procedural checkerboard, alternating in one run so that a shared
# machine's load hits all alike. Prints samples/s of each, the extra nanoseconds per
# sample of the textured runs over the constant one (median of the rounds), callgrind's
# instructions per sample for each (independent of load; skipped without valgrind) and
# the texture's memory per texel from `stokes info`.
# Usage: benches/texture_cost.sh [ROUNDS] [RES] [SPP]
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-5}; res=${2:-256x256}; spp=${3:-32}
cargo build --release -q
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
grep -m1 'model name' /proc/cpuinfo

python3 - "$dir" <<'EOF'
import random, struct, sys, zlib
d = sys.argv[1]
w = h = 1024
rng = random.Random(1)
raw = b"".join(b"\0" + bytes(rng.randrange(40, 216) for _ in range(3 * w)) for _ in range(h))
def chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
with open(f"{d}/noise.png", "wb") as f:
    f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
scene = """[camera]
position = [0, 0, -2]
look_at = [0, 0, 0]
fov = 40
resolution = [64, 64]

[materials.plane]
type = "diffuse"
reflectance = REFLECTANCE

[[shapes]]
type = "quad"
origin = [2, -2, 0]
edge_u = [-4, 0, 0]
edge_v = [0, 4, 0]
material = "plane"

[[lights]]
type = "point"
position = [0, 0, -1]
intensity = "D65"
"""
for name, refl in [("constant", "{ rgb = [0.33, 0.5, 0.6] }"),
                   ("image", '{ texture = "noise.png" }'),
                   ("checkerboard", "{ checkerboard = [0.3, 0.6], checks = [64, 64] }")]:
    open(f"{d}/{name}.toml", "w").write(scene.replace("REFLECTANCE", refl))
EOF

kinds=(constant image checkerboard)
rate() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['samples_per_second'])" "$1"; }
declare -A extra
for i in $(seq "$rounds"); do
    line="round $i:"
    declare -A r=()
    for k in "${kinds[@]}"; do
        target/release/stokes render "$dir/$k.toml" --res "$res" --spp "$spp" --max-depth 2 \
            --threads 1 -o "$dir/$k.exr" --stats-json "$dir/$k.json" 2>/dev/null
        r[$k]=$(rate "$dir/$k.json")
        line+=$(printf ' %s %.3f M/s' "$k" "$(python3 -c "print(${r[$k]}/1e6)")")
    done
    for k in image checkerboard; do
        extra[$k]+="$(python3 -c "print(1e9 / ${r[$k]} - 1e9 / ${r[constant]})") "
    done
    echo "$line"
done
median() { tr ' ' '\n' | grep . | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
for k in image checkerboard; do
    printf 'extra cost per sample, %s over constant (median of %d rounds): %.1f ns\n' \
        "$k" "$rounds" "$(median <<<"${extra[$k]}")"
done

if command -v valgrind >/dev/null; then
    # Loading (PNG decoding, upsampling table) is not per sample: it cancels in the
    # difference of two runs, (Ir at 32x32, 8 spp - Ir at 4 spp) / 4096 samples.
    for k in "${kinds[@]}"; do
        ir=()
        for s in 4 8; do
            valgrind --tool=callgrind --callgrind-out-file="$dir/cg.$k.$s" \
                target/release/stokes render "$dir/$k.toml" --res 32x32 --spp "$s" \
                --max-depth 2 --threads 1 -o "$dir/cg.exr" >/dev/null 2>"$dir/cg.log"
            ir+=("$(grep -m1 '^summary:' "$dir/cg.$k.$s" | awk '{ print $2 }')")
        done
        printf 'instructions per sample (callgrind), %s: %d\n' "$k" $(((ir[1] - ir[0]) / 4096))
    done
fi
target/release/stokes info "$dir/image.toml" | grep '^textures'
echo "memory per texel: RGB image 12 bytes (3 x f32 linear), one-channel map 4 bytes"
