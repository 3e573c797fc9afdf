#!/usr/bin/env bash
# The figures of docs/packets.md ("The SIMD estimator's first figures" and the targets
# table that ends the file), each comparison taken
# in one run (these machines are shared and noisy), and the CPU they came from:
#
#   benches/packets.sh [OUT_DIR]          # default out/packets; about 40 minutes on 2 cores
#   BASE=c5eae78 benches/packets.sh       # also instruction counts of that commit's binary
#   PARTS="5" BASE=fd54603 benches/packets.sh   # only the parts listed (numbers below)
#
# 1. stokes bench render: packet, packet8, lockstep and single rays, depths 1, 3 and
#    unbounded, 1 and 2 threads, on the Cornell box (512²) and the 100k-triangle sphere
#    (1024²); the two packet layouts against each other; every mode at depth 6 (256²).
# 2. stokes bench limit: the Cornell box's fraction of its Embree limit, packet and single.
# 3. The Cornell box at 256², 64 spp, depth 6, 2 threads against Mitsuba 3
#    (benches/mitsuba/cbox.py, scalar_spectral and llvm_ad_spectral), alternating, three
#    rounds; skipped if `import mitsuba` fails.
# 4. The fluorescent surfaces scene against the same scene with every dye removed (each
#    fluorescent_diffuse made a diffuse of its reflectance), packet rays, 2 threads, in six
#    alternating rounds.
# 5. Instructions per pixel sample (callgrind, independent of machine load) for the
#    Cornell box and the fluorescent volume, packet and single, with this binary and, if
#    BASE is set, with that commit's (built in a temporary worktree).
# 6. Where a Cornell-box sample's instructions go, by source file.
# 7. The estimator's instruction mix by kind (benches/opmix.py: moves, float arithmetic,
#    masks, branches, ...) and by the source file its inlined code comes from
#    (benches/bysource.py), Cornell box, single and packet (parts 7 and 8 are not in the
#    default set: PARTS="7 8").
# 8. Busy lanes per part of the step (the `census` build, in target/census), Cornell box
#    and fluorescent volume, packet and single.
set -euo pipefail
. "$(dirname "$0")/setup.sh" out/packets "1 2 3 4 5 6" "$@"

if part 1; then
echo "== 1. bench render"
for scene in cornell-box sphere-100k; do
    $B bench render "scenes/$scene.toml" --rays single,packet,packet8,lockstep \
        --max-depth 1,3,-1 --threads 1,2 --seconds 16 --repetitions 4 | tee "$out/render-$scene.txt"
done
# Packet layouts against each other, and the Mitsuba comparison's depth in every mode.
$B bench render scenes/cornell-box.toml --rays packet,packet8 --layouts quad,pixel \
    --max-depth 1,3,-1 --threads 1 --seconds 8 --repetitions 4 | tee "$out/layouts-cornell-box.txt"
$B bench render scenes/cornell-box.toml --res 256x256 --max-depth 6 --threads 2 \
    --rays single,packet,lockstep,packet8 --seconds 30 --repetitions 8 | tee "$out/depth6-cornell-box.txt"

fi
if part 2; then
echo "== 2. bench limit"
for rays in packet single; do
    $B bench limit scenes/cornell-box.toml --res 256x256 --threads 1 --rays "$rays" --seconds 4 \
        | tee "$out/limit-cornell-box-$rays.txt"
done

fi
if part 3; then
echo "== 3. against Mitsuba 3 (256², 64 spp, depth 6, 2 threads)"
# Dr.Jit's LLVM backend loads the newest libLLVM it finds and fails to compile its kernels
# with Debian 12's older ones (14, 15): a tiny render first, so that this part says why
# instead of stopping on an empty answer.
llvm_ok() {
    python3 benches/mitsuba/cbox.py --variant llvm_ad_spectral --res 16 --spp 1 --threads 1 \
        --repeat 1 >/dev/null 2>&1
}
if ! python3 -c 'import mitsuba' 2>/dev/null; then
    echo "mitsuba not installed (pip install mitsuba; apt-get install libllvm19): skipped" | tee "$out/mitsuba.txt"
elif ! llvm_ok; then
    echo "mitsuba's llvm_ad_spectral fails to compile its kernels here (apt-get install libllvm19): skipped" | tee "$out/mitsuba.txt"
else
    for round in 1 2 3; do
        for rays in packet single; do
            $B render scenes/cornell-box.toml --res 256x256 --spp 64 --max-depth 6 --threads 2 \
                --rays "$rays" -o "$out/cbox-$rays.exr" --stats-json "$out/cbox-$rays-$round.json" 2>/dev/null
            python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print('stokes $rays', round(d['samples_per_second']/1e6, 3), 'M samples/s')" "$out/cbox-$rays-$round.json"
        done
        for v in llvm_ad_spectral scalar_spectral; do
            python3 benches/mitsuba/cbox.py --variant $v --res 256 --spp 64 --threads 2 --repeat 2 2>/dev/null | tail -1 \
                | python3 -c "import json,sys; d=json.loads(sys.stdin.read()); print('mitsuba $v', round(d['msamples_per_s'], 3), 'M samples/s')"
        done
    done | tee "$out/mitsuba.txt"
fi

fi
if part 4; then
echo "== 4. fluorescence's cost"
sed -e 's/type = "fluorescent_diffuse"/type = "diffuse"/' -e '/^dye = /d' -e '/^matrix = /d' \
    scenes/fluorescent-surfaces.toml > scenes/.no-dyes.toml
trap 'rm -f scenes/.no-dyes.toml' EXIT
# Alternating rounds, so that the host's load drifts over both scenes alike; the cost ratio
# is the dyes-free median over the dyed median (time per sample with dyes / without).
for round in 1 2 3 4 5 6; do
    for s in scenes/fluorescent-surfaces.toml scenes/.no-dyes.toml; do
        $B bench render "$s" --rays packet --max-depth -1 --threads 2 --res 256x256 --seconds 2 \
            --repetitions 1 --json 2>/dev/null \
            | python3 -c 'import json,sys; print(sys.argv[1], json.load(sys.stdin)["results"][0]["samples_per_second"])' "$s"
    done
done | python3 -c '
import statistics, sys
rates = {}
for line in sys.stdin:
    s, r = line.split()
    rates.setdefault(s, []).append(float(r))
dyed, plain = (statistics.median(v) for v in rates.values())
for s, v in rates.items():
    print(f"{s}: median {statistics.median(v) / 1e6:.3f} M samples/s ({min(v) / 1e6:.3f}-{max(v) / 1e6:.3f}, {len(v)} rounds)")
print(f"cost per sample with dyes / without: {plain / dyed:.3f}")
' | tee "$out/fluorescence-cost.txt"

fi
if part 5; then
echo "== 5. instructions per sample (callgrind)"
# Each binary is named by its commit (`+` if the working tree differs from it): with BASE
# set, benches/targets.py reads the two as base and new and reports the change, counted
# side by side in this run.
head=$(git rev-parse --short HEAD)
git diff --quiet HEAD -- src embree-sys Cargo.toml Cargo.lock build.rs || head="$head+"
bins=("$B") names=("$head")
if [ -n "${BASE:-}" ]; then
    tmp=$(mktemp -d)
    git worktree add -q "$tmp/src" "$BASE"
    (cd "$tmp/src" && CARGO_TARGET_DIR="$tmp/target" cargo build --release -q)
    bins+=("$tmp/target/release/stokes") names+=("base:$(git rev-parse --short "$BASE")")
fi
# One pass of 8 spp counted: a 16-spp render minus an 8-spp one, both in passes of 8
# (`--pass-spp`), over 8 × 64² samples, so that a packet tracer keeps its 128 paths in
# flight as in a long render. Binaries from before `--pass-spp` (stop 50) are all counted
# the old way, 9 spp minus 1 spp in passes of 1, which at 64² also counts the packets'
# fill and drain in every pass (docs/packets.md, "Passes of one sample per pixel, counted").
measure="one pass of 8 spp"
for bin in "${bins[@]}"; do
    [[ $("$bin" render --help) == *--pass-spp* ]] || measure="passes of 1 spp (a binary without --pass-spp)"
done
per_sample() { # binary scene rays
    local runs a b
    case $measure in
        one*) runs=("--spp 8 --pass-spp 8" "--spp 16 --pass-spp 8") ;;
        *) runs=("--spp 1" "--spp 9") ;;
    esac
    # shellcheck disable=SC2086 # the runs' options split into words
    a=$(valgrind --tool=callgrind --callgrind-out-file=/dev/null "$1" render "$2" --res 64x64 ${runs[0]} \
        --threads 1 --rays "$3" -o "$out/cg.exr" 2>&1 | awk '/Collected/{print $4}')
    # shellcheck disable=SC2086
    b=$(valgrind --tool=callgrind --callgrind-out-file=/dev/null "$1" render "$2" --res 64x64 ${runs[1]} \
        --threads 1 --rays "$3" -o "$out/cg.exr" 2>&1 | awk '/Collected/{print $4}')
    echo $(((b - a) / (8 * 64 * 64)))
}
for n in "${!bins[@]}"; do
    for s in scenes/cornell-box.toml scenes/fluorescent-volume-440nm.toml; do
        for rays in packet single; do
            echo "${names[n]} $s $rays: $(per_sample "${bins[n]}" "$s" "$rays") instructions per sample"
        done
    done
done | sed "1i measured as: $measure" | tee "$out/instructions.txt"
if [ -n "${BASE:-}" ]; then git worktree remove --force "$tmp/src"; rm -rf "$tmp"; fi

fi
if part 6; then
echo "== 6. where a Cornell-box sample's instructions go (callgrind, by source file), and the width-1 estimator's scalar against packed multiplies"
split() { # rays spp -> "embree spectra rng rest" instruction totals
    valgrind --tool=callgrind --callgrind-out-file="$out/cg-$1-$2.out" "$B" render scenes/cornell-box.toml \
        --res 64x64 --spp "$2" --threads 1 --rays "$1" -o "$out/cg.exr" >/dev/null 2>&1
    callgrind_annotate --auto=no --threshold=100 "$out/cg-$1-$2.out" | awk '
        /file:function/ { f = 1; next }
        f && NF >= 2 { gsub(",", "", $1); n = $1 + 0
            if ($0 ~ /libembree/) e += n
            else if ($0 ~ /spectrum\/|cie.rs|color.rs/) s += n
            else if ($0 ~ /sampler.rs/) r += n
            else o += n }
        END { printf "%d %d %d %d\n", e, s, r, o }'
}
for rays in single packet; do
    read -ra a <<< "$(split "$rays" 9)"
    read -ra b <<< "$(split "$rays" 1)"
    n=$((8 * 64 * 64))
    echo "$rays per sample: Embree $(((a[0] - b[0]) / n)), spectra $(((a[1] - b[1]) / n)), random streams $(((a[2] - b[2]) / n)), the rest $(((a[3] - b[3]) / n))"
done | tee "$out/instructions-split.txt"
# The width-1 Tracer::run instances are the ones that call rtcIntersect1.
objdump -d --no-show-raw-insn "$B" | awk '
    /^[0-9a-f]+ </ { if (inrun && body ~ /rtcIntersect1@/) print body; inrun = 0 }
    /^[0-9a-f]+ <.*Tracer.*3run/ { inrun = 1; body = ""; next }
    inrun { body = body "\n" $0 }' | grep -oE '\b(mulss|mulps)\b' | sort | uniq -c | tee "$out/width1-multiplies.txt"
fi
if part 7; then
echo "== 7. the estimator's instruction mix (callgrind inside Tracer::run, Embree excluded)"
for rays in single packet; do
    valgrind --tool=callgrind --dump-instr=yes --compress-pos=no --compress-strings=no \
        --toggle-collect='*Tracer*run*' --callgrind-out-file="$out/mix-$rays.out" "$B" render \
        scenes/cornell-box.toml --res 64x64 --spp 16 --threads 1 --rays "$rays" \
        -o "$out/mix.exr" >/dev/null 2>&1
    echo "-- $rays"
    python3 benches/opmix.py "$B" "$out/mix-$rays.out" $((64 * 64 * 16))
    echo "-- $rays, by source file through inlining"
    python3 benches/bysource.py "$B" "$out/mix-$rays.out" $((64 * 64 * 16)) --by file 12
done | tee "$out/instruction-mix.txt"
fi
if part 8; then
echo "== 8. busy lanes per part of the step (cargo feature census)"
CARGO_TARGET_DIR=target/census cargo build --release -q --features census
for s in cornell-box fluorescent-volume-440nm; do
    for rays in packet single; do
        target/census/release/stokes render "scenes/$s.toml" --res 64x64 --spp 16 --threads 1 \
            --rays "$rays" -o "$out/census.exr" 2>&1 | sed -n '/^census/,$p'
    done
done | tee "$out/census.txt"
fi
