#!/usr/bin/env bash
# Convergence of every method on the project's comparison scenes: for each scene, a
# high-spp reference (cached) and `stokes converge` into docs/results/<scene>/
# (convergence.csv, error-vs-time.svg/.png, error-vs-spp.svg/.png, summary.md).
#
#   benches/converge_all.sh [SCENE ...]     # names from scenes/, default: the seven below
#
# Settings (environment):
#   RES=128          square image side for references and runs
#   BUDGET=10        seconds of rendering per method
#   THREADS=0        worker threads (0 = one per core)
#   REF_DIR=/tmp/stokes-refs   reference cache: <scene>-<RES>-<scene file hash>.exr
#   REF_SPP=         reference spp for every scene (default: per scene, below, sized to
#                    take a few minutes each at 128x128 on 2 cores)
#   OUT_ROOT=docs/results
#   EXTRA=           more flags for both commands (e.g. "--max-depth 6")
#
# A cached reference with fewer spp than asked for is topped up with
# `stokes reference --resume`; a changed scene file gets a new reference (the cache name
# holds its hash). Run from the repository root.
set -euo pipefail

RES=${RES:-128}
BUDGET=${BUDGET:-10}
THREADS=${THREADS:-0}
REF_DIR=${REF_DIR:-/tmp/stokes-refs}
OUT_ROOT=${OUT_ROOT:-docs/results}
EXTRA=${EXTRA:-}

# Reference spp per scene at 128x128 on 2 cores (measured rates: about 2 M samples/s for
# the Cornell box, 1.2–2.5 M for the fluorescent surfaces, 1.7 M for the volume, 4 M for
# the slab), scaled by the pixel count for other sizes.
declare -A SPP_AT_128=(
  [cornell-box]=16384
  [fluorescent-surfaces]=8192
  [fluorescent-surfaces-440nm]=8192
  [fluorescent-volume-440nm]=8192
  [fluorescent-slab]=16384
  [prism]=16384
  [colorchecker]=8192
)
if [ $# -gt 0 ]; then
  SCENES=("$@")
else
  SCENES=(cornell-box colorchecker fluorescent-surfaces fluorescent-surfaces-440nm fluorescent-volume-440nm fluorescent-slab prism)
fi

cargo build --release --quiet
STOKES=${CARGO_TARGET_DIR:-target}/release/stokes
mkdir -p "$REF_DIR"

# The spp a reference EXR holds (its stokes:spp attribute), or 0.
ref_spp() {
  if [ -f "$1" ] && command -v oiiotool >/dev/null; then
    oiiotool --info -v "$1" | sed -n 's/^ *stokes:spp: "\([0-9]*\)"$/\1/p' | head -1
  else
    echo 0
  fi
}

for name in "${SCENES[@]}"; do
  scene=scenes/$name.toml
  [ -f "$scene" ] || { echo "error: $scene: no such scene" >&2; exit 1; }
  hash=$(sha256sum "$scene" | cut -c1-12)
  ref=$REF_DIR/$name-$RES-$hash.exr
  if [ -n "${REF_SPP:-}" ]; then
    want=$REF_SPP
  else
    base=${SPP_AT_128[$name]:-8192}
    want=$(( base * 128 * 128 / (RES * RES) ))
    [ "$want" -ge 256 ] || want=256
  fi
  have=$(ref_spp "$ref")
  have=${have:-0}
  if [ ! -f "$ref" ]; then
    echo "== $name: reference, $want spp at ${RES}x$RES → $ref"
    # shellcheck disable=SC2086
    "$STOKES" reference "$scene" --res "${RES}x$RES" --spp "$want" --threads "$THREADS" $EXTRA -o "$ref"
  elif [ "$have" -lt "$want" ]; then
    echo "== $name: reference has $have spp, adding $(( want - have ))"
    # shellcheck disable=SC2086
    "$STOKES" reference "$scene" --res "${RES}x$RES" --spp $(( want - have )) --threads "$THREADS" $EXTRA -o "$ref" --resume
  else
    echo "== $name: cached reference $ref ($have spp)"
  fi
  out=$OUT_ROOT/$name
  echo "== $name: converge, $BUDGET s per method → $out"
  mkdir -p "$out"
  # shellcheck disable=SC2086
  "$STOKES" converge "$scene" --reference "$ref" --res "${RES}x$RES" --budget "$BUDGET" \
    --threads "$THREADS" $EXTRA --out "$out" | tee "$out/summary.md"
done
