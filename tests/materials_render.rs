//! Rough conductors and rough dielectrics through the whole renderer (light sampling, MIS,
//! the SIMD estimator), against answers known independently of it:
//!
//! - a perfect reflector (η = 1, k = 10⁴) as a GGX plate in a uniformly emitting box
//!   returns exactly its directional albedo E(θo), which a quadrature of the BSDF's own
//!   `eval` gives: single scattering loses energy, and only that much (at α = 0.8 and
//!   60° about 8 %, which the test also demands, so an energy-conserving bug shows);
//! - a rough conductor at α = 0.001 renders as the smooth conductor (Z-test);
//! - a non-absorbing smooth dielectric sphere in a furnace returns the emitted radiance;
//!   a rough one never more, and loses at most the few per cent that GGX's single
//!   scattering loses per interaction;
//! - HWSS (per-lane generalised half vectors at a dispersive rough interface) agrees with
//!   mono, which has one wavelength and nothing to get wrong between lanes.

mod common;
use common::*;
use glam::{Vec3, Vec4};
use stokes::bsdf::Material;
use stokes::method::Spectral;

/// A plate of `material` (TOML body) at y = 0 facing +y, seen at `theta` degrees from its
/// normal through a 2° field of view, inside a box whose walls emit 1 on both sides.
fn plate_scene(material: &str, theta: f32) -> String {
    let t = theta.to_radians();
    let (x, y) = (3.0 * t.sin(), 3.0 * t.cos());
    format!(
        r#"
[camera]
position = [{x}, {y}, 0]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov = 2
resolution = [8, 8]

[materials.plate]
{material}

[[shapes]]
type = "box"
min = [-10, -10, -10]
max = [10, 10, 10]
emission = {{ radiance = 1.0, two_sided = true }}

[[shapes]]
type = "quad"
origin = [-5, 0, -5]
edge_u = [0, 0, 10]
edge_v = [10, 0, 0]
material = "plate"
"#
    )
}

/// The directional albedo ∫ f·cos dωi of `material` (lane 0) seen at `theta` degrees, by
/// a midpoint quadrature in (cos θi, φ) over the upper hemisphere.
fn albedo(material: &Material, theta: f32) -> f64 {
    let lobe = material.at(Vec4::splat(550.0));
    let t = theta.to_radians();
    let wo = Vec3::new(t.sin(), t.cos(), 0.0);
    let (nc, nphi) = (2000, 720);
    let mut sum = 0.0;
    for i in 0..nc {
        // cos θi = 1 − s²: cells crowd towards the normal, where narrow lobes sit.
        let s = (i as f64 + 0.5) / nc as f64;
        let c = 1.0 - s * s;
        let sin = (1.0 - c * c).max(0.0).sqrt();
        for j in 0..nphi {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / nphi as f64;
            let wi = Vec3::new((sin * phi.cos()) as f32, c as f32, (sin * phi.sin()) as f32);
            let (f_cos, _) = lobe.eval(Vec3::Y, wo, wi);
            // dω = dcos θ dφ = 2s ds dφ.
            sum += f64::from(f_cos.x) * 2.0 * s / nc as f64 * std::f64::consts::TAU / nphi as f64;
        }
    }
    sum
}

#[test]
fn perfect_rough_reflector_returns_its_single_scattering_albedo() {
    let expected_rgb = white_rgb();
    for (alpha, theta) in [(0.3f32, 0.0f32), (0.3, 60.0), (0.8, 60.0)] {
        let body = format!("type = \"conductor\"\neta = 1.0\nk = 10000\nroughness = {alpha}");
        let scene_text = plate_scene(&body, theta);
        let mut scene = scene_from(&scene_text);
        let e = albedo(&scene.materials[0], theta);
        let film = TestRender::at(8, 8).spp(4096).seed(3).film(&mut scene);
        let (m, se) = region_mean(&film, &all_pixels(&film));
        eprintln!("α {alpha}, θo {theta}°: albedo {e:.5}, render {m:?} ± {se:?}");
        assert!(e < 1.0, "albedo {e} ≥ 1");
        if alpha == 0.8 {
            assert!(e < 0.95, "α 0.8 at 60° should lose several per cent: {e}");
        }
        for c in 0..3 {
            let want = e * expected_rgb[c];
            // 4 standard errors, plus 0.2 % for the ±1° the pixels see around θo.
            let tol = 4.0 * se[c] + 2e-3 * want;
            assert!(
                (m[c] - want).abs() <= tol,
                "α {alpha}, θo {theta}°, channel {c}: render {} vs albedo × white {want} (tolerance {tol})",
                m[c]
            );
        }
    }
}

#[test]
fn rough_conductor_at_tiny_roughness_renders_as_the_smooth_one() {
    let film = |roughness: &str, seed: u64| {
        let body = format!("type = \"conductor\"\nmetal = \"Au\"\nroughness = {roughness}");
        let mut scene = scene_from(&plate_scene(&body, 45.0));
        TestRender::at(8, 8).spp(1024).seed(seed).film(&mut scene)
    };
    let (smooth, rough) = (film("0", 1), film("0.001", 2));
    let all = all_pixels(&smooth);
    let (a, b) = (region_mean(&smooth, &all), region_mean(&rough, &all));
    eprintln!("smooth {a:?}, α 0.001 {b:?}");
    assert_agree("gold: smooth vs α = 0.001", a, b, 4.0);
    // And gold is gold: red reflected more than blue.
    assert!(a.0[0] > 1.3 * a.0[2], "{a:?}");
}

/// A sphere of `material` (TOML body) inside a box whose walls emit 1 on both sides.
fn furnace_sphere(material: &str) -> String {
    enclosure(material, "1.0", 32, "")
}

#[test]
fn dielectric_spheres_in_a_furnace_never_gain_energy() {
    let want = white_rgb();
    // GGX's single scattering loses 1–5 % per interaction from outside but 10–23 % from
    // inside glass at α = 0.3 (directional albedo by quadrature and by sampling, which
    // agree); a path bounces inside several times, so the rough spheres keep about three
    // quarters (measured 0.75 at α = 0.3, 0.67 at [0.1, 0.6]): the bound only catches
    // gross losses, the upper bound is the test. The smooth sphere returns 0.2 % less than
    // the furnace (measured at 16384 spp, uniform and visible wavelengths alike: R 0.9972–
    // 0.9986, G 0.9978–0.9983 of white), more than its noise at 1024 spp: a small loss
    // that is not yet explained (an open issue), so its bound is 0.995.
    for (roughness, min_ratio) in [("0", 0.995), ("0.3", 0.6), ("[0.1, 0.6]", 0.6)] {
        let body = format!("type = \"dielectric\"\nior = 1.5\nroughness = {roughness}");
        let mut scene = scene_from(&furnace_sphere(&body));
        let film = TestRender::at(16, 16).spp(1024).seed(5).film(&mut scene);
        let (m, se) = region_mean(&film, &all_pixels(&film));
        eprintln!("roughness {roughness}: {m:?} ± {se:?} (white {want:?})");
        for c in 0..3 {
            let r = m[c] / want[c];
            let e = se[c] / want[c];
            assert!(
                r <= 1.0 + 4.0 * e,
                "roughness {roughness}, channel {c}: gains energy: {r} ± {e}"
            );
            assert!(
                r >= min_ratio - 4.0 * e,
                "roughness {roughness}, channel {c}: {r} ± {e}, below {min_ratio}"
            );
        }
    }
}

#[test]
fn hwss_and_mono_agree_through_a_dispersive_rough_glass() {
    let text = r#"
[camera]
position = [0, 1.2, -3]
look_at = [0, 0.4, 0]
fov = 40
resolution = [16, 16]

[materials.glass]
type = "dielectric"
ior = { cauchy = [1.5, 30000] }
roughness = 0.15

[materials.floor]
type = "diffuse"
reflectance = 0.7

[[shapes]]
type = "quad"
origin = [-3, 0, -3]
edge_u = [0, 0, 6]
edge_v = [6, 0, 0]
material = "floor"

[[shapes]]
type = "sphere"
center = [0, 0.6, 0]
radius = 0.6
stacks = 24
material = "glass"

[[shapes]]
type = "quad"
origin = [-0.5, 2.5, -0.5]
edge_u = [1, 0, 0]
edge_v = [0, 0, 1]
emission = { radiance = "D65", scale = 8 }
"#;
    let mut scene = scene_from(text);
    let h = TestRender::at(16, 16).spp(512).seed(7).film(&mut scene);
    let m = TestRender::at(16, 16)
        .spp(512)
        .seed(8)
        .spectral(Spectral::Mono)
        .film(&mut scene);
    let px = all_pixels(&h);
    let sphere: Vec<usize> = (0..256)
        .filter(|i| (4..12).contains(&(i % 16)) && (3..11).contains(&(i / 16)))
        .collect();
    for (name, region) in [("image", &px), ("sphere", &sphere)] {
        let (a, b) = (region_mean(&h, region), region_mean(&m, region));
        eprintln!("{name}: HWSS {a:?}, mono {b:?}");
        assert_agree(&format!("HWSS vs mono, {name}"), a, b, 4.0);
    }
}

/// A furnace sphere of each coated material (TOML body after `type = "coated"`) returns
/// between `min` and `max` times the emitted white, within 4 standard errors.
fn coated_spheres_return_between(cases: &[(String, f64, f64)]) {
    let want = white_rgb();
    for (body, min_ratio, max_ratio) in cases {
        let mut scene = scene_from(&furnace_sphere(&format!("type = \"coated\"\n{body}")));
        let film = TestRender::at(16, 16).spp(1024).seed(9).film(&mut scene);
        let (m, se) = region_mean(&film, &all_pixels(&film));
        eprintln!("{body:?}: {m:?} ± {se:?}");
        for c in 0..3 {
            let (r, e) = (m[c] / want[c], se[c] / want[c]);
            assert!(
                r <= max_ratio + 4.0 * e,
                "{body}: channel {c}: {r} ± {e} above {max_ratio}"
            );
            assert!(
                r >= min_ratio - 4.0 * e,
                "{body}: channel {c}: {r} ± {e} below {min_ratio}"
            );
        }
    }
}

#[test]
fn clear_coat_over_a_white_base_conserves_energy_and_never_gains() {
    // ρ = 1 under a clear coat: every photon comes out again (the internal-reflection
    // series closes); a grey base and an absorbing coat only lose; a dispersive coat too.
    let cases = [
        ("ior = 1.5\nbase = { type = \"diffuse\", reflectance = 1.0 }".into(), 1.0, 1.0),
        ("ior = { cauchy = [1.5, 30000] }\nbase = { type = \"diffuse\", reflectance = 1.0 }".into(), 1.0, 1.0),
        ("ior = 1.5\nbase = { type = \"diffuse\", reflectance = 0.5 }".into(), 0.0, 0.9),
        ("ior = 1.5\nabsorption = 2.0\nthickness = 0.1\nbase = { type = \"diffuse\", reflectance = 1.0 }".into(), 0.0, 0.95),
    ];
    coated_spheres_return_between(&cases);
}

#[test]
fn rough_clear_coat_over_a_white_base_conserves_energy_and_never_gains() {
    // The rough coat's internal reflectance meets reciprocity, so ρ = 1 under a clear
    // rough coat returns everything (to the coat table's 0.3 %); a grey base, an
    // absorbing coat, only lose.
    let white = "base = { type = \"diffuse\", reflectance = 1.0 }";
    let cases = [
        (format!("ior = 1.5\nroughness = 0.3\n{white}"), 0.997, 1.003),
        (
            format!("ior = {{ cauchy = [1.5, 30000] }}\nroughness = 0.1\n{white}"),
            0.997,
            1.003,
        ),
        (format!("ior = 1.5\nroughness = 0.8\n{white}"), 0.997, 1.003),
        (
            "ior = 1.5\nroughness = 0.3\nbase = { type = \"diffuse\", reflectance = 0.5 }".into(),
            0.0,
            0.9,
        ),
        (
            format!("ior = 1.5\nroughness = 0.3\nabsorption = 2.0\nthickness = 0.1\n{white}"),
            0.0,
            0.95,
        ),
    ];
    coated_spheres_return_between(&cases);
}

/// What a coated plate returns in a uniform furnace of radiance 1, seen at `theta`
/// degrees (lane 0 at 550 nm): the coat's reflection albedo plus the exit factor times
/// the base lobe's ∫ f cos dωi, both by quadrature of the code's own `eval`.
fn coated_albedo(material: &Material, theta: f32) -> f64 {
    let Material::Coated(c) = material else {
        panic!("not a coated material")
    };
    let cos_o = theta.to_radians().cos();
    let lambda = stokes::simd::Spec::<f32>::from(Vec4::splat(550.0));
    let exit = f64::from(c.exit(cos_o, &lambda, true)[0]);
    let coat = match c.is_rough() {
        false => f64::from(stokes::bsdf::fresnel_dielectric(cos_o, c.ior.eval(550.0))),
        true => albedo(
            &Material::Conductor {
                eta: stokes::spectrum::Spectrum::Constant(c.ior.eval(550.0)),
                k: stokes::spectrum::Spectrum::Constant(0.0),
                alpha: [c.alpha; 2],
                alpha_map: None,
            },
            theta,
        ),
    };
    coat + exit * albedo(material, theta)
}

#[test]
fn coated_conductors_return_what_their_model_integrates_to() {
    let want = white_rgb();
    // A perfect conductor (η 1, k 10⁴) under the coat. Smooth under a smooth or rough
    // coat: the internal reflections' closed form makes the layer lossless. Rough: what
    // the refracted lobe sends beyond the critical angle is lost, as the model says, and
    // the render must return exactly the quadrature of its own eval.
    let perfect = "type = \"conductor\", eta = 1.0, k = 10000";
    let cases = [
        (format!("ior = 1.5\nbase = {{ {perfect} }}"), 0.0, true),
        (format!("ior = 1.5\nroughness = 0.2\nbase = {{ {perfect} }}"), 50.0, true),
        (format!("ior = 1.5\nbase = {{ {perfect}, roughness = 0.3 }}"), 0.0, false),
        (format!("ior = 1.5\nbase = {{ {perfect}, roughness = 0.3 }}"), 60.0, false),
        (format!("ior = 1.5\nroughness = 0.2\nbase = {{ {perfect}, roughness = 0.5 }}"), 30.0, false),
        (format!("ior = 1.4\nabsorption = 1.0\nthickness = 0.1\nroughness = 0.1\nbase = {{ {perfect}, roughness = 0.2 }}"), 45.0, false),
    ];
    for (body, theta, lossless) in cases {
        let mut scene = scene_from(&plate_scene(&format!("type = \"coated\"\n{body}"), theta));
        let e = match lossless {
            true => 1.0,
            false => coated_albedo(&scene.materials[0], theta),
        };
        let film = TestRender::at(8, 8).spp(4096).seed(4).film(&mut scene);
        let (m, se) = region_mean(&film, &all_pixels(&film));
        eprintln!("{body:?} at {theta}°: model {e:.5}, render {m:?} ± {se:?}");
        assert!(e <= 1.0 + 1e-3, "{body}: the model gains energy: {e}");
        for c in 0..3 {
            let want = e * want[c];
            // 4 standard errors, 0.3 % for the coat table, 0.2 % for the pixels' ±1°.
            let tol = 4.0 * se[c] + 5e-3 * want;
            assert!(
                (m[c] - want).abs() <= tol,
                "{body} at {theta}°, channel {c}: render {} vs model {want} (tolerance {tol})",
                m[c]
            );
        }
    }
}
