//! The ColorChecker under D65: each rendered patch has the colour computed directly from
//! its reflectance spectrum (ΔE2000 ≤ 1), in both spectral modes and with both hero pdfs.

mod common;
use common::*;
use glam::Vec3;
use stokes::color::{delta_e_2000, linear_srgb_to_xyz, xyz_to_lab};
use stokes::method::{Spectral, Wavelengths};
use stokes::spectrum::{csv_column, illuminant, reflectance_to_xyz, spectrum_to_xyz, Spectrum};

const W: u32 = 150;
const H: u32 = 100;

/// Pixels well inside patch `i` (row-major from the top left), from the scene's geometry.
fn patch_pixels(i: usize) -> Vec<usize> {
    let (r, c) = (i / 6, i % 6);
    let xw = 3.6 - 0.1 - 1.2 * c as f32 - 0.5;
    let yw = 2.4 - 0.1 - 1.2 * r as f32 - 0.5;
    let tan_half = (30.2f32.to_radians() / 2.0).tan();
    let aspect = W as f32 / H as f32;
    // Camera at z = −10 looking along +z: image right is −x.
    let px = (-xw / (10.0 * tan_half * aspect) + 1.0) / 2.0 * W as f32;
    let py = (1.0 - yw / (10.0 * tan_half)) / 2.0 * H as f32;
    let half = 0.8 * 0.5 / (10.0 * tan_half) / 2.0 * H as f32; // 0.8 of a patch's half-size
    let mut v = vec![];
    for y in 0..H {
        for x in 0..W {
            if (x as f32 + 0.5 - px).abs() < half && (y as f32 + 0.5 - py).abs() < half {
                v.push((y * W + x) as usize);
            }
        }
    }
    v
}

#[test]
fn rendered_patches_match_their_spectra_under_d65() {
    let csv = root().join("scenes/data/colorchecker/colorchecker_n_ohta.csv");
    let names: Vec<String> = stokes::spectrum::read_csv(&csv)
        .unwrap()
        .into_iter()
        .map(|c| c.0)
        .collect();
    assert_eq!(names.len(), 24);
    let d65 = Spectrum::Scaled(Box::new(illuminant("D65").unwrap()), 0.01);
    let white = spectrum_to_xyz(&d65);
    // Mono needs far more samples than HWSS for the same colour noise (that is the point
    // of HWSS); both counts bring the noise well below ΔE 1 on the light neutrals. Visible
    // wavelengths have less colour noise (the worst ΔE falls 3-5× with HWSS).
    for (spectral, wavelengths, spp) in [
        (Spectral::Hwss, Wavelengths::Uniform, 256),
        (Spectral::Mono, Wavelengths::Uniform, 2048),
        (Spectral::Hwss, Wavelengths::Visible, 256),
        (Spectral::Mono, Wavelengths::Visible, 2048),
    ] {
        let mut scene = scene_file("colorchecker.toml");
        let film = TestRender::at(W, H)
            .spp(spp)
            .seed(11)
            .spectral(spectral)
            .wavelengths(wavelengths)
            .film(&mut scene);
        let spectral = format!("{spectral:?} {wavelengths:?}");
        let mut worst = (0.0f32, String::new());
        for (i, name) in names.iter().enumerate() {
            let px = patch_pixels(i);
            assert!(px.len() >= 16, "patch {i} covers {} pixels", px.len());
            let (m, _) = region_mean(&film, &px);
            let got = linear_srgb_to_xyz(Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32));
            let rho = Spectrum::Tabulated(csv_column(&csv, Some(name)).unwrap());
            let want = reflectance_to_xyz(&rho, &d65);
            let de = delta_e_2000(xyz_to_lab(got, white), xyz_to_lab(want, white));
            if de > worst.0 {
                worst = (de, name.clone());
            }
            assert!(
                de <= 1.0,
                "{spectral}: patch {i} ({name}): ΔE2000 = {de:.3}"
            );
        }
        eprintln!("{spectral}: worst ΔE2000 = {:.3} ({})", worst.0, worst.1);
    }
}

#[test]
fn a_wrong_illuminant_is_caught() {
    // The same check against illuminant A must fail: the test can tell colours apart.
    let csv = root().join("scenes/data/colorchecker/colorchecker_n_ohta.csv");
    let d65 = Spectrum::Scaled(Box::new(illuminant("D65").unwrap()), 0.01);
    let a = Spectrum::Scaled(Box::new(illuminant("A").unwrap()), 0.01);
    let white = spectrum_to_xyz(&d65);
    let mut scene = scene_file("colorchecker.toml");
    let film = TestRender::at(W, H).spp(16).seed(12).film(&mut scene);
    let rho = Spectrum::Tabulated(csv_column(&csv, Some("blue_sky")).unwrap());
    let (m, _) = region_mean(&film, &patch_pixels(2));
    let got = linear_srgb_to_xyz(Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32));
    let wrong = reflectance_to_xyz(&rho, &a);
    assert!(delta_e_2000(xyz_to_lab(got, white), xyz_to_lab(wrong, white)) > 5.0);
}
