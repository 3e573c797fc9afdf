#!/usr/bin/env bash
# Installs the system packages stokes needs on Debian 12, if any is missing:
# Embree 3 (headers + library), libclang for bindgen, pkg-config, and OpenImageIO's
# command-line tools (idiff, oiiotool) for the image tests.
set -euo pipefail
PKGS=(libembree-dev libclang-dev pkg-config openimageio-tools)
missing=()
for p in "${PKGS[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
    exit 0
fi
echo "installing: ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq "${missing[@]}"
