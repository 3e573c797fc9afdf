#!/usr/bin/env bash
# Mutation testing with cargo-mutants (crates.io `cargo-mutants`): every module group is
# mutated and tested against the test binaries that concern it; the outcomes go to
# mutants.out/<group>/mutants.out/ (outcomes.json, caught.txt, missed.txt, timeout.txt,
# unviable.txt). docs/mutants.md holds the table and the reason for every survivor.
#
#   scripts/mutants.sh                 # every group (about 50 hours on 2 cores: docs/mutants.md)
#   scripts/mutants.sh fluoro medium   # just these
#   MUTANTS_JOBS=1 scripts/mutants.sh  # one mutant at a time (default 2)
#   MUTANTS_SHARD=0/4 scripts/mutants.sh   # every 4th mutant of each group (cargo-mutants
#                                      # --shard, round-robin over the list), a quarter of the time
#   touch mutants.pause                # wait before the next group while this file exists
#
# Too long for CI. It builds with the `mutants` profile (Cargo.toml: opt-level 1,
# incremental), without the `stokes` binary (--no-default-features: the selected tests do
# not run it), and hands the test selection to `cargo test --no-run` as well as to
# `cargo test` (--cargo-arg): otherwise every mutant rebuilds all the test binaries.
# The two slowest tests of tests/fluorescent_surfaces.rs (three methods at 128² and up to
# 1024 spp, ~20 s each) are skipped: the closed-form and diagonal-matrix tests of the same
# file are kept.
#
# Scene-file parsing (the `desc.rs` modules and the `from_desc`/`checked_power` parsers
# and checks) is left out: it is tested by the bad-scene corpus through the binary
# (tests/robustness.rs, tests/cli_errors.rs), whose fuzzing runs for up to a minute.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v cargo-mutants >/dev/null || cargo install --locked cargo-mutants
# Every mutant relinks its test binaries: mold (Debian's `mold`) links them in a fraction
# of the time GNU ld takes.
if command -v mold >/dev/null; then
    export RUSTFLAGS="${RUSTFLAGS:-} -C link-arg=-fuse-ld=mold"
fi

SLOW="-- --skip mono_constant_and_independent_agree"
# group | files (globs, comma-separated) | test binaries | test harness arguments
GROUPS_TABLE="
light    | src/light.rs, src/light/*.rs | --lib --test light_sampling --test render_analytic --test lights --test environment | -- --skip stokes_info_lists_the_lights_by_kind
texture  | src/texture/*.rs, src/fluoro/map.rs | --lib --test textures --test fluorescence_map --test roughness_map --test coated_texture | -- --skip stokes_info_lists
bsdf     | src/bsdf/*.rs           | --lib --test bsdf_sampling --test microfacet_sampling --test coated_sampling --test materials_render --test shading_normals --test roughness_map --test textures --test packet | -- --skip stokes_info_lists
medium   | src/medium/*.rs         | --lib --test medium_sampling --test media_renders |
spectrum | src/spectrum/*.rs       | --lib --test spectrum --test colorchecker --test upsample --test wavelengths | -- --skip the_binary_caches_the_table
path     | src/integrator/path.rs, src/integrator/shadow.rs, src/integrator/mod.rs | --lib --test render_analytic --test media_renders --test packet --test fluorescent_surfaces --test environment --test lights | $SLOW --skip stokes_info_lists
fluoro   | src/fluoro/*.rs         | --lib --test reradiation --test fluorescent_surfaces --test fluorescence_map --test bispectral_exr --test bfc | $SLOW --skip stokes_info_lists --skip convert
"
EXCLUDE=(--exclude 'src/*/desc.rs' --exclude-re 'from_desc|checked_power')

want=("$@")
status=0
while IFS='|' read -r group files tests harness; do
    group=$(echo "$group" | xargs)
    [ -n "$group" ] || continue
    if [ ${#want[@]} -gt 0 ] && [[ ! " ${want[*]} " == *" $group "* ]]; then
        continue
    fi
    while [ -e mutants.pause ]; do sleep 10; done
    args=()
    IFS=',' read -ra globs <<< "$files"
    for g in "${globs[@]}"; do args+=(-f "$(echo "$g" | xargs)"); done
    for t in $tests; do args+=(--cargo-arg="$t"); done
    read -ra extra <<< "$harness"
    echo "== $group: ${args[*]} ${extra[*]}"
    start=$SECONDS
    mkdir -p "mutants.out/$group"
    shard=()
    [ -n "${MUTANTS_SHARD:-}" ] && shard=(--shard "$MUTANTS_SHARD" --sharding round-robin)
    cargo mutants --profile mutants --no-default-features --no-shuffle --minimum-test-timeout 60 \
        --jobs "${MUTANTS_JOBS:-2}" "${shard[@]}" "${EXCLUDE[@]}" "${args[@]}" \
        -o "mutants.out/$group" -- "${extra[@]}" || status=$?
    echo "== $group took $((SECONDS - start)) s"
done <<< "$GROUPS_TABLE"
# cargo-mutants exits 2 when mutants were missed, 3 on timeouts: a result, not a failure.
exit $(( status == 1 || status == 4 ? status : 0 ))
