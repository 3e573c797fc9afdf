#!/usr/bin/env bash
# Where each speed target of issue 14 ("Packets that pay") stands on this machine, each
# measured the way the README's "Packets against single rays" describes, then summed up in
# one table (benches/targets.py) in OUT/targets.md:
#
#   benches/targets.sh [OUT_DIR]     # default out/targets; about 20 minutes on 2 cores
#   PARTS="2 3" benches/targets.sh   # only the parts listed; the table shows what is there
#   SECONDS_PER_FIGURE=12 REPS=8 benches/targets.sh   # a shorter, noisier first part
#   BASE=REV benches/targets.sh      # part 4 also counts REV's instructions, same run
#
# 1. Packets against single rays, paired (stokes bench render, REPS repetitions of
#    SECONDS_PER_FIGURE / REPS seconds per figure; default 16 of 3 s): the Cornell box
#    (512²) and the 100k-triangle sphere (1024²), depth 3 and unbounded, 1 and 2 threads,
#    packet and packet8 against single.
# 2. Two threads against one at depth 1 on the sphere, paired (16 repetitions of 1 s).
# 3. The Cornell box's fraction of its Embree limit (stokes bench limit, 8 renders of 2 s,
#    each paired with its rays' replays), packet and single.
# 4. Against Mitsuba 3, fluorescence's cost, and instructions per sample: parts 3, 4 and 5
#    of benches/packets.sh (Mitsuba is skipped if `import mitsuba` fails).
#
# The target table: packet / single >= 1.6x (part 1), 2 threads / 1 >= 1.85x (part 2),
# fraction of the Embree limit >= 0.6 (part 3), >= 1.5x Mitsuba's llvm_ad_spectral and
# >= 3x its scalar_spectral, fluorescence <= 1.3x (part 4).
set -euo pipefail
. "$(dirname "$0")/setup.sh" out/targets "1 2 3 4" "$@"
seconds=${SECONDS_PER_FIGURE:-48}
reps=${REPS:-16}

if part 1; then
    echo "== 1. packets against single rays, paired ($reps repetitions, $seconds s per figure)"
    for scene in cornell-box sphere-100k; do
        $B bench render "scenes/$scene.toml" --rays single,packet,packet8 --max-depth 3,-1 \
            --threads 1,2 --seconds "$seconds" --repetitions "$reps" --json >"$out/render-$scene.json"
        echo "$scene done"
    done
fi
if part 2; then
    echo "== 2. two threads against one, depth 1, sphere"
    $B bench render scenes/sphere-100k.toml --rays single,packet --max-depth 1 --threads 1,2 \
        --seconds 16 --repetitions 16 --json >"$out/threads-sphere-100k.json"
fi
if part 3; then
    echo "== 3. fraction of the Embree limit"
    for rays in packet single; do
        $B bench limit scenes/cornell-box.toml --res 256x256 --threads 1 --rays "$rays" \
            --seconds 16 --repetitions 8 --json >"$out/limit-cornell-box-$rays.json"
    done
fi
if part 4; then
    echo "== 4. against Mitsuba 3, fluorescence's cost, instructions per sample"
    PARTS="3 4 5" benches/packets.sh "$out"
fi
python3 benches/targets.py "$out" | tee "$out/targets.md"
