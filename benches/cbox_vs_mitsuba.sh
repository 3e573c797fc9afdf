#!/usr/bin/env bash
# stokes against Mitsuba 3: error against time on the measured Cornell box.
#
#   benches/cbox_vs_mitsuba.sh            # from anywhere; run on an otherwise idle machine
#
# 1. a stokes reference of scenes/cornell-box.toml at RES x RES, REF_SPP spp (kept in
#    REF and reused when it is there: delete it to render a new one);
# 2. Mitsuba 3 (benches/mitsuba/time_to_error.py) on that reference, the variants
#    VARIANTS, spp 1, 2, 4, ... until its renders add up to MITSUBA_BUDGET seconds
#    (each render timed on its own, after an untimed warm-up render), into mitsuba.csv;
# 3. `stokes converge` of every method against the same reference, BUDGET seconds each,
#    THREADS threads, with --compare mitsuba.csv (Mitsuba's curves on its charts) if
#    `stokes converge --help` mentions that option;
# 4. the table: per method and variant, the seconds to relMSE TARGET and the relMSE
#    reached in BUDGET seconds, and each Mitsuba variant's ratios to stokes' best.
#
# Settings (environment): RES (128), REF_SPP (16384), BUDGET (10), MITSUBA_BUDGET (30:
# the last render then takes about half of it, enough to read the error at BUDGET s),
# THREADS (2), VARIANTS (llvm_ad_spectral,scalar_spectral), TARGET (1e-3),
# MITSUBA_PYTHON (/work/venvs/mitsuba/bin/python), OUT (/tmp/cbox-vs-mitsuba), REF.
set -euo pipefail
cd "$(dirname "$0")/.."

RES=${RES:-128}
REF_SPP=${REF_SPP:-16384}
BUDGET=${BUDGET:-10}
MITSUBA_BUDGET=${MITSUBA_BUDGET:-30}
THREADS=${THREADS:-2}
VARIANTS=${VARIANTS:-llvm_ad_spectral,scalar_spectral}
TARGET=${TARGET:-1e-3}
PY=${MITSUBA_PYTHON:-/work/venvs/mitsuba/bin/python}
OUT=${OUT:-/tmp/cbox-vs-mitsuba}
REF=${REF:-/tmp/cbox-ref-$RES-$REF_SPP.exr}
SCENE=scenes/cornell-box.toml
STOKES=target/release/stokes

if ! "$PY" -c 'import mitsuba, numpy' 2>/dev/null; then
    echo "no mitsuba/numpy in $PY: see benches/mitsuba/README.md (Install)" >&2
    exit 1
fi
cargo build --release --quiet
mkdir -p "$OUT"
grep -m1 'model name' /proc/cpuinfo
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"

if [ -f "$REF" ]; then
    echo "reference: $REF (cached)"
else
    "$STOKES" reference "$SCENE" --res "${RES}x${RES}" --spp "$REF_SPP" --threads "$THREADS" -o "$REF"
fi

echo "== Mitsuba 3 ($VARIANTS), renders adding up to $MITSUBA_BUDGET s per variant"
"$PY" benches/mitsuba/time_to_error.py --reference "$REF" --variants "$VARIANTS" \
    --budget "$MITSUBA_BUDGET" --threads "$THREADS" --target "$TARGET" --at "$BUDGET" \
    --out "$OUT/mitsuba.csv" | tee "$OUT/mitsuba.txt"

compare=()
# (the help captured first: under pipefail, grep -q closing the pipe early could fail it)
converge_help=$("$STOKES" converge --help)
if grep -q -- '--compare' <<<"$converge_help"; then
    compare=(--compare "$OUT/mitsuba.csv")
else
    echo "(stokes converge has no --compare option: its charts show stokes only)"
fi
echo "== stokes converge, $BUDGET s per method"
# /usr/bin/time: the CPU time converge had (user + sys near THREADS x wall if it had
# the cores; it includes the warm-up pass and the error computations)
timer=()
if [ -x /usr/bin/time ]; then timer=(/usr/bin/time -f "converge: %e s wall, %U s user, %S s sys"); fi
"${timer[@]}" "$STOKES" converge "$SCENE" --reference "$REF" --res "${RES}x${RES}" --budget "$BUDGET" \
    --threads "$THREADS" --out "$OUT/stokes" "${compare[@]}" 2>&1 | tee "$OUT/stokes-summary.txt"
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"

echo "== stokes against Mitsuba 3 (relMSE over the whole image, linear sRGB)"
"$PY" benches/mitsuba/time_to_error.py --reference "$REF" --target "$TARGET" --at "$BUDGET" \
    --table-only "$OUT/mitsuba.csv" --stokes-csv "$OUT/stokes/convergence.csv" | tee "$OUT/table.md"
echo "outputs in $OUT: mitsuba.csv, stokes/ (convergence.csv, charts), table.md"
