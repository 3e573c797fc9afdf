#!/usr/bin/env bash
# The figures of Mojzík, Fichet and Wilkie, "Handling Fluorescence in a Uni-directional
# Spectral Path Tracer" (EGSR 2018), on the project's version of the paper's scene
# (scenes/egsr2018/), at the paper's sample counts.
#
#   benches/paper_figures.sh              # references (cached, resumable), panels, strips
#   benches/paper_figures.sh references   # only the two 65,536-spp references
#
# 1. Two references, HWSS with fluorescence-aware tracking at REF_SPP spp (65,536), of
#    teaser.toml and main.toml at RES x RES, seed 1000 (the panels use seed 0, so they are
#    independent of it). Each is rendered in chunks of CHUNK spp with
#    `stokes reference --resume` into CACHE: interrupt the script and run it again, and it
#    goes on where it stopped; a finished reference is reused.
# 2. The panels at RES x RES, every one timed (`stokes:render_seconds` of its header):
#    - teaser: mono + max tracking, mono + fluorescence-aware, HWSS + fluorescence-aware,
#      16 spp each, on teaser.toml;
#    - tracking: classic, max and fluorescence-aware at 128 spp on main.toml, plus max
#      and fluorescence-aware at the time fluorescence-aware took for 128 spp (equal time);
#    - hwss: mono against HWSS at 16 spp, and HWSS with constant against independent
#      shifting at 16 spp, on teaser.toml;
#    - results: main.toml's box under D65 without the medium, under a 440 nm lamp with
#      and without it, under a 550 nm lamp with and without it (256 spp each), and
#      main.toml at 2048 spp.
# 3. `stokes figure` writes each strip (labels, difference rows with a colour scale) as PNG
#    into OUT, and the error tables (RMSE and relMSE over the image and the scene's
#    regions) as markdown; errors.md collects them with the render times.
# 4. `stokes converge` of the trackers on main.toml against its reference (the error
#    floor of classic tracking), into OUT/converge-main.
#
# Settings (environment): RES (128), REF_SPP (65536), CHUNK (4096), THREADS (0: every
# core), CONVERGE_BUDGET (40 seconds per method; 0 skips step 4), CACHE ($HOME/.cache/stokes/egsr2018), OUT (docs/results/egsr2018),
# WORK (/tmp/stokes-egsr2018), STOKES (target/release/stokes).
set -euo pipefail
cd "$(dirname "$0")/.."

RES=${RES:-128}
REF_SPP=${REF_SPP:-65536}
CHUNK=${CHUNK:-4096}
THREADS=${THREADS:-0}
CACHE=${CACHE:-$HOME/.cache/stokes/egsr2018}
OUT=${OUT:-docs/results/egsr2018}
WORK=${WORK:-/tmp/stokes-egsr2018}
STOKES=${STOKES:-target/release/stokes}
SCENES=scenes/egsr2018
REF_SEED=1000

[ -x "$STOKES" ] || cargo build --release
mkdir -p "$CACHE" "$OUT" "$WORK"

# The spp an EXR written by stokes holds (0 when it does not exist).
spp_of() {
    if [ -f "$1" ]; then
        oiiotool --info -v "$1" | sed -n 's/.*stokes:spp: "\([0-9]*\)".*/\1/p'
    else
        echo 0
    fi
}

# reference NAME: the reference of $SCENES/NAME.toml at RES, grown in chunks until it holds
# at least REF_SPP spp (a cached one with more is used as it is).
reference() {
    local name=$1 ref="$CACHE/$1-$RES.exr"
    local have start
    have=$(spp_of "$ref")
    start=$(date +%s)
    while [ "$have" -lt "$REF_SPP" ]; do
        local add=$((REF_SPP - have < CHUNK ? REF_SPP - have : CHUNK))
        "$STOKES" reference "$SCENES/$name.toml" --res "${RES}x$RES" --seed $REF_SEED \
            --threads "$THREADS" --spp "$add" --resume -o "$ref" >&2
        have=$(spp_of "$ref")
        echo "$name reference: $have of $REF_SPP spp, $(($(date +%s) - start)) s this run" >&2
    done
    echo "$ref"
}

TEASER_REF=$(reference teaser)
MAIN_REF=$(reference main)
[ "${1:-}" = references ] && exit 0

# panel NAME SCENE SPP [render flags...]: renders $WORK/NAME.exr at RES (seed 0) unless it
# is there already with the same command (kept in $WORK/NAME.cmd).
panel() {
    local name=$1 scene=$2 spp=$3
    shift 3
    local args="render $SCENES/$scene.toml --res ${RES}x$RES --spp $spp --seed 0 --threads $THREADS $*"
    if [ -f "$WORK/$name.exr" ] && [ "$(cat "$WORK/$name.cmd" 2>/dev/null)" = "$args" ]; then
        return
    fi
    # shellcheck disable=SC2086 # the flags are words
    "$STOKES" $args -o "$WORK/$name.exr" >&2
    echo "$args" >"$WORK/$name.cmd"
}

# seconds NAME: the render time of $WORK/NAME.exr from its header.
seconds() {
    oiiotool --info -v "$WORK/$1.exr" | sed -n 's/.*stokes:render_seconds: "\([0-9.]*\)".*/\1/p'
}

MONO="--spectral mono"
HWSS="--spectral hwss"

# 1. Teaser (teaser.toml, 16 spp).
panel teaser-mono-max teaser 16 $MONO --tracking max
panel teaser-mono-fluo teaser 16 $MONO --tracking fluo-aware
panel teaser-hwss-fluo teaser 16 $HWSS --tracking fluo-aware
# 2. Tracking (main.toml, 128 spp; then max and fluo-aware at fluo-aware's time).
panel main-classic main 128 $HWSS --tracking classic
panel main-max main 128 $HWSS --tracking max
panel main-fluo main 128 $HWSS --tracking fluo-aware
T=$(seconds main-fluo)
panel main-max-time main 1000000 $HWSS --tracking max --time "$T"
panel main-fluo-time main 1000000 $HWSS --tracking fluo-aware --time "$T"
# 3. HWSS (teaser.toml, 16 spp): mono against HWSS, constant against independent shifting.
panel teaser-hwss-constant teaser 16 $HWSS --tracking fluo-aware --shifting constant
# 4. Results (the main box, 256 spp; main.toml at 2048 spp).
panel results-d65 main-d65-no-volume 256
panel results-440 main-440nm 256
panel results-440-none main-440nm-no-volume 256
panel results-550 main-550nm 256
panel results-550-none main-550nm-no-volume 256
panel results-main-2048 main 2048

spp_label() { echo "$(spp_of "$WORK/$1.exr") spp"; }

# strip OUT TITLE SCENE REFERENCE-or-"" [figure flags] -- LABEL=NAME ...: a strip of $WORK
# panels; with a reference, its difference row and error table (appended to errors.md).
strip() {
    local out=$1 title=$2 scene=$3 ref=$4
    shift 4
    local flags=()
    while [ "$1" != -- ]; do
        flags+=("$1")
        shift
    done
    shift
    local panels=()
    for p in "$@"; do
        panels+=("${p%=*}=$WORK/${p##*=}.exr")
    done
    if [ -n "$ref" ]; then
        {
            echo
            echo "### $title"
            echo
            "$STOKES" figure "${panels[@]}" --reference "$ref" --scene "$SCENES/$scene.toml" \
                --diff --title "$title" "${flags[@]}" -o "$OUT/$out.png"
        } >>"$OUT/errors.md"
    else
        "$STOKES" figure "${panels[@]}" --title "$title" "${flags[@]}" -o "$OUT/$out.png" >/dev/null
    fi
}

{
    echo "# The EGSR 2018 figures: errors against the references"
    echo
    echo "Written by \`benches/paper_figures.sh\` (RES=$RES; references HWSS fluorescence-aware,"
    echo "$(spp_of "$TEASER_REF") spp for the teaser and $(spp_of "$MAIN_REF") spp for the main scene, seed $REF_SEED;"
    echo "panels seed 0). RMSE and relMSE (mean (x − r)² / (r² + 0.01)) over linear sRGB, over"
    echo "the whole image and the scene's regions; seconds are each render's own, $(nproc) threads"
    echo "on $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)."
} >"$OUT/errors.md"

strip teaser "Teaser: 16 spp against the reference" teaser "$TEASER_REF" --zoom 2 --exposure 1 -- \
    "mono, max tracking, $(spp_label teaser-mono-max)=teaser-mono-max" \
    "mono, fluo-aware, $(spp_label teaser-mono-fluo)=teaser-mono-fluo" \
    "HWSS, fluo-aware, $(spp_label teaser-hwss-fluo)=teaser-hwss-fluo"
strip tracking "Tracking: classic, maximum and fluorescence-aware at 128 spp" main "$MAIN_REF" --zoom 2 -- \
    "classic, $(spp_label main-classic)=main-classic" \
    "max, $(spp_label main-max)=main-max" \
    "fluo-aware, $(spp_label main-fluo)=main-fluo"
strip tracking-equal-time "Tracking at equal time ($T s)" main "$MAIN_REF" --zoom 2 -- \
    "max, $(spp_label main-max-time)=main-max-time" \
    "fluo-aware, $(spp_label main-fluo-time)=main-fluo-time"
strip hwss "HWSS against mono, constant against independent shifting, 16 spp" teaser "$TEASER_REF" --zoom 2 --exposure 1 -- \
    "mono, $(spp_label teaser-mono-fluo)=teaser-mono-fluo" \
    "HWSS independent, $(spp_label teaser-hwss-fluo)=teaser-hwss-fluo" \
    "HWSS constant, $(spp_label teaser-hwss-constant)=teaser-hwss-constant"
strip results-d65 "D65 without the medium; the 300-700 nm lamp with it, 2048 spp" main "" --zoom 2 -- \
    "D65, no medium, $(spp_label results-d65)=results-d65" \
    "300-700 nm lamp, medium, $(spp_label results-main-2048)=results-main-2048"
{
    echo
    echo "### Under a 440 nm and a 550 nm lamp: with the medium against without it"
    echo
    echo "The \"reference\" of these two tables is the render without the medium: the error is"
    echo "what the medium changes (at 550 nm only noise: it is clear there)."
} >>"$OUT/errors.md"
strip results-440 "440 nm lamp: with the medium, against without" main-440nm "$WORK/results-440-none.exr" --zoom 2 -- \
    "440 nm, medium, $(spp_label results-440)=results-440" \
    "440 nm, no medium, $(spp_label results-440-none)=results-440-none"
strip results-550 "550 nm lamp: with the medium, against without" main-550nm "$WORK/results-550-none.exr" --zoom 2 -- \
    "550 nm, medium, $(spp_label results-550)=results-550" \
    "550 nm, no medium, $(spp_label results-550-none)=results-550-none"

{
    echo
    echo "### Render times"
    echo
    echo "| panel | spp | seconds |"
    echo "| --- | --- | --- |"
    for f in "$WORK"/*.exr; do
        n=$(basename "$f" .exr)
        case $n in *.variance) continue ;; esac
        echo "| $n | $(spp_label "$n") | $(seconds "$n") |"
    done
} >>"$OUT/errors.md"
# 4. The error floor: classic, maximum and fluorescence-aware tracking (and mono) against
#    time on main.toml, CONVERGE_BUDGET seconds each, charts and summary into
#    $OUT/converge-main, its table in summary.md (skipped when CONVERGE_BUDGET=0).
CONVERGE_BUDGET=${CONVERGE_BUDGET:-40}
if [ "$CONVERGE_BUDGET" != 0 ]; then
    "$STOKES" converge "$SCENES/main.toml" --reference "$MAIN_REF" --res "${RES}x$RES" \
        --threads "$THREADS" --methods hwss-classic,hwss-max,hwss-fluo-aware,mono-fluo-aware \
        --budget "$CONVERGE_BUDGET" --out "$OUT/converge-main" |
        grep -v '^→' >"$WORK/converge-summary.md"
    mv "$WORK/converge-summary.md" "$OUT/converge-main/summary.md"
fi
echo "wrote $OUT/*.png, $OUT/errors.md and $OUT/converge-main/" >&2
