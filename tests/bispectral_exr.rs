//! Spectral and bispectral OpenEXR as inputs and outputs (issue 17, parts 2 and 3), in
//! the layout of Fichet, Pacanowski and Wilkie (`stokes::spectral_exr`):
//!
//! - a re-radiation matrix written as a bispectral EXR (`Reradiation::to_exr`, `stokes
//!   convert-bispectral -o X.exr`) reads back cell by cell, and renders bit for bit like
//!   the CSV that `to_csv` writes; a measured BFC file survives BFC → EXR → matrix;
//! - malformed bispectral files are one-line errors naming the file and the channel;
//! - `{ exr = "file.exr" }` as a spectrum takes the `T.` (or else `S0.`) channels,
//!   averaged over the pixels, and renders like the same numbers given as a table.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use stokes::bsdf::Material;
use stokes::fluoro::{MatrixReport, Reradiation};
use stokes::output::{write_exr_planes, Plane};
use stokes::scene::Scene;
use stokes::spectral_exr::{channel_name, SpectralChannel, LAYOUT_VERSION};
use stokes::spectrum::{Spectrum, Tabulated};

/// A dye on `cell` nm cells over a diagonal that varies with wavelength.
fn dye(cell: f32) -> Reradiation {
    let diagonal = Spectrum::Tabulated(
        Tabulated::new(vec![360.0, 500.0, 830.0], vec![0.1, 0.3, 0.55]).unwrap(),
    );
    let absorption = Spectrum::Tabulated(
        Tabulated::new(vec![360.0, 440.0, 515.0], vec![0.35, 0.9, 0.0]).unwrap(),
    );
    let emission = Spectrum::narrow_band(560.0, 50.0).unwrap();
    Reradiation::from_dye(diagonal, &absorption, &emission, 0.85, cell).unwrap()
}

/// `a` and `b` hold the same matrix: the same grid, and at every cell centre the same
/// diagonal and re-radiated fraction F·h, to `tol` relative (0 for bit equality).
fn assert_same_matrix(what: &str, a: &Reradiation, b: &Reradiation, tol: f32) {
    assert_eq!(a.cells(), b.cells(), "{what}: cells");
    assert_eq!(a.cell_nm(), b.cell_nm(), "{what}: cell width");
    let close = |x: f32, y: f32| (x - y).abs() <= tol * x.abs().max(y.abs());
    let h = a.cell_nm();
    let mut fluorescent = 0;
    for i in 0..a.cells() {
        let ci = a.cell_centre(i);
        assert_eq!(ci, b.cell_centre(i), "{what}: centre {i}");
        assert!(
            close(a.d(ci), b.d(ci)),
            "{what}: D({ci}) {} vs {}",
            a.d(ci),
            b.d(ci)
        );
        for o in i + 1..a.cells() {
            let co = a.cell_centre(o);
            let (fa, fb) = (a.f(ci, co) * h, b.f(ci, co) * h);
            assert!(close(fa, fb), "{what}: F·h({ci} → {co}) {fa} vs {fb}");
            fluorescent += usize::from(fa > 0.0);
        }
    }
    assert!(
        fluorescent > 10,
        "{what}: only {fluorescent} shifting cells"
    );
}

#[test]
fn a_dye_round_trips_through_a_bispectral_exr_and_renders_like_its_csv() {
    let dir = scratch("bispec-dye");
    let rr = dye(5.0);
    let exr = dir.join("dye.exr");
    rr.to_exr(&exr, &[("note".into(), "a test dye".into())])
        .unwrap();
    let (back, report) = Reradiation::from_file(&exr).unwrap();
    assert!(
        matches!(report, MatrixReport::Exr(r) if r.is_clean() && r.pixels == 1),
        "{report}"
    );
    // The numbers written are F·h in f32; F read back is that over h.
    assert_same_matrix("EXR read back", &rr, &back, 2.0 * f32::EPSILON);

    // The CSV `to_csv` writes holds the same numbers (shortest round-trip decimals):
    // both files give the same matrix, bit for bit, and the same render.
    let csv = dir.join("dye.csv");
    std::fs::write(&csv, rr.to_csv("a test dye").unwrap()).unwrap();
    let (from_csv, _) = Reradiation::from_file(&csv).unwrap();
    assert_same_matrix("EXR against CSV", &from_csv, &back, 0.0);
    let film = |file: &Path| {
        let material = format!("type = \"fluorescent_diffuse\"\nmatrix = \"{}\"", s(file));
        let mut scene = scene_from(&enclosure(&material, "\"D65\", scale = 0.01", 16, ""));
        TestRender::at(16, 16)
            .spp(4)
            .seed(11)
            .film(&mut scene)
            .mean()
    };
    let (a, b) = (film(&exr), film(&csv));
    assert!(a.iter().flatten().any(|&v| v > 0.0));
    assert!(a == b, "the EXR and CSV renders differ");

    // R, G, B: the diagonal's colour under D65 (grey-ish, reddening: 0.1 → 0.55).
    let ch = stokes::output::Channels::read(&exr).unwrap();
    let get = |n: &str| ch.planes.iter().find(|p| p.name == n).unwrap().data[0];
    let (r, g, b) = (get("R"), get("G"), get("B"));
    assert!(r > g && g > b && b > 0.05 && r < 0.6, "RGB {r} {g} {b}");
    let version = ch.text.iter().find(|(k, _)| k == LAYOUT_VERSION.0);
    assert_eq!(version.map(|v| v.1.as_str()), Some(LAYOUT_VERSION.1));
    let n = rr.cells();
    assert_eq!(ch.planes.len(), 3 + n + n * (n - 1) / 2);
}

/// The BFC files of the RIT database, as tests/bfc.rs finds them (None, with a notice,
/// where they are missing and not required).
fn bfc_file(name: &str) -> Option<PathBuf> {
    let candidates = [
        std::env::var_os("STOKES_SHARED_DATA").map(|d| PathBuf::from(d).join("bispectral")),
        Some(root().join("../shared/data/bispectral")),
        Some(PathBuf::from("/work/shared/data/bispectral")),
    ];
    if let Some(p) = candidates
        .into_iter()
        .flatten()
        .map(|d| d.join(name))
        .find(|p| p.is_file())
    {
        return Some(p);
    }
    let required = std::env::var("STOKES_REQUIRE_SHARED_DATA").is_ok_and(|v| v == "1");
    assert!(!required, "{name} is missing (../shared/data/bispectral)");
    eprintln!("NOTICE: ../shared/data/bispectral not found; the BFC → EXR test did not run");
    None
}

#[test]
fn a_bfc_file_converted_to_exr_reads_back_as_the_same_matrix() {
    let Some(bfc) = bfc_file("IXCRLALE.BFC") else {
        return;
    };
    let exr = scratch("bispec-bfc").join("IXCRLALE.exr");
    let (ok, _, err) = run(stokes().args(["convert-bispectral", &s(&bfc), "-o", &s(&exr)]));
    assert!(ok, "{err}");
    assert!(err.contains("dropped 6 excitation column(s)"), "{err}");
    let (direct, _) = Reradiation::from_file(&bfc).unwrap();
    let (back, report) = Reradiation::from_file(&exr).unwrap();
    assert!(
        matches!(report, MatrixReport::Exr(r) if r.is_clean()),
        "{report}"
    );
    // 10 nm cells: F·h is rounded once to f32 on the way out and divided by h on the
    // way in.
    assert_same_matrix("BFC → EXR", &direct, &back, 4.0 * f32::EPSILON);
    let ch = stokes::output::Channels::read(&exr).unwrap();
    assert!(ch
        .text
        .iter()
        .any(|(k, v)| k == "stokes:source" && v.ends_with("IXCRLALE.BFC")));
}

/// The error loading the scene `text` as if from `path`.
fn load_error(text: &str, path: &Path) -> String {
    match Scene::from_str(text, path) {
        Ok(_) => panic!("the scene loaded"),
        Err(e) => e.to_string(),
    }
}

/// Writes a one-pixel EXR of the layout with diagonal `(nm, value)` and bispectral
/// `(λi, λo, value)` channels, plus R, G, B.
fn write_matrix(path: &Path, diagonal: &[(f64, f32)], pairs: &[(f64, f64, f32)]) {
    let mut planes: Vec<Plane> = diagonal
        .iter()
        .map(|&(nm, v)| Plane {
            name: channel_name(SpectralChannel::Reflective { nm }),
            data: vec![v],
        })
        .collect();
    planes.extend(pairs.iter().map(|&(input, output, v)| Plane {
        name: channel_name(SpectralChannel::Bispectral { input, output }),
        data: vec![v],
    }));
    write_exr_planes(path, 1, 1, &[[0.5; 3]], &planes, &[], &[LAYOUT_VERSION]).unwrap();
}

/// A diagonal as (nm, value).
type Diagonal = Vec<(f64, f32)>;
/// Bispectral channels as (λi, λo, value).
type Pairs = Vec<(f64, f64, f32)>;

/// Every pair of `grid` with a value.
fn all_pairs(grid: &[f64]) -> Pairs {
    let mut p = Vec::new();
    for (i, &a) in grid.iter().enumerate() {
        for &b in &grid[i + 1..] {
            p.push((a, b, 0.01));
        }
    }
    p
}

#[test]
fn malformed_bispectral_files_are_one_line_naming_file_and_channel() {
    let dir = scratch("bispec-bad");
    let grid = [400.0, 410.0, 420.0, 430.0];
    let diag: Vec<(f64, f32)> = grid.iter().map(|&l| (l, 0.5)).collect();
    // A good file reads, to be sure the cases below fail for their one fault.
    write_matrix(&dir.join("good.exr"), &diag, &all_pairs(&grid));
    let (rr, _) = Reradiation::from_file(&dir.join("good.exr")).unwrap();
    assert_eq!((rr.cells(), rr.cell_nm()), (4, 10.0));
    assert!((rr.f(405.0, 425.0) - 0.001).abs() < 1e-9);

    let mut backwards = all_pairs(&grid);
    backwards.push((420.0, 410.0, 0.01));
    let mut equal = all_pairs(&grid);
    equal.push((420.0, 420.0, 0.01));
    let mut off_grid = all_pairs(&grid);
    off_grid.push((410.0, 440.0, 0.01));
    let mut between = all_pairs(&grid);
    between.push((400.0, 415.0, 0.01));
    let ragged: Vec<_> = all_pairs(&grid)
        .into_iter()
        .filter(|p| *p != (400.0, 420.0, 0.01))
        .collect();
    let uneven = [400.0, 410.0, 425.0, 430.0];
    let uneven_diag: Vec<(f64, f32)> = uneven.iter().map(|&l| (l, 0.5)).collect();
    let cases: Vec<(&str, Diagonal, Pairs, &str)> = vec![
        ("backwards.exr", diag.clone(), backwards, "T.420,000000nm.410,000000nm"),
        ("equal.exr", diag.clone(), equal, "T.420,000000nm.420,000000nm"),
        (
            "no_diagonal.exr",
            [&diag[..2], &diag[3..]].concat(),
            all_pairs(&grid),
            "uses 420 nm, which has no diagonal channel T.420,000000nm",
        ),
        (
            "no_last_diagonal.exr",
            diag[..3].to_vec(),
            all_pairs(&grid),
            "uses 430 nm, which has no diagonal channel T.430,000000nm",
        ),
        (
            "between.exr",
            diag.clone(),
            between,
            "channel T.400,000000nm.415,000000nm uses 415 nm",
        ),
        (
            "off_grid.exr",
            diag.clone(),
            off_grid,
            "channel T.410,000000nm.440,000000nm uses 440 nm",
        ),
        (
            "ragged.exr",
            diag.clone(),
            ragged,
            "missing channel T.400,000000nm.420,000000nm",
        ),
        (
            "uneven.exr",
            uneven_diag,
            all_pairs(&uneven),
            "evenly spaced (one per cell; a non-uniform grid is not resampled): channel T.425,000000nm",
        ),
        ("no_pairs.exr", diag.clone(), vec![], "only reflective channels"),
    ];
    for (file, d, p, want) in cases {
        let path = dir.join(file);
        write_matrix(&path, &d, &p);
        let e = Reradiation::from_file(&path).unwrap_err().to_string();
        println!("{e}");
        assert!(e.contains(&s(&path)) && e.contains(want), "{file}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }

    // No T channels at all: an RGB image, and an emissive spectral one.
    let rgb = dir.join("rgb.exr");
    write_exr_planes(&rgb, 1, 1, &[[0.5; 3]], &[], &[], &[]).unwrap();
    let e = Reradiation::from_file(&rgb).unwrap_err().to_string();
    assert!(
        e.contains(&s(&rgb)) && e.contains("no spectral channels"),
        "{e}"
    );
    let emissive = dir.join("emissive.exr");
    let s0 = Plane {
        name: "S0.550,000000nm".into(),
        data: vec![1.0],
    };
    write_exr_planes(&emissive, 1, 1, &[[0.5; 3]], &[s0], &[], &[]).unwrap();
    let e = Reradiation::from_file(&emissive).unwrap_err().to_string();
    assert!(
        e.contains(&s(&emissive))
            && e.contains("no T. channels (spectral channels: S0.550,000000nm)"),
        "{e}"
    );

    // Through a scene: the key, the file and the channel, on one line.
    let scene_path = dir.join("scene.toml");
    let text = enclosure(
        "type = \"fluorescent_diffuse\"\nmatrix = \"ragged.exr\"",
        "1.0",
        8,
        "",
    );
    let e = load_error(&text, &scene_path);
    println!("{e}");
    for want in [
        "materials.sphere.matrix",
        "ragged.exr",
        "missing channel T.400,000000nm.420,000000nm",
    ] {
        assert!(e.contains(want), "{want} not in: {e}");
    }
    assert_eq!(e.lines().count(), 1);
}

#[test]
fn a_bispectral_image_is_averaged_over_its_pixels_and_says_so() {
    let dir = scratch("bispec-avg");
    let path = dir.join("two_by_two.exr");
    let grid = [500.0, 510.0];
    let plane = |c: SpectralChannel, v: [f32; 4]| Plane {
        name: channel_name(c),
        data: v.to_vec(),
    };
    let planes = vec![
        plane(
            SpectralChannel::Reflective { nm: grid[0] },
            [0.1, 0.2, 0.3, 0.4],
        ),
        plane(SpectralChannel::Reflective { nm: grid[1] }, [0.5; 4]),
        plane(
            SpectralChannel::Bispectral {
                input: grid[0],
                output: grid[1],
            },
            [0.0, 0.0, 0.0, 0.08],
        ),
    ];
    write_exr_planes(&path, 2, 2, &[[0.0; 3]; 4], &planes, &[], &[]).unwrap();
    let (rr, report) = Reradiation::from_file(&path).unwrap();
    let MatrixReport::Exr(r) = report else {
        panic!("{report}")
    };
    assert_eq!(r.pixels, 4);
    assert!(!report.is_clean() && report.to_string().contains("over 4 pixels"));
    assert!((rr.d(500.0) - 0.25).abs() < 1e-7, "{}", rr.d(500.0));
    assert!((rr.f(502.0, 512.0) * 10.0 - 0.02).abs() < 1e-8);
}

/// Writes a `w`×`h` EXR whose channels are `channels[k]` with values `values[k]`.
fn write_spectral(path: &Path, w: u32, h: u32, channels: &[(String, Vec<f32>)]) {
    let planes: Vec<Plane> = channels
        .iter()
        .map(|(n, v)| Plane {
            name: n.clone(),
            data: v.clone(),
        })
        .collect();
    let rgb = vec![[0.2f32; 3]; (w * h) as usize];
    write_exr_planes(path, w, h, &rgb, &planes, &[], &[LAYOUT_VERSION]).unwrap();
}

#[test]
fn spectra_from_spectral_exrs_are_their_channels_averaged() {
    let dir = scratch("bispec-spectrum");
    let nm = [400.0, 500.0, 600.0, 700.0];
    let values = [0.2f32, 0.6, 0.4, 0.3];
    let named = |c: fn(f64) -> SpectralChannel, v: &[f32]| -> Vec<(String, Vec<f32>)> {
        nm.iter()
            .zip(v)
            .map(|(&l, &x)| (channel_name(c(l)), vec![x]))
            .collect()
    };
    let reflective = |l| SpectralChannel::Reflective { nm: l };
    let emissive = |l| SpectralChannel::Emissive { stokes: 0, nm: l };
    write_spectral(&dir.join("swatch.exr"), 1, 1, &named(reflective, &values));
    let radiance: Vec<f32> = values.iter().map(|v| v * 3.0).collect();
    write_spectral(&dir.join("lamp.exr"), 1, 1, &named(emissive, &radiance));
    // A 2×2 swatch whose pixels average to `values`; with some S0 channels beside it
    // that must not be taken (T. comes first).
    let mut quad: Vec<(String, Vec<f32>)> = nm
        .iter()
        .zip(values)
        .map(|(&l, v)| {
            (
                channel_name(reflective(l)),
                vec![v - 0.1, v + 0.1, v - 0.05, v + 0.05],
            )
        })
        .collect();
    quad.push((channel_name(emissive(550.0)), vec![9.0; 4]));
    write_spectral(&dir.join("quad.exr"), 2, 2, &quad);

    let table = |v: &[f32]| {
        format!(
            "{{ wavelengths = [400, 500, 600, 700], values = [{}] }}",
            v.iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    let scene_path = dir.join("scene.toml");
    let load = |material: &str, radiance: &str| {
        Scene::from_str(&enclosure(material, radiance, 16, ""), &scene_path)
            .unwrap_or_else(|e| panic!("{e}"))
    };
    let diffuse = |r: &str| format!("type = \"diffuse\"\nreflectance = {r}");
    let reflectance = |scene: &Scene| match &scene.materials[0] {
        Material::Diffuse { reflectance } => reflectance.clone(),
        _ => panic!("not diffuse"),
    };
    // Reflective and 2×2: the tabulated values, exactly at the channels, linear between.
    for file in ["swatch.exr", "quad.exr"] {
        let r = reflectance(&load(&diffuse(&format!("{{ exr = \"{file}\" }}")), "1.0"));
        for (&l, &v) in nm.iter().zip(&values) {
            assert!(
                (r.eval(l as f32) - v).abs() < 1e-6,
                "{file} at {l}: {}",
                r.eval(l as f32)
            );
        }
        assert!((r.eval(450.0) - 0.4).abs() < 1e-6, "{file}");
        assert_eq!(r.eval(380.0), 0.0, "{file}: zero outside, as a table");
    }
    // Renders: reflectance and emission from EXRs against the same numbers as tables,
    // bit for bit.
    let film = |mut scene: Scene| {
        TestRender::at(16, 16)
            .spp(4)
            .seed(5)
            .film(&mut scene)
            .mean()
    };
    let from_exr = film(load(
        &diffuse("{ exr = \"swatch.exr\" }"),
        "{ exr = \"lamp.exr\", scale = 0.1 }",
    ));
    let lamp = table(&radiance).replace(" }", ", scale = 0.1 }");
    let from_tables = film(load(&diffuse(&table(&values)), &lamp));
    assert!(from_exr.iter().flatten().any(|&v| v > 0.0));
    assert!(from_exr == from_tables, "EXR spectra render differently");

    // Neither T. nor S0.: the key and the file.
    let rgb = dir.join("rgb.exr");
    write_spectral(&rgb, 1, 1, &[]);
    let e = load_error(
        &enclosure(&diffuse("{ exr = \"rgb.exr\" }"), "1.0", 8, ""),
        &scene_path,
    );
    println!("{e}");
    for want in [
        "materials.sphere.reflectance.exr",
        "rgb.exr",
        "T.<λ>nm",
        "S0.<λ>nm",
    ] {
        assert!(e.contains(want), "{want} not in: {e}");
    }
    assert_eq!(e.lines().count(), 1);
}
