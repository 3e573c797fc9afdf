#!/usr/bin/env bash
# Compile-checks the Embree 4 code path on a Debian 12 machine (which ships Embree 3):
# fetches Debian 13's libembree-dev 4.x headers without touching the system's apt state,
# then runs `cargo check` against them. The library cannot run here
# (it needs a newer glibc); this only proves the Embree 4 bindings and queries compile.
set -euo pipefail
cd "$(dirname "$0")/.."
work=${EMBREE4_WORK:-/tmp/stokes-embree4}
mkdir -p "$work/lists/partial" "$work/root"
echo "deb [trusted=yes] http://deb.debian.org/debian trixie main" > "$work/sources.list"
apt_opts=(-o "Dir::Etc::sourcelist=$work/sources.list" -o Dir::Etc::sourceparts=- -o "Dir::State::Lists=$work/lists")
if [ ! -f "$work/root/usr/include/embree4/rtcore.h" ]; then
    apt-get "${apt_opts[@]}" update -qq
    (cd "$work" && apt-get "${apt_opts[@]}" download libembree-dev)
    dpkg -x "$work"/libembree-dev_*.deb "$work/root"
fi
EMBREE_DIR="$work/root/usr" CARGO_TARGET_DIR="$work/target" cargo check --all-targets
grep -h "rustc-cfg=embree" "$work"/target/debug/build/embree-sys-*/output
