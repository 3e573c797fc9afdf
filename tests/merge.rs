//! `stokes merge` through the library, in-process ([`merge::merge`]): parts rendered on
//! disjoint sample ranges and written with their headers merge into the render of the
//! union (up to float summation order), with the pooled variance of one render of all the
//! samples; parts that differ in the method are refused and nothing is written.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use stokes::header::{RenderHeader, SampleRange};
use stokes::integrator::render::{render_progressive, Progressive, RenderOptions};
use stokes::method::Rays;
use stokes::output::{read_exr, variance_path, RenderFiles};
use stokes::scene::Scene;
use stokes::tools::merge;

/// Renders samples `[first, first + spp)` of `scene` with `opts` into `out` (and its
/// variance image), as `stokes render --seed-offset first --variance` would.
fn part(scene: &Scene, opts: &RenderOptions, first: u32, spp: u32, out: &Path) -> PathBuf {
    let prog = Progressive {
        first_sample: first,
        max_spp: Some(spp),
        batch: 1,
        ..Default::default()
    };
    let done = render_progressive(scene, opts, &prog, &|| {}, &mut |_| {}).unwrap();
    let range = SampleRange {
        seed: opts.seed,
        start: first as u64,
        end: (first + spp) as u64,
    };
    let header =
        RenderHeader::for_render(scene, opts, vec![range], done.render.seconds, done.stopped);
    let files = RenderFiles {
        exr: out.to_path_buf(),
        variance: true,
        png: false,
        stats_json: None,
    };
    files.check().unwrap();
    files.write_images(&done.render.film, &header).unwrap();
    out.to_path_buf()
}

fn pixels(path: &Path) -> Vec<[f32; 3]> {
    read_exr(path).unwrap().2
}

/// The largest relative difference between two images' channels.
fn max_relative_difference(x: &[[f32; 3]], y: &[[f32; 3]]) -> f64 {
    x.iter()
        .flatten()
        .zip(y.iter().flatten())
        .map(|(&u, &v)| ((u - v).abs() / v.abs().max(1e-6)) as f64)
        .fold(0.0, f64::max)
}

#[test]
fn parts_on_disjoint_samples_merge_into_the_render_of_all_of_them() {
    let dir = scratch("merge-in-process");
    let mut scene = scene_file("cornell-box.toml");
    scene.set_resolution(12, 12);
    let opts = RenderOptions {
        seed: 5,
        threads: 1,
        max_depth: 6,
        ..Default::default()
    };
    let a = part(&scene, &opts, 0, 6, &dir.join("a.exr"));
    let b = part(&scene, &opts, 6, 10, &dir.join("b.exr"));
    let full = part(&scene, &opts, 0, 16, &dir.join("full.exr"));
    let out = dir.join("merged.exr");
    let report = merge::merge(&[b.clone(), a.clone()], &out, true).unwrap();
    assert_eq!(report.spp, 16);
    assert_eq!(stokes::header::format_ranges(&report.ranges), "5:0..16");
    let d = max_relative_difference(&pixels(&out), &pixels(&full));
    assert!(d < 1e-5, "merged and single render differ by {d:.2e}");
    let dv = max_relative_difference(
        &pixels(&variance_path(&out)),
        &pixels(&variance_path(&full)),
    );
    assert!(dv < 1e-3, "variances differ by {dv:.2e}");
    // The control: the first part alone is not the 16-spp image.
    assert!(max_relative_difference(&pixels(&a), &pixels(&full)) > 1e-3);
    // The merged header reads back with every sample and the parts.
    let merged = merge::Part::read(&out).unwrap();
    assert_eq!(merged.spp(), 16);
    assert_eq!(merged.header.method, opts.method.resolve(&scene));
    let parts = merged.header.parts.as_deref().unwrap();
    assert!(parts.contains("a.exr (6 spp)") && parts.contains("b.exr (10 spp)"));
    assert_eq!(merged.header.stopped, None);
}

#[test]
fn parts_with_another_method_or_the_same_samples_are_refused_and_nothing_is_written() {
    let dir = scratch("merge-refused");
    let mut scene = scene_file("cornell-box.toml");
    scene.set_resolution(8, 8);
    let opts = RenderOptions {
        threads: 1,
        ..Default::default()
    };
    let a = part(&scene, &opts, 0, 2, &dir.join("a.exr"));
    let mut single = opts.clone();
    single.method.rays = Rays::Single;
    let b = part(&scene, &single, 2, 2, &dir.join("b.exr"));
    let out = dir.join("out.exr");
    let e = merge::merge(&[a.clone(), b], &out, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("was rendered with rays = single") && e.contains("rays = packet"),
        "{e}"
    );
    // Parts drawn with another hero pdf estimate the same image but are other samples
    // of another estimator: refused, naming the key.
    let mut uniform = opts.clone();
    uniform.method.wavelengths = stokes::method::Wavelengths::Uniform;
    let c = part(&scene, &uniform, 2, 2, &dir.join("c.exr"));
    let e = merge::merge(&[a.clone(), c], &out, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("was rendered with wavelengths = uniform")
            && e.contains("wavelengths = visible"),
        "{e}"
    );
    let e = merge::merge(&[a.clone(), a], &out, false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("both hold samples 0..2 of seed 0"), "{e}");
    assert!(!out.exists(), "a refused merge wrote {}", out.display());
}

#[test]
fn spectral_parts_merge_every_bin_and_refuse_other_bins() {
    let dir = scratch("merge-spectral");
    let mut scene = scene_file("cornell-box.toml");
    scene.set_resolution(8, 8);
    let opts = RenderOptions {
        seed: 2,
        threads: 1,
        max_depth: 5,
        bins: Some(stokes::spectral_exr::Bins::new(12, 400.0, 700.0).unwrap()),
        ..Default::default()
    };
    let a = part(&scene, &opts, 0, 5, &dir.join("a.exr"));
    let b = part(&scene, &opts, 5, 7, &dir.join("b.exr"));
    let full = part(&scene, &opts, 0, 12, &dir.join("full.exr"));
    let out = dir.join("merged.exr");
    merge::merge(&[a.clone(), b], &out, true).unwrap();
    let (m, f) = (
        merge::Part::read(&out).unwrap(),
        merge::Part::read(&full).unwrap(),
    );
    assert_eq!(m.planes.len(), 12);
    let d = max_plane_difference(&m.planes, &f.planes);
    assert!(
        d < 1e-5,
        "merged and single spectral render differ by {d:.2e}"
    );
    let (mv, fv) = (m.read_variance("").unwrap(), f.read_variance("").unwrap());
    let dv = max_plane_difference(&mv.planes, &fv.planes);
    assert!(dv < 1e-3, "spectral variances differ by {dv:.2e}");
    assert!(max_plane_difference(&merge::Part::read(&a).unwrap().planes, &f.planes) > 1e-3);
    // The merged file is still in the spectral layout.
    let text = stokes::output::Channels::read(&out).unwrap().text;
    assert!(text.contains(&("spectralLayoutVersion".into(), "1.0".into())));
    assert!(text.contains(&("emissiveUnits".into(), "W.m^-2.sr^-1".into())));

    // Another binning, or none, does not pool with these bins.
    let mut other = opts.clone();
    other.bins = Some(stokes::spectral_exr::Bins::new(6, 400.0, 700.0).unwrap());
    let c = part(&scene, &other, 20, 2, &dir.join("c.exr"));
    other.bins = None;
    let rgb = part(&scene, &other, 30, 2, &dir.join("rgb.exr"));
    for (p, what) in [(c, "6 channels"), (rgb, "no channels beside R, G, B")] {
        let out = dir.join("refused.exr");
        let e = merge::merge(&[a.clone(), p], &out, false)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(what) && e.contains("12 channels") && e.contains("--spectral-bins"),
            "{e}"
        );
        assert!(!out.exists());
    }
}
