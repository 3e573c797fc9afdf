#!/usr/bin/env bash
# Runs the Embree-facing tests once more under every Embree kernel (ISA) this CPU can run
# below its best one (which the plain `make test` already uses), by forcing the kernel with
# STOKES_EMBREE_CONFIG=isa=<name>. An assertion that holds on one kernel only (an exact
# float out of Embree, say) then fails on any machine, not just on the one that differs.
#
#   scripts/test-isas.sh            # every ISA below the best
#   scripts/test-isas.sh sse2 avx   # just these
#
# Prints one line per ISA with its wall time; exits non-zero if any run failed.
set -euo pipefail
cd "$(dirname "$0")/.."

# The tests that trace rays through Embree and would notice a kernel's arithmetic: the
# safe layer, packets against single rays, and image checks against stored references.
TESTS=(--test accel --test packet --test embree_config --test image_oiio --test render_analytic)

flags=$(grep -m1 '^flags' /proc/cpuinfo || true)
has() { [[ " $flags " == *" $1 "* ]]; }

# Embree's kernel names (Embree 3 and 4), each with the CPU flags it needs, lowest first.
available=(sse2)
has sse4_2 && available+=(sse4.2)
has avx && available+=(avx)
has avx2 && has fma && available+=(avx2)
has avx512f && has avx512dq && has avx512cd && has avx512bw && has avx512vl && available+=(avx512)

if [ $# -gt 0 ]; then
    isas=("$@")
else
    best=${available[${#available[@]}-1]}
    isas=("${available[@]:0:${#available[@]}-1}")
    echo "Embree kernels this CPU can run: ${available[*]} (best: $best, used by the plain test run)"
fi

status=0
summary=()
for isa in "${isas[@]}"; do
    echo "== STOKES_EMBREE_CONFIG=isa=$isa"
    start=$(date +%s%N)
    if STOKES_EMBREE_CONFIG="isa=$isa" cargo test --release --quiet "${TESTS[@]}"; then
        result=passed
    else
        result=FAILED
        status=1
    fi
    ms=$((($(date +%s%N) - start) / 1000000))
    summary+=("$(printf 'isa=%-7s %s in %d.%01d s' "$isa" "$result" $((ms / 1000)) $((ms % 1000 / 100)))")
done
printf '%s\n' "${summary[@]}"
exit $status
