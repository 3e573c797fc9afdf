//! `stokes reference` through the library, in-process ([`reference::render`]):
//!
//! - a reference of 4 spp resumed with 4 more equals one reference of 8 spp (up to float
//!   summation order), and its header holds the samples `SEED:0..8`; the first 4 spp
//!   alone do not pass the same comparison (the control);
//! - a resume with another setting, and a reference that exists without `resume`, are
//!   refused with errors that name the file, and write nothing;
//! - new samples start after the ones held, per seed ([`next_free_sample`]).

mod common;
use common::*;
use std::collections::BTreeMap;
use std::path::Path;
use stokes::error::{Detail, Error};
use stokes::header::{format_ranges, next_free_sample, parse_ranges};
use stokes::output::{read_exr, variance_path};
use stokes::scene::Scene;
use stokes::tools::reference::{self, Job, Report};

const SEED: u64 = 3;

/// The Cornell box at `t`'s size.
fn cornell(t: &TestRender) -> Scene {
    let mut scene = scene_file("cornell-box.toml");
    scene.set_resolution(t.size.0, t.size.1);
    scene
}

/// Small, single-threaded, seed [`SEED`], depth 5.
fn settings() -> TestRender {
    TestRender::at(8, 8).seed(SEED).threads(1).max_depth(5)
}

/// Renders (or with `resume`, extends) the reference `out` with `spp` more samples, in
/// passes of 1 spp.
fn run(
    scene: &Scene,
    t: &TestRender,
    out: &Path,
    spp: u32,
    resume: bool,
) -> stokes::Result<Report> {
    run_in_passes(scene, t, out, spp, resume, 1)
}

/// [`run`] in passes of `pass_spp`.
fn run_in_passes(
    scene: &Scene,
    t: &TestRender,
    out: &Path,
    spp: u32,
    resume: bool,
    pass_spp: u32,
) -> stokes::Result<Report> {
    let job = Job {
        scene,
        opts: &t.opts,
        spp,
        pass_spp,
        out,
        resume,
        stop: None,
    };
    reference::render(&job, &mut |_| {})
}

/// The largest relative difference between two images' channels.
fn max_relative_difference(x: &[[f32; 3]], y: &[[f32; 3]]) -> f64 {
    assert_eq!(x.len(), y.len());
    x.iter()
        .flatten()
        .zip(y.iter().flatten())
        .map(|(&u, &v)| ((u - v).abs() / v.abs().max(1e-6)) as f64)
        .fold(0.0, f64::max)
}

/// Every file in `dir`, by name, with its bytes.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().into_string().unwrap(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect()
}

fn header_attributes(path: &Path) -> BTreeMap<String, String> {
    read_exr(path).unwrap().3.into_iter().collect()
}

#[test]
fn resumed_reference_equals_one_reference_of_the_total_spp() {
    let dir = scratch("reference-resume");
    let t = settings();
    let scene = cornell(&t);
    let (parts, whole) = (dir.join("parts.exr"), dir.join("whole.exr"));

    let first = run(&scene, &t, &parts, 4, false).unwrap();
    assert_eq!(format_ranges(&first.header.ranges), "3:0..4");
    let first_pixels = read_exr(&parts).unwrap().2;
    let resumed = run(&scene, &t, &parts, 4, true).unwrap();
    assert_eq!(resumed.added, 4);
    assert_eq!(format_ranges(&resumed.header.ranges), "3:0..8");
    assert_eq!(resumed.variance, variance_path(&parts));
    run(&scene, &t, &whole, 8, false).unwrap();

    let meta = header_attributes(&parts);
    assert_eq!(meta["sample_ranges"], "3:0..8");
    assert_eq!(meta["spp"], "8");
    assert_eq!(
        header_attributes(&variance_path(&parts))["sample_ranges"],
        "3:0..8"
    );
    let (a, b) = (read_exr(&parts).unwrap().2, read_exr(&whole).unwrap().2);
    let d = max_relative_difference(&a, &b);
    assert!(
        d < 1e-5,
        "4 + 4 spp against 8 spp: relative difference {d:.2e}"
    );
    let va = read_exr(&variance_path(&parts)).unwrap().2;
    let vb = read_exr(&variance_path(&whole)).unwrap().2;
    let dv = max_relative_difference(&va, &vb);
    assert!(dv < 1e-4, "variances: relative difference {dv:.2e}");
    // Control: the comparison tells 4 spp from 8.
    let d4 = max_relative_difference(&first_pixels, &b);
    assert!(
        d4 > 1e-3,
        "4 spp against 8 spp: relative difference only {d4:.2e}"
    );
}

#[test]
fn passes_of_several_samples_give_the_same_reference() {
    // Packet rays, whose tracer fills and drains its paths once per pass: the pass size
    // changes which lanes carry a sample, never its bits or the order of the sums.
    let dir = scratch("reference-passes");
    let t = settings().rays(stokes::method::Rays::Packet);
    let scene = cornell(&t);
    let (ones, fours) = (dir.join("ones.exr"), dir.join("fours.exr"));
    let a = run_in_passes(&scene, &t, &ones, 6, false, 1).unwrap();
    let b = run_in_passes(&scene, &t, &fours, 6, false, 4).unwrap();
    assert_eq!((a.passes, b.passes), (6, 2));
    assert_eq!(read_exr(&ones).unwrap().2, read_exr(&fours).unwrap().2);
    assert_eq!(
        read_exr(&variance_path(&ones)).unwrap().2,
        read_exr(&variance_path(&fours)).unwrap().2
    );
    assert_eq!(header_attributes(&fours)["sample_ranges"], "3:0..6");
}

#[test]
fn a_resume_that_does_not_fit_is_refused_and_writes_nothing() {
    let dir = scratch("reference-refused");
    let t = settings();
    let scene = cornell(&t);
    let out = dir.join("ref.exr");
    run(&scene, &t, &out, 4, false).unwrap();
    let before = files(&dir);
    assert_eq!(before.len(), 2, "{:?}", before.keys());

    let e = run(&scene, &t.clone().max_depth(2), &out, 4, true).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "--resume: {} was rendered with max_depth = 5 but this run has max_depth = 2: resume with the same settings",
            out.display()
        )
    );
    match &e {
        Error::Option {
            option,
            detail: Detail::Cause(cause),
        } => {
            assert_eq!(option, "--resume");
            assert!(
                matches!(&**cause, Error::About { file, .. } if file == &out),
                "{cause:?}"
            );
        }
        _ => panic!(
            "expected an error of --resume about {}: {e:?}",
            out.display()
        ),
    }
    assert_eq!(files(&dir), before, "a refused resume wrote");

    let e = run(&scene, &t, &out, 4, false).unwrap_err();
    assert!(
        matches!(&e, Error::File { file, line: None, .. } if file == &out),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .contains("the reference exists: pass --resume to add 4 samples"),
        "{e}"
    );
    assert_eq!(files(&dir), before, "a refused reference wrote");
}

#[test]
fn new_samples_start_after_the_held_ones_of_their_seed() {
    let dir = scratch("reference-seeds");
    let t = settings();
    let scene = cornell(&t);
    let out = dir.join("ref.exr");
    run(&scene, &t, &out, 4, false).unwrap();
    // Another seed's streams are independent of seed 3's: its samples start at 0.
    let other = run(&scene, &t.clone().seed(5), &out, 2, true).unwrap();
    assert_eq!(format_ranges(&other.header.ranges), "3:0..4 5:0..2");
    let again = run(&scene, &t, &out, 4, true).unwrap();
    let ranges = &again.header.ranges;
    assert_eq!(format_ranges(ranges), "3:0..8 5:0..2");
    assert_eq!(header_attributes(&out)["sample_ranges"], "3:0..8 5:0..2");
    assert_eq!(header_attributes(&out)["spp"], "10");
    assert_eq!(next_free_sample(ranges, 3), 8);
    assert_eq!(next_free_sample(ranges, 5), 2);
    assert_eq!(next_free_sample(ranges, 9), 0);
    // After a gap, new samples go after the last range, not into the gap (which other
    // parts may hold).
    let gapped = parse_ranges("3:0..4 3:16..20").unwrap();
    assert_eq!(next_free_sample(&gapped, 3), 20);
}

#[test]
fn a_spectral_reference_resumes_every_bin_and_only_with_the_same_bins() {
    use stokes::spectral_exr::Bins;
    use stokes::tools::merge::Part;
    let dir = scratch("reference-spectral");
    let mut t = settings();
    t.opts.bins = Some(Bins::new(10, 400.0, 700.0).unwrap());
    let scene = cornell(&t);
    let (parts, whole) = (dir.join("parts.exr"), dir.join("whole.exr"));
    run(&scene, &t, &parts, 3, false).unwrap();
    let first = Part::read(&parts).unwrap().planes;
    run(&scene, &t, &parts, 5, true).unwrap();
    run(&scene, &t, &whole, 8, false).unwrap();
    let (a, b) = (Part::read(&parts).unwrap(), Part::read(&whole).unwrap());
    assert_eq!(a.planes.len(), 10);
    assert!(max_plane_difference(&a.planes, &b.planes) < 1e-5);
    let (va, vb) = (a.read_variance("").unwrap(), b.read_variance("").unwrap());
    assert!(max_plane_difference(&va.planes, &vb.planes) < 1e-4);
    assert!(
        max_plane_difference(&first, &b.planes) > 1e-3,
        "the control: 3 spp is not 8"
    );

    // Other bins, or none, do not resume it; nothing is written.
    let before = files(&dir);
    for bins in [Some(Bins::new(5, 400.0, 700.0).unwrap()), None] {
        let mut other = t.clone();
        other.opts.bins = bins;
        let e = run(&scene, &other, &parts, 2, true)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("has 10 spectral channels") && e.contains("--spectral-bins"),
            "{e}"
        );
    }
    assert_eq!(files(&dir), before);
}
