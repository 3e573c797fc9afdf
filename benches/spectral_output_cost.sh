#!/usr/bin/env bash
# The cost of spectral output: the Cornell box rendered with RGB only and with
# --spectral-bins N (default 32), alternating in one run so that a shared machine's load
# hits both alike; prints samples/s of each, their ratio (median of the pairs) and the
# file size per bin.
# Usage: benches/spectral_output_cost.sh [BINS] [PAIRS] [RES] [SPP]
set -euo pipefail
cd "$(dirname "$0")/.."
bins=${1:-32}; pairs=${2:-5}; res=${3:-256x256}; spp=${4:-32}
cargo build --release -q
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
grep -m1 'model name' /proc/cpuinfo
rate() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['samples_per_second'])" "$1"; }
ratios=()
for i in $(seq "$pairs"); do
    target/release/stokes render scenes/cornell-box.toml --res "$res" --spp "$spp" \
        -o "$out/rgb.exr" --stats-json "$out/rgb.json" 2>/dev/null
    target/release/stokes render scenes/cornell-box.toml --res "$res" --spp "$spp" \
        --spectral-bins "$bins" -o "$out/spectral.exr" --stats-json "$out/spectral.json" 2>/dev/null
    a=$(rate "$out/rgb.json"); b=$(rate "$out/spectral.json")
    r=$(python3 -c "print($b / $a)")
    ratios+=("$r")
    printf 'pair %d: RGB %.3f M samples/s, %d bins %.3f M samples/s, ratio %.3f\n' \
        "$i" "$(python3 -c "print($a/1e6)")" "$bins" "$(python3 -c "print($b/1e6)")" "$r"
done
median=$(printf '%s\n' "${ratios[@]}" | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }')
rgb_size=$(stat -c %s "$out/rgb.exr"); spectral_size=$(stat -c %s "$out/spectral.exr")
echo "median speed with $bins bins / RGB only: $median"
echo "file: RGB $rgb_size bytes, with $bins bins $spectral_size bytes," \
    "$(( (spectral_size - rgb_size) / bins )) bytes per bin ($res, zip-compressed float)"
