//! Spectral output (`--spectral-bins`): every bin holds the bin-averaged spectral radiance.
//! Checked against known spectra (a uniform enclosure, a narrow band), across methods that
//! must agree (HWSS and mono; dropping and splitting the lanes at a dispersive refraction,
//! the case where a renderer that bins dropped lanes goes wrong), and the RGB beside the
//! bins against the RGB-only render, bit for bit (the same arithmetic).

mod common;
use common::*;
use stokes::integrator::render::Film;
use stokes::method::{Dispersion, Spectral, Wavelengths};
use stokes::spectral_exr::Bins;
use stokes::spectrum::Spectrum;

/// Bin b's mean over `pixels` and its standard error (pixels are independent).
fn bin_means(film: &Film, pixels: &[usize]) -> Vec<(f64, f64)> {
    let (mean, var) = (film.spectral_mean(), film.spectral_variance_of_mean());
    let n = pixels.len() as f64;
    mean.iter()
        .zip(&var)
        .map(|(m, v)| {
            let mu: f64 = pixels.iter().map(|&i| m.data[i] as f64).sum::<f64>() / n;
            let se = pixels.iter().map(|&i| v.data[i] as f64).sum::<f64>().sqrt() / n;
            (mu, se)
        })
        .collect()
}

/// The average of `s` over each of `bins` (midpoint rule, 0.01 nm steps).
fn bin_averages(s: &Spectrum, bins: &Bins) -> Vec<f64> {
    let w = bins.width() as f64;
    let steps = (w / 0.01).round() as usize;
    (0..bins.count)
        .map(|b| {
            let lo = bins.centre(b) - w / 2.0;
            let sum: f64 = (0..steps)
                .map(|k| s.eval((lo + (k as f64 + 0.5) * w / steps as f64) as f32) as f64)
                .sum();
            sum / steps as f64
        })
        .collect()
}

/// Asserts that every bin agrees with `expected` within `z` standard errors (and that the
/// errors are small enough for the test to decide).
fn assert_bins_match(what: &str, got: &[(f64, f64)], expected: &[f64], z: f64) {
    assert_eq!(got.len(), expected.len());
    for (b, (&(m, se), &e)) in got.iter().zip(expected).enumerate() {
        assert!(
            se < 0.05 * e.abs().max(1e-3),
            "{what}: bin {b} too noisy to decide (se {se:.3e}, expected {e:.4})"
        );
        assert!(
            (m - e).abs() < z * se,
            "{what}: bin {b} holds {m:.5} ± {se:.2e}, expected {e:.5} ({:.1} se)",
            (m - e) / se
        );
    }
}

/// A varying emission: the enclosure's walls emit this, so a white furnace and a clear
/// glass sphere in it show exactly this spectrum at every pixel.
const RAMP: &str =
    "{ wavelengths = [360, 450, 600, 700, 830], values = [0.3, 1.2, 0.5, 0.9, 0.2] }";

fn ramp() -> Spectrum {
    Spectrum::Tabulated(
        stokes::spectrum::Tabulated::new(
            vec![360.0, 450.0, 600.0, 700.0, 830.0],
            vec![0.3, 1.2, 0.5, 0.9, 0.2],
        )
        .unwrap(),
    )
}

#[test]
fn a_white_furnace_shows_the_emitted_spectrum_bin_by_bin() {
    let bins = Bins::new(47, 360.0, 830.0).unwrap();
    let expected = bin_averages(&ramp(), &bins);
    // Visible wavelengths sample the ends of the range 7× less often than uniform ones
    // (the pdf's floor): those bins need 8× the samples to be measured as well.
    for (spectral, wavelengths, spp) in [
        (Spectral::Hwss, Wavelengths::Uniform, 512),
        (Spectral::Mono, Wavelengths::Uniform, 2048),
        (Spectral::Hwss, Wavelengths::Visible, 4096),
        (Spectral::Mono, Wavelengths::Visible, 16384),
    ] {
        let mut scene = scene_from(&enclosure(
            "type = \"diffuse\"\nreflectance = 1.0",
            RAMP,
            16,
            "",
        ));
        let mut r = TestRender::at(8, 8)
            .spp(spp)
            .seed(3)
            .spectral(spectral)
            .wavelengths(wavelengths);
        r.opts.bins = Some(bins);
        let film = r.film(&mut scene);
        let got = bin_means(&film, &all_pixels(&film));
        let what = format!("{spectral:?} {wavelengths:?} furnace");
        assert_bins_match(&what, &got, &expected, 4.5);
    }
}

#[test]
fn dropped_lanes_at_a_dispersive_refraction_leave_every_bin_right() {
    // A clear dispersive glass sphere in the enclosure: glass neither absorbs nor emits,
    // so every pixel sees the walls' spectrum. With `drop` the three secondary lanes end at
    // the first refraction and the hero carries their share; binning the dropped lanes (or
    // dividing the hero by the wrong pdf) would bias every bin.
    let bins = Bins::new(24, 360.0, 830.0).unwrap();
    let expected = bin_averages(&ramp(), &bins);
    let glass = "type = \"dielectric\"\nior = { cauchy = [1.5, 30000] }";
    for dispersion in [Dispersion::Drop, Dispersion::Split] {
        let mut scene = scene_from(&enclosure(glass, RAMP, 24, ""));
        let mut r = TestRender::at(8, 8)
            .spp(8192)
            .seed(4)
            .max_depth(24)
            .dispersion(dispersion);
        r.opts.bins = Some(bins);
        let film = r.film(&mut scene);
        // Pixels on the sphere only (radius 1 at distance 1.8, 60° fov: about 0.8 of the
        // half-width): the walls alone would not refract anything.
        let inner: Vec<usize> = (0..64)
            .filter(|i| {
                let (x, y) = ((i % 8) as f32 - 3.5, (i / 8) as f32 - 3.5);
                (x * x + y * y).sqrt() < 2.5
            })
            .collect();
        let got = bin_means(&film, &inner);
        assert_bins_match(&format!("{dispersion:?}"), &got, &expected, 4.5);
    }
}

#[test]
fn a_narrow_band_lands_in_its_bin_and_nowhere_else() {
    // A 2 nm wide line at 550 nm, seen directly; bins of 10 nm centred on 550.
    let text = r#"
[camera]
position = [0, 0, 0]
look_at = [0, 0, 1]
fov = 30
resolution = [8, 8]

[materials.black]
type = "diffuse"
reflectance = 0

[[shapes]]
type = "quad"
origin = [-5, -5, 4]
edge_u = [10, 0, 0]
edge_v = [0, 10, 0]
material = "black"
emission = { radiance = { narrow_band = 550, fwhm = 2, scale = 10 }, two_sided = true }
"#;
    let bins = Bins::new(30, 405.0, 705.0).unwrap();
    let at_550 = bins.index(550.0).unwrap();
    assert_eq!(bins.centre(at_550 as u32), 550.0);
    let mut scene = scene_from(text);
    let mut r = TestRender::at(8, 8).spp(1024).seed(5).max_depth(1);
    r.opts.bins = Some(bins);
    let film = r.film(&mut scene);
    let got = bin_means(&film, &all_pixels(&film));
    // The line's integral is 10, spread over a 10 nm bin: 1 on average.
    let (m, se) = got[at_550];
    assert!(se < 0.03, "too noisy to decide: se {se}");
    assert!(
        (m - 1.0).abs() < 4.5 * se,
        "550 nm bin holds {m} ± {se}, expected 1"
    );
    for (b, &(v, _)) in got.iter().enumerate() {
        if b != at_550 {
            assert!(
                v.abs() < 1e-6,
                "bin {b} ({} nm) holds {v}: the line leaked out of its bin",
                bins.centre(b as u32)
            );
        }
    }
}

#[test]
fn hwss_and_mono_spectral_images_agree_on_the_cornell_box() {
    // The measured box is lit between 400 and 700 nm only.
    // Uniform wavelengths: every bin sampled alike (visible ones are in the furnace test).
    let bins = Bins::new(15, 400.0, 700.0).unwrap();
    let films: Vec<(Spectral, Film)> = [(Spectral::Hwss, 512), (Spectral::Mono, 2048)]
        .into_iter()
        .map(|(spectral, spp)| {
            let mut scene = scene_file("cornell-box.toml");
            let mut r = TestRender::at(12, 12)
                .spp(spp)
                .seed(6)
                .max_depth(6)
                .spectral(spectral)
                .wavelengths(Wavelengths::Uniform);
            r.opts.bins = Some(bins);
            (spectral, r.film(&mut scene))
        })
        .collect();
    let px = all_pixels(&films[0].1);
    let (a, b) = (bin_means(&films[0].1, &px), bin_means(&films[1].1, &px));
    for (k, (&(ma, sa), &(mb, sb))) in a.iter().zip(&b).enumerate() {
        let z = (ma - mb) / (sa * sa + sb * sb).sqrt();
        assert!(
            z.abs() < 4.5,
            "bin {k} ({} nm): HWSS {ma:.5} ± {sa:.1e}, mono {mb:.5} ± {sb:.1e} (z {z:.1})",
            bins.centre(k as u32)
        );
    }
    // The test can decide: the bins that carry the image are measured to a few percent.
    let peak = a.iter().map(|x| x.0).fold(0.0, f64::max);
    for (k, &(m, se)) in a.iter().enumerate() {
        assert!(m < 0.05 * peak || se < 0.08 * m, "bin {k}: {m} ± {se}");
    }
}

#[test]
fn the_rgb_beside_the_bins_is_the_rgb_only_render_bit_for_bit() {
    // Same samples, same arithmetic for the colour: the bins are only added beside it.
    let mut scene = scene_file("cornell-box.toml");
    let base = TestRender::at(10, 10).spp(8).seed(7).max_depth(5);
    let rgb_only = base.film(&mut scene);
    let mut spectral = base.clone();
    spectral.opts.bins = Some(Bins::new(47, 360.0, 830.0).unwrap());
    let with_bins = spectral.film(&mut scene);
    assert_eq!(rgb_only.mean(), with_bins.mean());
    assert_eq!(rgb_only.variance_of_mean(), with_bins.variance_of_mean());
    assert!(rgb_only.spectral_mean().is_empty());
    let planes = with_bins.spectral_mean();
    assert_eq!(planes.len(), 47);
    assert_eq!(planes[0].name, "S0.365,000000nm");
    assert!(planes.iter().all(|p| p.data.len() == 100));
}
