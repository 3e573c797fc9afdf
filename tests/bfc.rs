//! Measured bispectral matrices in the Labsphere BFC-450 format (`stokes::fluoro::bfc`):
//! the eight files of the RIT database in `../shared/data/bispectral/` import with a
//! report, and a sphere of each in a uniform D65 furnace returns, per wavelength, what a
//! quadrature of the file's own numbers says (read here by a parser of its own), so that
//! neither the importer's grid nor its units are taken on trust.
//!
//! The files stay outside the repository (`../shared`, beside it). Where it is missing
//! these tests say so and pass, unless `STOKES_REQUIRE_SHARED_DATA=1` (CI sets it), which
//! turns a missing directory into a failure. `STOKES_SHARED_DATA` points elsewhere.

mod common;
use common::*;
use std::path::PathBuf;
use stokes::bsdf::Material;
use stokes::fluoro::{MatrixReport, Reradiation};
use stokes::spectrum::{illuminant, Spectrum};

const FILES: [&str; 8] = [
    "CIBA12.BFC",
    "CIPLAW10.BFC",
    "HERPICER.BFC",
    "HERPIORA.BFC",
    "IXCRLALE.BFC",
    "PHP8HP1C.BFC",
    "POLGREE.BFC",
    "TEXTYELL.BFC",
];

/// The directory of the BFC files, or None (with a notice) where it is missing and not
/// required.
fn bispectral_dir() -> Option<PathBuf> {
    let candidates = [
        std::env::var_os("STOKES_SHARED_DATA").map(|d| PathBuf::from(d).join("bispectral")),
        Some(root().join("../shared/data/bispectral")),
        Some(PathBuf::from("/work/shared/data/bispectral")),
    ];
    if let Some(d) = candidates
        .into_iter()
        .flatten()
        .find(|d| d.join(FILES[0]).is_file())
    {
        return Some(d);
    }
    let required = std::env::var("STOKES_REQUIRE_SHARED_DATA").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "the BFC files are missing (looked in $STOKES_SHARED_DATA/bispectral, ../shared/data/bispectral)"
    );
    eprintln!("NOTICE: ../shared/data/bispectral not found; the BFC tests did not run");
    None
}

/// The file's matrix as written: (emission wavelengths, excitation wavelengths, rows).
fn raw(path: &std::path::Path) -> (Vec<f64>, Vec<f64>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut excitation = Vec::new();
    let mut emission = Vec::new();
    let mut rows = Vec::new();
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.first() == Some(&"r:c:") {
            excitation = f[1..].iter().map(|x| x.parse().unwrap()).collect();
        } else if !excitation.is_empty() && f.len() == excitation.len() + 1 {
            emission.push(f[0].parse().unwrap());
            rows.push(f[1..].iter().map(|x| x.parse().unwrap()).collect());
        }
    }
    (emission, excitation, rows)
}

#[test]
fn all_eight_files_import_with_a_report() {
    let Some(dir) = bispectral_dir() else { return };
    for name in FILES {
        let path = dir.join(name);
        let (rr, report) = Reradiation::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let MatrixReport::Bfc(r) = &report else {
            panic!("{name}: not read as BFC")
        };
        let gains = rr.energy_gain_rows();
        println!(
            "{name} ({}): {report}; {} cells of {} nm; energy-gaining excitation cells: {:?}",
            r.sample.as_deref().unwrap_or("?"),
            rr.cells(),
            rr.cell_nm(),
            gains
                .iter()
                .map(|(l, t)| format!("{l} nm: {t:.3}"))
                .collect::<Vec<_>>()
        );
        assert_eq!(r.excitation_dropped, Some((300.0, 350.0, 6)), "{name}");
        assert_eq!(r.emission_unmeasured, Some((360.0, 370.0)), "{name}");
        assert_eq!(r.held_above, Some(780.0), "{name}");
        assert_eq!(
            rr.d(829.0),
            rr.d(780.0),
            "{name}: reflectance held above 785 nm"
        );
        assert!(
            r.clamped.clamped_negative > 0,
            "{name}: measurement noise expected"
        );
        assert_eq!(rr.cells(), 43, "{name}: 360–780 nm in 10 nm cells");
        assert!(
            (0.0..=1.2).contains(&rr.d(550.0)),
            "{name}: D(550) = {}",
            rr.d(550.0)
        );
    }
}

/// What the file's numbers give for a Lambertian sphere in a uniform furnace of light L
/// at the emission wavelength `lo` (a cell centre): m(lo, lo)·L(lo) plus, for every
/// excitation cell wholly below lo's cell and inside the rendered range, m(λx → lo) times
/// the mean of L over that cell (its part above 360 nm for the first), negatives as 0.
fn quadrature(path: &std::path::Path, lo: f64, light: &Spectrum) -> f64 {
    let (emission, excitation, rows) = raw(path);
    let r = emission
        .iter()
        .position(|&e| (e - lo).abs() < 1e-6)
        .unwrap();
    let h = excitation[1] - excitation[0];
    let mean_light = |a: f64, b: f64| {
        let n = 200;
        (0..n)
            .map(|k| f64::from(light.eval((a + (b - a) * (k as f64 + 0.5) / n as f64) as f32)))
            .sum::<f64>()
            / n as f64
    };
    let mut total = 0.0;
    for (x, &lx) in excitation.iter().enumerate() {
        let v = rows[r][x].max(0.0);
        if (lx - lo).abs() < 1e-6 {
            total += v * f64::from(light.eval(lo as f32));
        } else if lx < lo {
            let (a, b) = ((lx - h / 2.0).max(360.0), lx + h / 2.0);
            if b > a {
                // m is per cell of width h; the part of the cell in range keeps (b − a)/h.
                total += v * mean_light(a, b) * (b - a) / h;
            }
        }
    }
    total
}

#[test]
fn measured_spheres_in_a_d65_furnace_match_a_quadrature_of_the_file() {
    let Some(dir) = bispectral_dir() else { return };
    let light = Spectrum::Scaled(Box::new(illuminant("D65").unwrap()), 0.01);
    for (k, name) in FILES.iter().enumerate() {
        let path = dir.join(name);
        let material = format!("type = \"fluorescent_diffuse\"\nmatrix = \"{}\"", s(&path));
        let scene = scene_from(&enclosure(&material, "\"D65\", scale = 0.01", 64, ""));
        let ray = scene.camera.ray(8.0, 8.0);
        for lo in [450.0f32, 520.0, 580.0, 650.0] {
            let want = quadrature(&path, f64::from(lo), &light);
            let (mean, se) = mono_estimate(&scene, ray, lo, 40_000, 100 + k as u64);
            let tol = 4.0 * se + 1e-3 * want;
            println!("{name}, λo {lo}: render {mean:.5} ± {se:.5}, file {want:.5}");
            assert!(
                (mean - want).abs() <= tol,
                "{name} at {lo} nm: render {mean} vs the file's {want} (tolerance {tol})"
            );
        }
    }
}

#[test]
fn fluorescent_samples_differ_from_their_diagonal_and_whites_glow_blue() {
    let Some(dir) = bispectral_dir() else { return };
    let light = Spectrum::Scaled(Box::new(illuminant("D65").unwrap()), 0.01);
    for (name, lo) in [
        ("IXCRLALE.BFC", 530.0f64), // Crayola "laser lemon": yellow-green emission
        ("HERPIORA.BFC", 600.0),    // Hercules orange pigment
        ("POLGREE.BFC", 520.0),     // Labsphere green
        ("CIBA12.BFC", 440.0),      // a white plastic's optical brightener: blue
        ("CIPLAW10.BFC", 440.0),
    ] {
        let path = dir.join(name);
        let (rr, _) = Reradiation::from_file(&path).unwrap();
        let total = quadrature(&path, lo, &light);
        let diagonal = f64::from(rr.d(lo as f32) * light.eval(lo as f32));
        println!(
            "{name} at {lo} nm under D65: {total:.5} with re-emission, {diagonal:.5} diagonal only"
        );
        assert!(
            total > 1.1 * diagonal,
            "{name}: re-emission adds only {:.1} %",
            100.0 * (total / diagonal - 1.0)
        );
        let Material::FluorescentDiffuse { reradiation, .. } = &scene_from(&enclosure(
            &format!("type = \"fluorescent_diffuse\"\nmatrix = \"{}\"", s(&path)),
            "1.0",
            8,
            "",
        ))
        .materials[0] else {
            panic!("not fluorescent")
        };
        assert!(reradiation.is_fluorescent(), "{name}");
    }
}

#[test]
fn a_bfc_file_with_a_bad_row_is_one_line_naming_file_and_line() {
    let Some(dir) = bispectral_dir() else { return };
    let text = std::fs::read_to_string(dir.join("POLGREE.BFC")).unwrap();
    let scratch = scratch("bfc");
    let truncated: String = text.lines().take(40).collect::<Vec<_>>().join("\n");
    let cases = [
        ("truncated.BFC", truncated, "truncated"),
        (
            "nan.BFC",
            text.replacen("\t0.", "\tx.", 1),
            "expected a number in column",
        ),
        // The sampling line (380 780 10 49 300 10): a zero excitation step, and a column
        // count that is not whole, each with the other numbers as measured.
        (
            "zero-step.BFC",
            text.replacen("\t49\t300\t10", "\t49\t300\t0", 1),
            "positive steps",
        ),
        (
            "half-column.BFC",
            text.replacen("\t49\t300\t10", "\t48.5\t300\t10", 1),
            "positive steps",
        ),
    ];
    for (file, body, want) in cases {
        let path = scratch.join(file);
        std::fs::write(&path, body).unwrap();
        let e = Reradiation::from_file(&path).unwrap_err().to_string();
        println!("{e}");
        assert!(e.contains(file) && e.contains(want), "{e}");
        assert_eq!(e.lines().count(), 1);
    }
}

#[test]
fn convert_bispectral_writes_a_csv_that_reads_back_as_the_same_matrix() {
    let Some(dir) = bispectral_dir() else { return };
    let out = scratch("bfc-convert");
    for name in ["IXCRLALE.BFC", "CIBA12.BFC"] {
        let csv = out.join(name.replace(".BFC", ".csv"));
        let (ok, _, err) =
            run(stokes().args(["convert-bispectral", &s(&dir.join(name)), "-o", &s(&csv)]));
        assert!(ok, "{err}");
        assert!(err.contains("dropped 6 excitation column(s)"), "{err}");
        let (a, _) = Reradiation::from_file(&dir.join(name)).unwrap();
        let (b, report) = Reradiation::from_file(&csv).unwrap();
        assert!(
            matches!(report, MatrixReport::Csv(r) if r.is_clean()),
            "{report}"
        );
        assert_eq!(a.cells(), b.cells());
        for li in (360..780).step_by(7).map(|l| l as f32 + 0.5) {
            let (da, db) = (a.d(li), b.d(li));
            assert!(
                (da - db).abs() <= 1e-6 * da.abs().max(1e-3),
                "{name}: D({li}) {da} vs {db}"
            );
            for lo in (360..790).step_by(9).map(|l| l as f32 + 0.25) {
                let (fa, fb) = (a.f(li, lo), b.f(li, lo));
                assert!(
                    (fa - fb).abs() <= 1e-6 * fa.abs().max(1e-6),
                    "{name}: F({li}, {lo}) {fa} vs {fb}"
                );
            }
        }
    }
    // Neither a CSV nor an EXR name: an error, nothing written.
    let (ok, _, err) = run(stokes().args([
        "convert-bispectral",
        &s(&dir.join("POLGREE.BFC")),
        "-o",
        &s(&out.join("x.txt")),
    ]));
    assert!(!ok && err.contains("ending in .csv or .exr"), "{err}");
    assert!(!out.join("x.txt").exists());
}
