#!/usr/bin/env bash
# Mutation testing with cargo-mutants (crates.io `cargo-mutants`): every module group is
# mutated and tested against the test binaries that concern it; the outcomes go to
# mutants.out/<group>/mutants.out/ (outcomes.json, caught.txt, missed.txt, timeout.txt,
# unviable.txt). docs/mutants.md holds the table and the reason for every survivor.
#
#   scripts/mutants.sh                 # every group (hours on 2 cores: see docs/mutants.md)
#   scripts/mutants.sh fluoro medium   # just these
#   MUTANTS_JOBS=1 scripts/mutants.sh  # one mutant at a time (default 2)
#
# Too long for CI. It builds with the `mutants` profile (Cargo.toml: opt-level 1,
# incremental), without the `stokes` binary (--no-default-features: the selected tests do
# not run it), and hands the test selection to `cargo test --no-run` as well as to
# `cargo test` (--cargo-arg): otherwise every mutant rebuilds all the test binaries.
#
# Scene-file parsing (the `desc.rs` modules and the `from_desc`/`checked_power` parsers
# and checks) is left out: it is tested by the bad-scene corpus through the binary
# (tests/robustness.rs, tests/cli_errors.rs), whose fuzzing runs for up to a minute.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v cargo-mutants >/dev/null || cargo install --locked cargo-mutants

# group | files (globs, comma-separated) | test binaries
GROUPS_TABLE="
spectrum | src/spectrum/*.rs       | --lib --test spectrum --test colorchecker
fluoro   | src/fluoro/*.rs         | --lib --test reradiation --test fluorescent_surfaces
medium   | src/medium/*.rs         | --lib --test medium_sampling --test media_renders
light    | src/light.rs            | --lib --test light_sampling --test render_analytic
bsdf     | src/bsdf/*.rs           | --lib --test bsdf_sampling --test render_analytic --test packet
path     | src/integrator/path.rs  | --test render_analytic --test fluorescent_surfaces --test media_renders --test packet
"
EXCLUDE=(--exclude 'src/*/desc.rs' --exclude-re 'from_desc|checked_power')

want=("$@")
status=0
while IFS='|' read -r group files tests; do
    group=$(echo "$group" | xargs)
    [ -n "$group" ] || continue
    if [ ${#want[@]} -gt 0 ] && [[ ! " ${want[*]} " == *" $group "* ]]; then
        continue
    fi
    args=()
    IFS=',' read -ra globs <<< "$files"
    for g in "${globs[@]}"; do args+=(-f "$(echo "$g" | xargs)"); done
    for t in $tests; do args+=(--cargo-arg="$t"); done
    echo "== $group: ${args[*]}"
    start=$SECONDS
    mkdir -p "mutants.out/$group"
    cargo mutants --profile mutants --no-default-features --no-shuffle --minimum-test-timeout 60 \
        --jobs "${MUTANTS_JOBS:-2}" "${EXCLUDE[@]}" "${args[@]}" \
        -o "mutants.out/$group" || status=$?
    echo "== $group took $((SECONDS - start)) s"
done <<< "$GROUPS_TABLE"
# cargo-mutants exits 2 when mutants were missed, 3 on timeouts: a result, not a failure.
exit $(( status == 1 || status == 4 ? status : 0 ))
