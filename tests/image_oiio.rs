//! The EXR output as OpenImageIO sees it, and a Z-image check of a small Cornell box render
//! against a stored reference (tests/reference/, see its README).

mod common;
use common::oiio::{stats, z_diff, ZThresholds};
use common::*;

fn render_cbox(
    dir: &std::path::Path,
    seed: u64,
    spp: u32,
) -> (std::path::PathBuf, std::path::PathBuf) {
    let out = dir.join("cbox.exr");
    let (ok, _, err) = run(stokes().args([
        "render",
        &s(&root().join("scenes/cornell-box.toml")),
        "--res",
        "64x64",
        "--spp",
        &spp.to_string(),
        "--seed",
        &seed.to_string(),
        "--variance",
        "-o",
        &s(&out),
    ]));
    assert!(ok, "{err}");
    (out.clone(), dir.join("cbox.variance.exr"))
}

#[test]
fn exr_is_read_by_oiiotool_with_the_expected_size_and_no_nan() {
    assert!(
        have("oiiotool"),
        "oiiotool missing: apt-get install openimageio-tools"
    );
    let dir = scratch("oiiostats");
    let (img, var) = render_cbox(&dir, 5, 4);
    for f in [&img, &var] {
        let st = stats(f)
            .unwrap()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        assert!(st.contains("64 x 64, 3 channel, float openexr"), "{st}");
        assert!(st.contains("channel list: R, G, B"), "{st}");
        assert!(
            st.contains("NanCount: 0 0 0") && st.contains("InfCount: 0 0 0"),
            "{st}"
        );
    }
}

#[test]
fn cornell_box_matches_the_stored_reference() {
    assert!(
        have("idiff"),
        "idiff missing: apt-get install openimageio-tools"
    );
    let dir = scratch("oiioref");
    let (img, var) = render_cbox(&dir, 77, 256);
    let rf = root().join("tests/reference/cornell-box-64.exr");
    let rv = root().join("tests/reference/cornell-box-64.variance.exr");
    z_diff(&img, &var, &rf, &rv, ZThresholds::default()).unwrap();

    // The image means agree too (a test with power against small global biases).
    let (_, _, a, _) = stokes::output::read_exr(&img).unwrap();
    let (_, _, av, _) = stokes::output::read_exr(&var).unwrap();
    let (_, _, b, _) = stokes::output::read_exr(&rf).unwrap();
    let (_, _, bv, _) = stokes::output::read_exr(&rv).unwrap();
    let n = a.len() as f64;
    let mean = |px: &[[f32; 3]], c: usize| px.iter().map(|p| p[c] as f64).sum::<f64>() / n;
    let se = |v: &[[f32; 3]], c: usize| (v.iter().map(|p| p[c] as f64).sum::<f64>()).sqrt() / n;
    let ta = (
        std::array::from_fn(|c| mean(&a, c)),
        std::array::from_fn(|c| se(&av, c)),
    );
    let tb = (
        std::array::from_fn(|c| mean(&b, c)),
        std::array::from_fn(|c| se(&bv, c)),
    );
    assert_agree("image mean vs reference", ta, tb, 4.0);
}

#[test]
fn the_check_fails_on_a_biased_image() {
    // A render shifted by 3 standard errors per pixel, and one 15 % too bright, must fail.
    let dir = scratch("oiiobias");
    let (img, var) = render_cbox(&dir, 78, 256);
    let rf = root().join("tests/reference/cornell-box-64.exr");
    let rv = root().join("tests/reference/cornell-box-64.variance.exr");
    let shifted = dir.join("shifted.exr");
    let p = |x: &std::path::Path| x.display().to_string();
    let st = std::process::Command::new("oiiotool")
        .args([
            &p(&var),
            &p(&rv),
            "--add",
            "--powc",
            "0.5",
            "--mulc",
            "3",
            &p(&img),
            "--add",
            "-o",
            &p(&shifted),
        ])
        .status()
        .unwrap();
    assert!(st.success());
    let e = z_diff(&shifted, &var, &rf, &rv, ZThresholds::default()).unwrap_err();
    assert!(e.contains("zdiff.exr"), "{e}");
    assert!(
        dir.join("shifted.zdiff.exr").exists(),
        "difference image not kept"
    );

    let bright = dir.join("bright.exr");
    let st = std::process::Command::new("oiiotool")
        .args([&p(&img), "--mulc", "1.15", "-o", &p(&bright)])
        .status()
        .unwrap();
    assert!(st.success());
    assert!(z_diff(&bright, &var, &rf, &rv, ZThresholds::default()).is_err());
}
