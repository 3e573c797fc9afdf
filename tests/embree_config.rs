//! `STOKES_EMBREE_CONFIG`: the Embree configuration string handed to `rtcNewDevice`, used
//! to force a kernel (`isa=sse4.2`, …) so that the suite can be run under every ISA the
//! CPU has. Invalid values are one-line errors naming the variable, never aborts or a
//! silent fallback to SSE2.

mod common;
use common::*;
use stokes::accel::{check_config, cpu_has_isa, CONFIG_VARIABLE, ISAS};

#[test]
fn valid_configurations_pass_the_check() {
    for config in [
        "",
        "threads=1",
        "max_isa=avx512",
        "max_isa=sse2",
        "threads=1,isa=sse2",
        "isa=sse2 threads=1",
        "verbose=0",
    ] {
        assert_eq!(check_config(config), Ok(()), "{config:?}");
    }
    for (isa, _) in ISAS {
        if cpu_has_isa(isa) {
            assert_eq!(check_config(&format!("isa={isa}")), Ok(()), "{isa}");
        }
    }
    assert!(cpu_has_isa("sse2"), "every x86-64 CPU has SSE2");
}

#[test]
fn unknown_or_unavailable_isas_are_rejected() {
    for config in [
        "isa=foo",
        "isa=",
        "max_isa=avx3",
        "threads=1,isa=AVX2",
        "isa=avx512skx",
    ] {
        let e = check_config(config).expect_err(config);
        assert!(
            e.message
                .contains("expected one of sse2, sse4.2, avx, avx2, avx512"),
            "{config:?}: {e}"
        );
    }
    for (isa, _) in ISAS {
        if !cpu_has_isa(isa) {
            let e = check_config(&format!("isa={isa}")).expect_err(isa);
            assert!(e.message.contains("cannot run"), "{e}");
            // As a maximum it is fine: Embree picks the best kernel at or below it.
            assert_eq!(check_config(&format!("max_isa={isa}")), Ok(()));
        }
    }
}

/// Renders a tiny scene with `STOKES_EMBREE_CONFIG=config`: (success, stderr, output written).
fn render_with(name: &str, config: &str) -> (bool, String, bool) {
    let dir = scratch(name);
    let out = dir.join("out.exr");
    let _ = std::fs::remove_file(&out);
    let (ok, _, err) = run(stokes()
        .env(CONFIG_VARIABLE, config)
        .args([
            "render",
            "scenes/cornell-box.toml",
            "--spp",
            "1",
            "--res",
            "8x8",
            "-o",
        ])
        .arg(&out));
    (ok, err, out.exists())
}

#[test]
fn invalid_values_are_one_line_errors_naming_the_variable() {
    for (i, (config, fragment)) in [
        ("isa=foo", "expected one of"),
        ("max_isa=avx3", "expected one of"),
        // Embree's own parser rejects a value of the wrong type (it keeps no message, so
        // the error carries its code).
        ("threads=abc", "RTC_ERROR_UNKNOWN"),
    ]
    .iter()
    .enumerate()
    {
        let (ok, err, written) = render_with(&format!("embree_config_bad_{i}"), config);
        assert!(!ok && !written, "{config:?} rendered: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{config:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(err.contains("STOKES_EMBREE_CONFIG"), "{config:?}: {err}");
        assert!(err.contains(config), "{config:?}: {err}");
        assert!(err.contains(fragment), "{config:?}: {err}");
    }
}

#[test]
fn every_isa_of_this_cpu_renders() {
    for (isa, _) in ISAS.iter().filter(|(isa, _)| cpu_has_isa(isa)) {
        let (ok, err, written) =
            render_with(&format!("embree_config_{isa}"), &format!("isa={isa}"));
        assert!(ok && written, "isa={isa}: {err}");
    }
}
