//! The environment map: its sampler against its density (chi-square over the image), the
//! density in solid angle (pointwise and its integral), a constant map against the
//! constant sky of the same spectrum, a floor's irradiance under a sky with a sun against
//! a quadrature of the map, the variance that importance sampling saves over uniform
//! directions, and bad maps.

mod common;
use common::stats::{chi_square, Rng};
use common::*;
use glam::{Vec3, Vec4};
use std::f64::consts::PI;
use stokes::light::EnvMap;
use stokes::spectrum::upsample::RgbSpectrum;
use stokes::spectrum::{spectrum_to_xyz, Spectrum, Tabulated};

/// A `w` × `w/2` map with a smooth sky of colour `sky` and, if `sun` > 0, a sun of that
/// radiance in one texel at (`w`/4, `w`/8) (above the horizon).
fn sky_rgb(w: usize, sky: [f32; 3], sun: f32) -> Vec<[f32; 3]> {
    let h = w / 2;
    (0..w * h)
        .map(|k| {
            let (x, y) = (k % w, k / w);
            if sun > 0.0 && (x, y) == (w / 4, h / 4) {
                return [sun, 0.9 * sun, 0.7 * sun];
            }
            // Brighter towards the zenith, varying with azimuth: no two rows alike.
            let f = 0.3 + 0.7 * (1.0 - y as f32 / h as f32) + 0.2 * (x as f32 * 0.7).sin();
            sky.map(|c| c * f.max(0.05))
        })
        .collect()
}

#[test]
fn the_map_sampler_draws_texels_by_luminance_times_sin_theta() {
    let (w, h) = (16, 8);
    let rgb = sky_rgb(w, [0.2, 0.4, 1.0], 30.0);
    let map = EnvMap::from_rgb(w, h, &rgb, 1.0).unwrap();
    // Each texel split into 2 × 2 bins: the density is uniform within a texel.
    let (bw, bh) = (2 * w, 2 * h);
    let mut counts = vec![0u64; bw * bh];
    let mut rng = Rng::new(11, 0);
    let n = 400_000;
    let (mut pdf_mismatch, mut none) = (0, 0);
    for _ in 0..n {
        // None only at an exact pole (a uniform of exactly 0), where the density is 0.
        let Some((d, pdf, texel)) = map.sample(rng.next_2d()) else {
            none += 1;
            continue;
        };
        let (x, y) = EnvMap::image_point(d);
        let (bx, by) = ((x * bw as f32) as usize, (y * bh as f32) as usize);
        counts[by.min(bh - 1) * bw + bx.min(bw - 1)] += 1;
        // Equal but for rounding: at texel edges the direction may fall in the next
        // texel, and near the poles acos loses digits of sin θ.
        if (map.pdf(d) - pdf).abs() > 1e-3 * pdf || map.texel(d) != texel {
            pdf_mismatch += 1;
        }
    }
    assert!(
        pdf_mismatch < n / 1000,
        "{pdf_mismatch} samples whose pdf(ω) or texel differs"
    );
    assert!(none < 3, "{none} samples without a direction");
    let lum = |t: [f32; 3]| 0.2126 * t[0] as f64 + 0.7152 * t[1] as f64 + 0.0722 * t[2] as f64;
    let expected_with = |sin_weight: bool| {
        let weight = |k: usize| {
            let theta = PI * ((k / w) as f64 + 0.5) / h as f64;
            lum(rgb[k]) * if sin_weight { theta.sin() } else { 1.0 }
        };
        let total: f64 = (0..w * h).map(weight).sum();
        (0..bw * bh)
            .map(|b| weight((b / bw / 2) * w + (b % bw) / 2) / total / 4.0 * (n - none) as f64)
            .collect::<Vec<f64>>()
    };
    chi_square(&counts, &expected_with(true)).assert_accepts(1e-3, "map sampler");
    // The same test must reject a density that forgets sin θ.
    chi_square(&counts, &expected_with(false)).assert_rejects(1e-3, "map sampler without sin θ");
}

#[test]
fn the_map_density_integrates_to_one_over_the_sphere() {
    // E[1/pdf] over the sampler's directions is the solid angle of the sphere: the
    // Jacobian 2π² sin θ between image and directions.
    let map = EnvMap::from_rgb(32, 16, &sky_rgb(32, [1.0, 0.8, 0.6], 0.0), 1.0).unwrap();
    let mut rng = Rng::new(12, 0);
    let n = 200_000;
    let (mut sum, mut sq) = (0.0, 0.0);
    for _ in 0..n {
        let (_, pdf, _) = map.sample(rng.next_2d()).unwrap();
        let v = 1.0 / f64::from(pdf);
        sum += v;
        sq += v * v;
    }
    let mean = sum / n as f64;
    let se = ((sq / n as f64 - mean * mean) / n as f64).sqrt();
    let z = (mean - 4.0 * PI) / se;
    assert!(z.abs() < 4.5, "E[1/pdf] = {mean} ± {se}, 4π = {}", 4.0 * PI);
    // And pdf(ω) by quadrature over the sphere: 1 to the midpoint rule's accuracy.
    let (nt, np) = (400, 800);
    let mut integral = 0.0;
    for i in 0..nt {
        let theta = PI * (i as f64 + 0.5) / nt as f64;
        for j in 0..np {
            let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
            let d = EnvMap::direction((phi / (2.0 * PI)) as f32, (theta / PI) as f32);
            integral +=
                f64::from(map.pdf(d)) * theta.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
        }
    }
    assert!((integral - 1.0).abs() < 2e-3, "∫ pdf dω = {integral}");
}

#[test]
fn directions_and_image_points_are_inverse() {
    for (x, y) in [(0.1f32, 0.2f32), (0.6, 0.5), (0.95, 0.9), (0.25, 0.5)] {
        let d = EnvMap::direction(x, y);
        let (x2, y2) = EnvMap::image_point(d);
        assert!(
            (x - x2).abs() < 1e-5 && (y - y2).abs() < 1e-5,
            "({x}, {y}) → ({x2}, {y2})"
        );
    }
    // Row 0 is up; x = 0 looks along −z, x = ¼ along +x.
    assert!(EnvMap::direction(0.3, 0.0).abs_diff_eq(Vec3::Y, 1e-6));
    assert!(EnvMap::direction(0.0, 0.5).abs_diff_eq(-Vec3::Z, 1e-6));
    assert!(EnvMap::direction(0.25, 0.5).abs_diff_eq(Vec3::X, 1e-6));
}

/// Writes `rgb` (`w` × `w/2`) as an RGB OpenEXR file.
fn write_map(path: &std::path::Path, w: usize, rgb: &[[f32; 3]]) {
    exr::prelude::write_rgb_file(path, w, w / 2, |x, y| {
        let t = rgb[y * w + x];
        (t[0], t[1], t[2])
    })
    .unwrap();
}

/// A grey sphere (reflectance 0.5) under the environment `env` (a `[[lights]]` body).
fn sphere_under(env: &str) -> String {
    format!(
        r#"
[camera]
position = [0, 0.4, -2.5]
look_at = [0, 0, 0]
fov = 60
resolution = [16, 16]

[materials.ball]
type = "diffuse"
reflectance = 0.5

[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
stacks = 24
smooth = true
material = "ball"

[[lights]]
type = "environment"
{env}
"#
    )
}

#[test]
fn a_constant_map_renders_as_the_constant_sky_of_its_spectrum() {
    // The same radiance, D65 of luminance 1 × 0.8 from every direction, sampled two ways.
    let dir = scratch("envmap-constant");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("grey.exr");
    write_map(&file, 16, &vec![[0.8; 3]; 16 * 8]);
    let mut map = scene_from(&sphere_under(&format!("map = {:?}", s(&file))));
    let mut sky = scene_from(&sphere_under("radiance = { rgb = [0.8, 0.8, 0.8] }"));
    let a = TestRender::at(16, 16).spp(256).seed(5).film(&mut map);
    let b = TestRender::at(16, 16).spp(256).seed(6).film(&mut sky);
    let all = all_pixels(&a);
    assert_agree(
        "constant map vs constant sky",
        region_mean(&a, &all),
        region_mean(&b, &all),
        4.5,
    );
    // And the white of the map is sRGB white: 0.8 in every channel, the sphere 0.4.
    let (m, _) = region_mean(&b, &[0]);
    for (c, v) in m.iter().enumerate() {
        assert!((v - 0.8).abs() < 0.01, "background channel {c}: {v}");
    }
}

/// The spectral irradiance on an upward-facing surface under `map` (scale 1), by
/// summing each texel above the horizon × its ∫cos θ dω, at 1 nm.
fn irradiance_spectrum(w: usize, rgb: &[[f32; 3]]) -> Spectrum {
    let h = w / 2;
    let lambdas: Vec<f32> = (360..=830).map(|l| l as f32).collect();
    let mut e = vec![0.0f64; lambdas.len()];
    for y in 0..h / 2 {
        let (t0, t1) = (PI * y as f64 / h as f64, PI * (y + 1) as f64 / h as f64);
        let cos_omega = (2.0 * PI / w as f64) * 0.5 * (t1.sin().powi(2) - t0.sin().powi(2));
        for x in 0..w {
            let s = RgbSpectrum::illuminant(rgb[y * w + x]);
            for (k, &l) in lambdas.iter().enumerate() {
                e[k] += f64::from(s.eval(l)) * cos_omega;
            }
        }
    }
    let values = e.iter().map(|&v| v as f32).collect();
    Spectrum::Tabulated(Tabulated::new(lambdas, values).unwrap())
}

#[test]
fn a_floor_under_a_sky_with_a_sun_has_the_irradiance_of_the_map() {
    let w = 64;
    let rgb = sky_rgb(w, [0.3, 0.5, 1.0], 2000.0);
    let dir = scratch("envmap-sun");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("sun.exr");
    write_map(&file, w, &rgb);
    let rho = 0.5;
    let text = format!(
        r#"
[camera]
position = [0, 3, 0]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov = 40
resolution = [16, 16]

[materials.floor]
type = "diffuse"
reflectance = {rho}

[[shapes]]
type = "quad"
origin = [-4, 0, -4]
edge_u = [0, 0, 8]
edge_v = [8, 0, 0]
material = "floor"

[[lights]]
type = "environment"
map = {:?}
"#,
        s(&file)
    );
    let mut scene = scene_from(&text);
    let film = TestRender::at(16, 16)
        .spp(64)
        .seed(8)
        .max_depth(2)
        .film(&mut scene);
    let (m, se) = region_mean(&film, &all_pixels(&film));
    let xyz = spectrum_to_xyz(&irradiance_spectrum(w, &rgb)) * (rho / std::f32::consts::PI);
    let want = stokes::color::xyz_to_linear_srgb(xyz);
    for c in 0..3 {
        let z = (m[c] - f64::from(want[c])) / se[c];
        assert!(
            z.abs() < 4.5,
            "channel {c}: {} vs {} (z {z:.2})",
            m[c],
            want[c]
        );
    }
}

#[test]
fn importance_sampling_the_map_beats_uniform_directions_on_a_sun() {
    // The irradiance E = ∫ L cos⁺θ dω at 550 nm under a sky with a sun of 1/8192 of the
    // image (0.01 % of the sphere), estimated with N directions from the map's sampler and
    // N uniform ones.
    let w = 128;
    let rgb = sky_rgb(w, [0.3, 0.5, 1.0], 5000.0);
    let map = EnvMap::from_rgb(w, w / 2, &rgb, 1.0).unwrap();
    let lambda = Vec4::splat(550.0);
    let f = |d: Vec3| f64::from(map.radiance(map.texel(d), lambda).x) * f64::from(d.y.max(0.0));
    let n = 200_000;
    let stats = |mut draw: Box<dyn FnMut(&mut Rng) -> f64>| {
        let mut rng = Rng::new(13, 1);
        let (mut s, mut sq) = (0.0, 0.0);
        for _ in 0..n {
            let v = draw(&mut rng);
            s += v;
            sq += v * v;
        }
        let mean = s / n as f64;
        (mean, sq / n as f64 - mean * mean)
    };
    let (m_map, v_map) = stats(Box::new(|r| {
        let (d, pdf, _) = map.sample(r.next_2d()).unwrap();
        f(d) / f64::from(pdf)
    }));
    let (m_uni, v_uni) = stats(Box::new(|r| {
        let u = r.next_2d();
        let z = 1.0 - 2.0 * u[0];
        let s = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * u[1];
        f(Vec3::new(s * phi.cos(), z, s * phi.sin())) * 4.0 * PI
    }));
    eprintln!(
        "irradiance at 550 nm: map sampling {m_map:.4} (variance {v_map:.3e}), uniform {m_uni:.4} (variance {v_uni:.3e}): {:.0}× less variance",
        v_uni / v_map
    );
    let se = (v_map / n as f64).sqrt() + (v_uni / n as f64).sqrt();
    assert!(
        (m_map - m_uni).abs() < 4.5 * se,
        "the two estimates disagree"
    );
    assert!(
        v_uni > 20.0 * v_map,
        "importance sampling saves too little: {v_uni} vs {v_map}"
    );
}

#[test]
fn bad_maps_are_rejected_naming_the_file() {
    let dir = scratch("envmap-bad");
    std::fs::create_dir_all(&dir).unwrap();
    let square = dir.join("square.exr");
    exr::prelude::write_rgb_file(&square, 8, 8, |_, _| (1.0f32, 1.0f32, 1.0f32)).unwrap();
    let nan = dir.join("nan.exr");
    write_map(
        &nan,
        8,
        &(0..32)
            .map(|k| {
                if k == 5 {
                    [f32::NAN, 0.0, 0.0]
                } else {
                    [1.0; 3]
                }
            })
            .collect::<Vec<_>>(),
    );
    let negative = dir.join("negative.exr");
    write_map(
        &negative,
        8,
        &(0..32)
            .map(|k| if k == 9 { [0.5, -1.0, 0.0] } else { [1.0; 3] })
            .collect::<Vec<_>>(),
    );
    let black = dir.join("black.exr");
    write_map(&black, 8, &vec![[0.0; 3]; 32]);
    let text_file = dir.join("not-an-image.exr");
    std::fs::write(&text_file, "hello").unwrap();
    let cases = [
        (dir.join("missing.exr"), "cannot read"),
        (text_file, "cannot read"),
        (square, "twice as wide as it is high, found 8x8"),
        (
            nan,
            "expected finite non-negative radiance, found [NaN, 0.0, 0.0] at texel (5, 0)",
        ),
        (negative, "found [0.5, -1.0, 0.0] at texel (1, 1)"),
        (black, "the image is black"),
    ];
    for (file, want) in cases {
        let text = sphere_under(&format!("map = {:?}", s(&file)));
        let err = match stokes::scene::Scene::from_str(&text, &root().join("scenes/inline.toml")) {
            Ok(_) => panic!("{} loaded", file.display()),
            Err(e) => e.to_string(),
        };
        assert!(
            err.contains("lights[0].map") && err.contains(&s(&file)),
            "{err}"
        );
        assert!(err.contains(want), "{}: {err}", file.display());
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    // Texels × scale beyond what a path's estimate can hold in f32.
    let ok = dir.join("ok.exr");
    write_map(&ok, 8, &vec![[10.0; 3]; 32]);
    let text = sphere_under(&format!("map = {:?}\nscale = 1e30", s(&ok)));
    let err = match stokes::scene::Scene::from_str(&text, &root().join("scenes/inline.toml")) {
        Ok(_) => panic!("a map of 10 × 1e30 loaded"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("expected texels × scale ≤ 1e30") && err.contains("1e1 × 1e30"),
        "{err}"
    );
    let both = sphere_under("radiance = 1\nmap = \"x.exr\"");
    let err = stokes::scene::Scene::from_str(&both, &root().join("scenes/inline.toml"))
        .err()
        .unwrap();
    assert!(
        err.to_string()
            .contains("expected one of `radiance` (a constant sky) and `map`"),
        "{err}"
    );
}
