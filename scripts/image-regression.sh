#!/usr/bin/env bash
# Image regression check for refactors: renders every scene of scenes/ with the `stokes`
# binary of a base commit and with the working tree's, for every method the scene makes
# meaningful, and demands bit-identical images (and variance images), identical
# `stokes info` output and identical error messages for tests/bad_scenes/.
#
#   scripts/image-regression.sh [BASE_COMMIT] [--res WxH] [--spp N] [--keep DIR]
#
#   BASE_COMMIT   commit to compare against (default HEAD); built in a temporary worktree
#   --res WxH     render resolution (default 48x48)
#   --spp N       samples per pixel (default 4)
#   --keep DIR    keep the images that differ (base, current, |difference|) in DIR
#                 (default: a temporary directory, printed if anything differs)
#
# Environment:
#   STOKES_REGRESSION_CACHE=DIR  keep the base build's target dir in DIR/target and its
#                 binary in DIR/stokes-<commit>-<toolchain>, reused by later runs
#   STOKES_EMBREE_CONFIG etc. are passed to both binaries alike.
#
# Both binaries read the working tree's scene files, from the working tree's root (so the
# paths in messages and headers agree), with --seed 7 --threads 2 --variance. Methods per
# scene (decided from the base's `stokes info`): --spectral hwss|mono x --rays
# packet|lockstep|single; if fluorescent, --shifting independent|constant (HWSS) x rays;
# with media, --tracking classic|max|fluo-aware x spectral x rays; with a dispersive
# dielectric, --dispersion split|drop (HWSS) x rays; and --max-depth 3 with the defaults.
#
# "Identical" means: same resolution, channels and pixel type, and the same bits in every
# pixel value. `idiff -fail 0 -failpercent 0 -warn 0` (OpenImageIO 2.4) fails on any finite
# difference, one ULP included, but passes NaN against a number, Inf against a number and
# -0 against +0; so each pair is also re-encoded, metadata stripped, as an uncompressed TIFF
# and compared byte for byte. Header attributes are not compared for the verdict (render
# time and version always differ); other attribute differences are printed as notes.
#
# Prints one line per image pair and per message, then a summary; exits 0 only if
# everything is identical.
set -euo pipefail

usage() {
    sed -n '7,13p' "$0" | sed 's/^# \{0,1\}//'
    exit "$1"
}
die() {
    echo "image-regression: $*" >&2
    exit 2
}

base_rev=HEAD
res=48x48
spp=4
keep=""
base_given=false
while [ $# -gt 0 ]; do
    case "$1" in
    --res)
        [ $# -ge 2 ] || die "--res needs a value WxH"
        res=$2
        shift 2
        ;;
    --spp)
        [ $# -ge 2 ] || die "--spp needs a value"
        spp=$2
        shift 2
        ;;
    --keep)
        [ $# -ge 2 ] || die "--keep needs a directory"
        keep=$2
        shift 2
        ;;
    -h | --help) usage 0 ;;
    -*) die "unknown option '$1' (see --help)" ;;
    *)
        $base_given && die "only one BASE_COMMIT, found '$base_rev' and '$1'"
        base_rev=$1
        base_given=true
        shift
        ;;
    esac
done
[[ $res =~ ^[1-9][0-9]*x[1-9][0-9]*$ ]] || die "--res: expected WxH such as 48x48, found '$res'"
[[ $spp =~ ^[1-9][0-9]*$ ]] || die "--spp: expected a positive integer, found '$spp'"

for tool in idiff oiiotool; do
    command -v "$tool" >/dev/null ||
        die "'$tool' not found: it comes with OpenImageIO's tools (apt-get install openimageio-tools, or scripts/install-deps.sh)"
done
for tool in git cargo cmp diff; do
    command -v "$tool" >/dev/null || die "'$tool' not found"
done

root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
commit=$(git rev-parse --verify --quiet "$base_rev^{commit}") || die "not a commit: '$base_rev'"
if [ -n "$keep" ]; then
    mkdir -p "$keep"
    keep=$(cd "$keep" && pwd)
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/stokes-regression.XXXXXX")
worktree="" # the base's temporary worktree while it exists
cleanup() {
    if [ -n "$worktree" ]; then
        git -C "$root" worktree remove --force "$worktree" >/dev/null 2>&1 || true
        git -C "$root" worktree prune >/dev/null 2>&1 || true
    fi
    rm -rf "$work"
}
trap cleanup EXIT
trap 'echo "image-regression: interrupted" >&2; exit 130' INT
trap 'exit 143' TERM

start=$SECONDS
dirty=""
[ -z "$(git status --porcelain --untracked-files=no)" ] || dirty=" + uncommitted changes"
echo "base:    $commit ($(git log -1 --format=%s "$commit" | cut -c1-60))"
echo "current: working tree of $(git rev-parse --short HEAD)$dirty"
echo "renders: --res $res --spp $spp --seed 7 --threads 2"

# --- the two binaries -------------------------------------------------------------------

# Builds BASE's binary into $work/stokes-base, or takes it from the cache.
build_base() {
    local cache=${STOKES_REGRESSION_CACHE:-} cached="" target="$work/base-target"
    if [ -n "$cache" ]; then
        mkdir -p "$cache"
        cache=$(cd "$cache" && pwd)
        # A toolchain or flag change can change the code, so it is part of the key.
        local toolchain
        toolchain=$(printf '%s\n%s\n' "$(rustc -vV)" "${RUSTFLAGS:-}" | sha1sum | cut -c1-12)
        cached="$cache/stokes-$commit-$toolchain"
        target="$cache/target"
        if [ -x "$cached" ]; then
            echo "base binary: cached $cached"
            cp "$cached" "$work/stokes-base"
            return
        fi
    fi
    worktree="$work/base-src"
    git worktree add --quiet --detach "$worktree" "$commit"
    echo "building base in a temporary worktree (target dir $target) ..."
    if ! (cd "$worktree" && CARGO_TARGET_DIR="$target" cargo build --release) >"$work/base-build.log" 2>&1; then
        tail -n 30 "$work/base-build.log" >&2
        die "building the base commit $commit failed (log above)"
    fi
    cp "$target/release/stokes" "$work/stokes-base"
    if [ -n "$cached" ]; then
        cp "$work/stokes-base" "$cached.tmp.$$"
        mv "$cached.tmp.$$" "$cached"
    fi
    git worktree remove --force "$worktree"
    worktree=""
}

build_current() {
    echo "building the working tree ..."
    if ! cargo build --release >"$work/current-build.log" 2>&1; then
        tail -n 30 "$work/current-build.log" >&2
        die "building the working tree failed (log above)"
    fi
    # A copy, so that a rebuild during the run cannot swap the binary under us.
    cp "${CARGO_TARGET_DIR:-target}/release/stokes" "$work/stokes-current"
}


# --- helpers ----------------------------------------------------------------------------

n_img_same=0 n_img_diff=0 n_msg_same=0 n_msg_diff=0 n_header_notes=0 n_weak=0
default_keep=false
if [ -z "$keep" ]; then
    keep="$work/keep"
    default_keep=true
fi
mkdir -p "$keep"

report() { printf '%-66s %s\n' "$1" "$2"; }

# The TIFF form of an image: pixel values with their bits unchanged, no metadata.
tiff_args() { printf '%s\n' "$1" --eraseattrib ".*" --attrib DateTime "-" --compression none -o "$2"; }

# Splits `oiiotool -v --info --stats` output into DIR/NAME.layout (size, channels, pixel
# type), DIR/NAME.stats and DIR/NAME.attrs (the other header lines, minus those that
# always differ).
split_info() {
    awk -v dir="$1" '
        /^Reading / { name = $2; first = 1; next }
        /^Writing / { name = ""; next }
        name == "" { next }
        first {
            line = $0
            if (index(line, name) == 1) line = substr(line, length(name) + 1)
            sub(/^ *: */, "", line)
            print line > (dir "/" name ".layout"); first = 0; next
        }
        /^    channel list:/ { print > (dir "/" name ".layout"); next }
        /^    (Stats |Constant:|Monochrome:)/ { print > (dir "/" name ".stats"); next }
        /^    (stokes:render_seconds|stokes:version):/ { next }
        { print > (dir "/" name ".attrs") }
    ' "$2"
}

# Reads DIR/base.* and DIR/current.* (the files named) in one oiiotool run: their layout
# and header lines, and their TIFF copies.
prepare() {
    local dir=$1 f
    shift
    local -a args=()
    for f in "$@"; do
        [ -f "$dir/$f" ] || continue
        mapfile -t -O "${#args[@]}" args < <(tiff_args "$f" "$f.tif")
    done
    [ ${#args[@]} -gt 0 ] || return 0
    if ! (cd "$dir" && oiiotool -v --info --stats --nosoftwareattrib "${args[@]}") >"$dir/info.txt" 2>&1; then
        cat "$dir/info.txt" >&2
        die "oiiotool could not read or convert the images in $dir"
    fi
    split_info "$dir" "$dir/info.txt"
}

# Counts the pixels whose bits differ between two TIFF copies of LAYOUT (a float image) and
# prints "COUNT X Y" (X, Y: the first such pixel). oiiotool writes the pixel data last, so it
# starts W*H*C*4 bytes before the end; the self-check confirms where the first one lies.
bit_diff() {
    local w h c fmt size
    read -r w h c fmt < <(awk -F'[ ,]+' 'NR == 1 { print $1, $3, $4, $6 }' "$3")
    size=$(wc -c <"$1")
    if [ "$fmt" != float ] || [ "$size" -lt $((w * h * c * 4)) ]; then
        echo "? ? ?"
        return
    fi
    cmp -l "$1" "$2" 2>/dev/null | awk -v d=$((size - w * h * c * 4)) -v c="$c" -v w="$w" '
        { i = int(($1 - 1 - d) / (4 * c)); if (!(i in seen)) { seen[i] = 1; if (n++ == 0) first = i } }
        END { printf "%d %d %d\n", n, first % w, int(first / w) }' || true
}

# Prints why DIR/base.NAME and DIR/current.NAME differ, or nothing if they are identical:
# the pixels whose bits differ, and idiff's largest absolute difference.
verdict() {
    local a="$1/base.$2" b="$1/current.$2"
    if [ ! -f "$a" ] || [ ! -f "$b" ]; then
        echo "DIFFERS: $([ -f "$a" ] || echo "no base image ")$([ -f "$b" ] || echo "no current image")"
        return
    fi
    if ! cmp -s "$a.layout" "$b.layout"; then
        echo "DIFFERS: layout $(tr -s ' ' <"$a.layout" | paste -sd ';') vs $(tr -s ' ' <"$b.layout" | paste -sd ';')"
        return
    fi
    local rc=0 out max n x y
    out=$(idiff -fail 0 -failpercent 0 -warn 0 "$a" "$b" 2>&1) || rc=$?
    if cmp -s "$a.tif" "$b.tif"; then
        [ "$rc" -eq 0 ] || echo "DIFFERS: idiff exit $rc although the bits agree: $(head -n 3 <<<"$out" | tr '\n' ' ')"
        return
    fi
    max=$(sed -n 's/^ *Max error *= *\([^ ]*\).*/\1/p' <<<"$out" | head -n 1)
    read -r n x y < <(bit_diff "$a.tif" "$b.tif" "$a.layout")
    if [ "$rc" -eq 0 ]; then
        echo "DIFFERS: $n pixels (first at $x,$y), by NaN/Inf/signed zero only (idiff passes these)"
    else
        echo "DIFFERS: $n pixels (first at $x,$y), max abs diff ${max:-?} (idiff exit $rc)"
    fi
}

# Names the header attributes (other than render time and version) that differ, if any.
header_note() {
    local a="$1/base.$2.attrs" b="$1/current.$2.attrs"
    [ -f "$a" ] && [ -f "$b" ] || return 0
    cmp -s "$a" "$b" && return 0
    echo " (note: header attributes differ: $(diff "$a" "$b" | sed -nE 's/^[<>] +([^ ]+): .*/\1/p' | sort -u | paste -sd ' '))"
}

# Notes what makes a pair a weak test: a constant base image (black, say) or NaN/Inf.
stats_note() {
    local a="$1/base.$2.stats" b="$1/current.$2.stats"
    [ -f "$a" ] && [ -f "$b" ] || return 0
    if grep -q '^    Constant: Yes' "$a"; then
        echo " (note: constant base image: it tests little)"
    fi
    local side
    for side in base current; do
        if awk '/^    Stats (NanCount|InfCount):/ { for (i = 3; i <= NF; i++) if ($i != 0) bad = 1 } END { exit !bad }' "$1/$side.$2.stats"; then
            echo " (note: NaN or Inf in the $side image)"
        fi
    done
}

# Reports one image pair, counts it, and keeps the images if they differ.
compare_pair() {
    local dir=$1 name=$2 label=$3 tag=$4
    local why note weak
    why=$(verdict "$dir" "$name")
    note=$(header_note "$dir" "$name")
    [ -z "$note" ] || n_header_notes=$((n_header_notes + 1))
    weak=$(stats_note "$dir" "$name" | tr -d '\n')
    [ -z "$weak" ] || n_weak=$((n_weak + 1))
    note+=$weak
    if [ -z "$why" ]; then
        n_img_same=$((n_img_same + 1))
        report "$label" "identical$note"
        return
    fi
    n_img_diff=$((n_img_diff + 1))
    report "$label" "$why$note"
    local a="$dir/base.$name" b="$dir/current.$name" stem="$keep/$tag${name#image}"
    stem=${stem%.exr}
    if [ -f "$a" ]; then cp "$a" "$stem.base.exr"; fi
    if [ -f "$b" ]; then cp "$b" "$stem.current.exr"; fi
    if [ -f "$a" ] && [ -f "$b" ]; then
        idiff -q -abs -fail 0 -failpercent 0 -warn 0 -o "$stem.absdiff.exr" "$a" "$b" >/dev/null 2>&1 || true
    fi
}

# The comparison must see what it claims to: an identical pair passes; one ULP in one pixel,
# a NaN for a 1 and a -0 for a +0 each fail (the last two are invisible to idiff).
self_check() {
    local dir="$work/self-check"
    mkdir -p "$dir"
    (
        cd "$dir"
        local ones=(--pattern "constant:color=1,1,1" 8x8 3 -d float)
        oiiotool "${ones[@]}" -o base.same.exr -o base.ulp.exr -o base.nan.exr
        oiiotool "${ones[@]}" -o current.same.exr
        oiiotool "${ones[@]}" --fill:color=1.0000001,1,1 1x1+3+5 -o current.ulp.exr
        oiiotool "${ones[@]}" --fill:color=nan,1,1 1x1+3+5 -o current.nan.exr
        oiiotool --pattern constant:color=0,0,0 8x8 3 -d float -o base.zero.exr \
            --fill:color=-0,0,0 1x1+3+5 -o current.zero.exr
    ) >"$dir/log" 2>&1 || { cat "$dir/log" >&2; die "self-check: oiiotool could not make the test images"; }
    prepare "$dir" {base,current}.{same,ulp,nan,zero}.exr
    local got expect name
    for name in same:'' ulp:'DIFFERS: 1 pixels (first at 3,5), max abs diff 1.19209e-07 (idiff' \
        nan:'DIFFERS: 1 pixels (first at 3,5), by NaN' zero:'DIFFERS: 1 pixels (first at 3,5), by NaN'; do
        expect=${name#*:}
        name=${name%%:*}
        got=$(verdict "$dir" "$name.exr")
        if { [ -z "$expect" ] && [ -n "$got" ]; } || [[ $got != "$expect"* ]]; then
            die "self-check of the image comparison failed on '$name': expected '${expect:-identical}', got '${got:-identical}'"
        fi
    done
    echo "self-check: identical pair passes; 1 ULP, NaN and -0 in one pixel are caught"
}

# Renders one scene with one method (flags in $3) with both binaries and compares.
check_method() {
    local scene=$1 name=$2 method=$3
    local tag
    tag="$name.$(tr ' ' '_' <<<"$method" | sed 's/--//g')"
    local dir="$work/r/$tag"
    mkdir -p "$dir"
    local -a flags
    read -ra flags <<<"$method"
    local side bin failed=""
    for side in base current; do
        bin=$base_bin
        [ "$side" = current ] && bin=$cur_bin
        if ! "$bin" render "$scene" --res "$res" --spp "$spp" --seed 7 --threads 2 "${flags[@]}" \
            --variance -o "$dir/$side.image.exr" >"$dir/$side.log" 2>&1; then
            failed+="$side render failed: $(grep -m1 . "$dir/$side.log" || echo '(no output)'); "
            rm -f "$dir/$side.image.exr" "$dir/$side.image.variance.exr"
        fi
    done
    local label="$name $method"
    if [ -n "$failed" ]; then
        n_img_diff=$((n_img_diff + 2))
        report "$label" "DIFFERS: ${failed%; }"
        report "$label [variance]" "DIFFERS: (see above)"
        for side in base current; do cp "$dir/$side.log" "$keep/$tag.$side.log"; done
        return
    fi
    prepare "$dir" {base,current}.image.exr {base,current}.image.variance.exr
    compare_pair "$dir" image.exr "$label" "$tag"
    compare_pair "$dir" image.variance.exr "$label [variance]" "$tag"
}

# Runs `stokes ARGS...` from the working tree's root with both binaries and compares exit
# status, stdout, stderr and whether an output file appeared. With OUT set, that file is
# removed before each run. Timings of a successful render are masked.
check_message() {
    local label=$1 out=$2
    shift 2
    local dir="$work/m"
    mkdir -p "$dir"
    local side bin rc
    for side in base current; do
        bin=$base_bin
        [ "$side" = current ] && bin=$cur_bin
        [ -z "$out" ] || rm -f "$out" "${out%.exr}.variance.exr"
        rc=0
        "$bin" "$@" >"$dir/stdout" 2>"$dir/stderr" || rc=$?
        {
            echo "exit status: $rc"
            if [ -n "$out" ]; then
                if [ -e "$out" ]; then echo "output file: written"; else echo "output file: none"; fi
            fi
            echo "--- stdout"
            cat "$dir/stdout"
            echo "--- stderr"
            if [ "$rc" -eq 0 ] && [ -n "$out" ]; then
                sed -E 's/[0-9]+(\.[0-9]+)? (s|M samples\/s|M rays\/s)\b/# \2/g' "$dir/stderr"
            else
                cat "$dir/stderr"
            fi
        } >"$dir/$side.txt"
    done
    local note=""
    grep -q '^exit status: 0$' "$dir/base.txt" && [ -n "$out" ] && note=" (rendered; timings masked)"
    if cmp -s "$dir/base.txt" "$dir/current.txt"; then
        n_msg_same=$((n_msg_same + 1))
        report "$label" "identical$note"
    else
        n_msg_diff=$((n_msg_diff + 1))
        report "$label" "DIFFERS$note:"
        diff -u --label "base: $label" --label "current: $label" "$dir/base.txt" "$dir/current.txt" | sed 's/^/    /' || true
    fi
}

# --- run ------------------------------------------------------------------------------

self_check
build_base
build_current
base_bin="$work/stokes-base"
cur_bin="$work/stokes-current"
echo "build time: $((SECONDS - start)) s"
t_renders=$SECONDS

# --- renders ----------------------------------------------------------------------------

rays=(packet lockstep single)
shopt -s nullglob
scenes=(scenes/*.toml)
[ ${#scenes[@]} -gt 0 ] || die "no scenes in $root/scenes"
n_methods=0
new_scenes=()
for scene in "${scenes[@]}"; do
    name=$(basename "$scene" .toml)
    echo
    echo "== $scene"
    check_message "stokes info $scene" "" info "$scene"
    if ! info=$("$base_bin" info "$scene" 2>/dev/null); then
        # A scene the base commit does not have, or has changed since, may use syntax the
        # base cannot read; an unchanged scene it cannot read is a broken base.
        if git cat-file -e "$base_rev:$scene" 2>/dev/null; then
            git diff --quiet "$base_rev" -- "$scene" && die "base: stokes info $scene failed"
            echo "scene changed since the base, which cannot read it: not rendered"
        else
            echo "new scene, which the base cannot read: not rendered"
        fi
        new_scenes+=("$scene")
        continue
    fi
    for key in spectral fluorescence media; do
        grep -q "^$key " <<<"$info" || die "base: stokes info $scene has no '$key' line"
    done
    fluorescent=false media=false dispersive=false
    grep -q '^fluorescence yes' <<<"$info" && fluorescent=true
    grep -qE '^media +none' <<<"$info" || media=true
    grep '^spectral ' <<<"$info" | grep -q -- '--dispersion' && dispersive=true

    methods=()
    for spectral in hwss mono; do
        for r in "${rays[@]}"; do methods+=("--spectral $spectral --rays $r"); done
    done
    if $fluorescent; then
        for shifting in independent constant; do
            for r in "${rays[@]}"; do methods+=("--spectral hwss --rays $r --shifting $shifting"); done
        done
    fi
    if $media; then
        for tracking in classic max fluo-aware; do
            for spectral in hwss mono; do
                for r in "${rays[@]}"; do methods+=("--spectral $spectral --rays $r --tracking $tracking"); done
            done
        done
    fi
    if $dispersive; then
        for dispersion in split drop; do
            for r in "${rays[@]}"; do methods+=("--spectral hwss --rays $r --dispersion $dispersion"); done
        done
    fi
    methods+=("--max-depth 3")
    for method in "${methods[@]}"; do
        check_method "$scene" "$name" "$method"
    done
    n_methods=$((n_methods + ${#methods[@]}))
done
t_messages=$SECONDS

# --- error messages ---------------------------------------------------------------------

echo
echo "== tests/bad_scenes (stokes render SCENE --spp 1 --res 8x8)"
bad_out="$work/bad/x.exr"
mkdir -p "$work/bad"
for bad in tests/bad_scenes/*.toml; do
    check_message "$bad" "$bad_out" render "$bad" --spp 1 --res 8x8 -o "$bad_out"
done

# --- summary ----------------------------------------------------------------------------

echo
echo "$n_methods methods over ${#scenes[@]} scenes, 2 images each; renders and comparisons $((t_messages - t_renders)) s, messages $((SECONDS - t_messages)) s, total $((SECONDS - start)) s"
[ ${#new_scenes[@]} -eq 0 ] || echo "${#new_scenes[@]} new or changed scenes the base cannot read, not rendered: ${new_scenes[*]}"
[ "$n_header_notes" -eq 0 ] || echo "$n_header_notes images have header attributes that differ (not part of the verdict; see the notes)"
[ "$n_weak" -eq 0 ] || echo "$n_weak images are weak tests (constant, or NaN/Inf; see the notes)"
echo "$n_img_same images identical, $n_img_diff differ; $n_msg_same messages identical, $n_msg_diff differ"
if [ "$n_img_diff" -ne 0 ]; then
    if $default_keep; then
        kept=$(mktemp -d "${TMPDIR:-/tmp}/stokes-regression-diff.XXXXXX")
        cp -r "$keep"/. "$kept"/
        keep=$kept
    fi
    echo "differing images (base, current, |difference|) kept in $keep"
fi
[ "$n_img_diff" -eq 0 ] && [ "$n_msg_diff" -eq 0 ]
