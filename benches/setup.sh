# Sourced by benches/packets.sh and benches/targets.sh, after `set -euo pipefail`:
#
#   . "$(dirname "$0")/setup.sh" DEFAULT_OUT "DEFAULT_PARTS" "$@"
#
# leaves the shell in the repository root with the release binary built as $B, the output
# directory $out made (the script's first argument, else DEFAULT_OUT), the CPU's model
# name in $out/cpu.txt, and `part N` true when N is in $PARTS (else in DEFAULT_PARTS).
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=${3:-$1}
default_parts=$2
mkdir -p "$out"
cargo build --release -q
B=target/release/stokes
part() { [[ " ${PARTS:-$default_parts} " == *" $1 "* ]]; }
grep -m1 'model name' /proc/cpuinfo | tee "$out/cpu.txt"
