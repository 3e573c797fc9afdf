#!/usr/bin/env bash
# A real client reads what stokes writes: renders the Cornell box with 94 and 470 spectral
# bins (5 and 1 nm) and checks it with colour-science and OpenImageIO's Python bindings
# (tests/client/spectral_exr.py), in a Python venv this script creates under target/.
# Needs python3-venv, network access to PyPI the first time, and oiiotool.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=${STOKES_CLIENT_VENV:-target/client-venv}
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install -q --disable-pip-version-check \
    colour-science==0.4.7 OpenImageIO==3.2.2.0 numpy==2.4.6
out=target/client
mkdir -p "$out"
cargo build --release -q
for bins in 94 470; do
    image="$out/cornell-$bins-bins.exr"
    target/release/stokes render scenes/cornell-box.toml --res 48x48 --spp 64 --seed 1 \
        --spectral-bins "$bins" -o "$image"
    "$venv/bin/python" tests/client/spectral_exr.py "$image" "$bins" 360 830
done
