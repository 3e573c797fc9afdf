//! Renders with known answers: white furnace, a diffuse sphere in a uniformly emitting
//! enclosure, depth semantics, determinism across thread counts, and HWSS = mono.

mod common;
use common::*;
use stokes::color::xyz_to_linear_srgb;
use stokes::method::{Spectral, Wavelengths};
use stokes::spectrum::{reflectance_to_xyz, spectrum_to_xyz, Spectrum};

/// A diffuse sphere of the given reflectance inside a black box whose walls emit
/// `radiance` from both sides.
fn enclosure_scene(reflectance: &str, radiance: &str) -> String {
    enclosure(
        &format!("type = \"diffuse\"\nreflectance = {reflectance}"),
        radiance,
        32,
        "",
    )
}

#[test]
fn white_furnace_returns_the_emitted_radiance() {
    let expected = xyz_to_linear_srgb(spectrum_to_xyz(&Spectrum::Constant(1.0)));
    // Mono pays for its wavelength noise with more samples: enough that the standard
    // error is well under the 0.5 % tolerance in every mode.
    for (spectral, wavelengths, spp) in [
        (Spectral::Hwss, Wavelengths::Uniform, 4096),
        (Spectral::Mono, Wavelengths::Uniform, 40000),
        (Spectral::Hwss, Wavelengths::Visible, 4096),
        (Spectral::Mono, Wavelengths::Visible, 16384),
    ] {
        let mut scene = scene_from(&enclosure_scene("1.0", "1.0"));
        let film = TestRender::at(16, 16)
            .spp(spp)
            .seed(1)
            .spectral(spectral)
            .wavelengths(wavelengths)
            .film(&mut scene);
        let (m, se) = region_mean(&film, &all_pixels(&film));
        let spectral = format!("{spectral:?} {wavelengths:?}");
        eprintln!("{spectral}: mean {m:?} se {se:?}, expected {expected}");
        for c in 0..3 {
            assert!(
                se[c] < 0.0012 * expected[c] as f64,
                "{spectral}: too few samples for the test to decide (se {})",
                se[c]
            );
            let rel = (m[c] - expected[c] as f64).abs() / expected[c] as f64;
            assert!(
                rel < 0.005,
                "{spectral} channel {c}: {} vs {} (rel. error {rel:.4}, se {:.2e})",
                m[c],
                expected[c],
                se[c]
            );
        }
    }
}

#[test]
fn diffuse_sphere_in_uniform_enclosure_matches_albedo_times_radiance() {
    // A spectrally varying albedo under D65: the sphere reflects ρ(λ)·L(λ) exactly (it is
    // convex and the walls do not reflect), whatever the depth.
    let rho = "{ wavelengths = [360, 500, 600, 830], values = [0.2, 0.8, 0.3, 0.6] }";
    let d65 = "{ illuminant = \"D65\", scale = 0.01 }";
    let text = enclosure_scene(rho, d65);
    let rho_s = Spectrum::Tabulated(
        stokes::spectrum::Tabulated::new(
            vec![360.0, 500.0, 600.0, 830.0],
            vec![0.2, 0.8, 0.3, 0.6],
        )
        .unwrap(),
    );
    let d65_s = Spectrum::Scaled(Box::new(stokes::spectrum::illuminant("D65").unwrap()), 0.01);
    let expected = xyz_to_linear_srgb(reflectance_to_xyz(&rho_s, &d65_s));
    for spectral in [Spectral::Hwss, Spectral::Mono] {
        let mut scene = scene_from(&text);
        let film = TestRender::at(32, 32)
            .spp(32)
            .seed(2)
            .spectral(spectral)
            .film(&mut scene);
        // Pixels well inside the sphere's silhouette (radius 1 at distance 1.8, 60° fov).
        let r_px = (1.0f32 / (1.8f32 * 1.8 - 1.0).sqrt()) / (30f32.to_radians().tan()) * 16.0;
        let inner: Vec<usize> = (0..32 * 32)
            .filter(|i| {
                let (x, y) = ((i % 32) as f32 + 0.5 - 16.0, (i / 32) as f32 + 0.5 - 16.0);
                (x * x + y * y).sqrt() < 0.8 * r_px
            })
            .collect();
        assert!(inner.len() > 100);
        let got = region_mean(&film, &inner);
        let want = (expected.to_array().map(|v| v as f64), [0.0; 3]);
        assert_agree(&format!("{spectral:?} sphere"), got, want, 4.0);
    }
}

#[test]
fn biased_expectation_is_rejected() {
    // The Z-test above can fail: a 3 % brighter expectation is rejected.
    let mut scene = scene_from(&enclosure_scene("0.5", "1.0"));
    let film = TestRender::at(32, 32).spp(256).seed(3).film(&mut scene);
    let expected = xyz_to_linear_srgb(spectrum_to_xyz(&Spectrum::Constant(0.5)));
    let centre: Vec<usize> = (0..32 * 32usize)
        .filter(|i| (i % 32).abs_diff(16) < 5 && (i / 32).abs_diff(16) < 5)
        .collect();
    let got = region_mean(&film, &centre);
    for c in 0..3 {
        let want = expected[c] as f64 * 1.03;
        assert!(
            (got.0[c] - want).abs() > 4.0 * got.1[c],
            "a 3 % bias went unnoticed"
        );
    }
}

#[test]
fn max_depth_counts_segments_from_the_camera() {
    let mut scene = scene_file("cornell-box.toml");
    // Depth 1: only the luminaire is visible; everything else is black.
    let film = TestRender::at(24, 24).spp(4).max_depth(1).film(&mut scene);
    let mean = film.mean();
    let lit = mean.iter().filter(|p| p[1] > 0.0).count();
    assert!(lit > 0 && lit < 24, "depth 1 lit {lit} pixels");
    // Depth 2 adds direct light: the floor is lit but the ceiling (which the light
    // cannot see) stays black apart from the luminaire itself.
    let film2 = TestRender::at(24, 24).spp(4).max_depth(2).film(&mut scene);
    let m2 = film2.mean();
    let ceiling_corner = m2[24 + 12]; // row 1, column 12: ceiling in front of the light
    assert_eq!(ceiling_corner, [0.0, 0.0, 0.0], "ceiling lit at depth 2");
    let floor = m2[22 * 24 + 4]; // the floor in front of the red wall
    assert!(floor[1] > 0.0, "floor dark at depth 2");
    // Depth 3 lights the ceiling through one bounce.
    let film3 = TestRender::at(24, 24).spp(4).max_depth(3).film(&mut scene);
    assert!(film3.mean()[24 + 12][1] > 0.0, "ceiling dark at depth 3");
}

#[test]
fn same_seed_same_image_whatever_the_thread_count() {
    let mut scene = scene_file("cornell-box.toml");
    let a = TestRender::at(16, 16)
        .spp(4)
        .seed(42)
        .threads(1)
        .film(&mut scene);
    let b = TestRender::at(16, 16)
        .spp(4)
        .seed(42)
        .threads(2)
        .film(&mut scene);
    assert_eq!(a.mean(), b.mean());
    let c = TestRender::at(16, 16)
        .spp(4)
        .seed(43)
        .threads(2)
        .film(&mut scene);
    assert_ne!(a.mean(), c.mean());
}

#[test]
fn hwss_and_mono_agree_on_the_cornell_box() {
    let mut scene = scene_file("cornell-box.toml");
    let h = TestRender::at(32, 32).spp(64).seed(7).film(&mut scene);
    let m = TestRender::at(32, 32)
        .spp(64)
        .seed(8)
        .spectral(Spectral::Mono)
        .film(&mut scene);
    let hm = region_mean(&h, &all_pixels(&h));
    let mm = region_mean(&m, &all_pixels(&m));
    assert_agree("HWSS vs mono, image mean", hm, mm, 4.0);
    // HWSS is the less noisy of the two (that is its point).
    for c in 0..3 {
        assert!(
            hm.1[c] < mm.1[c],
            "HWSS not less noisy than mono in channel {c}"
        );
    }
}
