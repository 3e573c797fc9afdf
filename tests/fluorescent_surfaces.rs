//! Fluorescent surfaces in renders: mono, HWSS-constant and HWSS-independent agree; a
//! fluorescent plane under uniform light matches the closed form per wavelength; a
//! diagonal-only matrix renders like plain diffuse; narrow-band light stays finite.

mod common;
use common::*;
use glam::Vec3;
use stokes::bsdf::Material;
use stokes::color::xyz_to_linear_srgb;
use stokes::method::{Method, Shifting, Spectral};
use stokes::scene::Scene;
use stokes::spectrum::{illuminant, Spectrum};

fn render_with(
    scene: &mut Scene,
    res: u32,
    spp: u32,
    seed: u64,
    spectral: Spectral,
    shifting: Shifting,
) -> stokes::integrator::render::Film {
    let method = Method {
        spectral,
        shifting,
        ..Method::default()
    };
    TestRender::at(res, res)
        .spp(spp)
        .seed(seed)
        .method(method)
        .film(scene)
}

/// Pixels whose centres fall in the inner `keep` share of an axis-aligned rectangle on
/// the plane z = `z` (facing the camera).
fn rect_pixels(scene: &Scene, x: (f32, f32), y: (f32, f32), z: f32, keep: f32) -> Vec<usize> {
    let (cx, cy) = ((x.0 + x.1) / 2.0, (y.0 + y.1) / 2.0);
    let (hx, hy) = ((x.1 - x.0) / 2.0 * keep, (y.1 - y.0) / 2.0 * keep);
    let a = scene
        .camera
        .project(Vec3::new(cx - hx, cy - hy, z))
        .unwrap();
    let b = scene
        .camera
        .project(Vec3::new(cx + hx, cy + hy, z))
        .unwrap();
    let (x0, x1) = (a.0.min(b.0), a.0.max(b.0));
    let (y0, y1) = (a.1.min(b.1), a.1.max(b.1));
    let w = scene.camera.width;
    let mut v = vec![];
    for py in 0..scene.camera.height {
        for px in 0..w {
            let (fx, fy) = (px as f32 + 0.5, py as f32 + 0.5);
            if fx > x0 && fx < x1 && fy > y0 && fy < y1 {
                v.push((py * w + px) as usize);
            }
        }
    }
    v
}

/// Regions of the fluorescent-surfaces scenes: the three dyes, the chart's white patch
/// and a piece of the back wall.
fn regions(scene: &Scene) -> Vec<(&'static str, Vec<usize>)> {
    let z = 558.2;
    let mut r = vec![];
    for (c, name) in ["highlighter", "orange", "pink"].into_iter().enumerate() {
        let x_hi = 278.0 + 180.0 - c as f32 * 130.0;
        r.push((
            name,
            rect_pixels(scene, (x_hi - 100.0, x_hi), (90.0, 190.0), z, 0.6),
        ));
    }
    // Chart patch 19 (white 9.5): row 3, column 0.
    let x_hi = 278.0 + 174.0;
    let y_hi = 500.0 - 3.0 * 58.0;
    r.push((
        "chart white",
        rect_pixels(scene, (x_hi - 50.0, x_hi), (y_hi - 50.0, y_hi), z, 0.7),
    ));
    r.push((
        "back wall",
        rect_pixels(scene, (60.0, 500.0), (20.0, 70.0), 559.0, 0.9),
    ));
    for (name, px) in &r {
        assert!(px.len() >= 12, "region {name} has {} pixels", px.len());
    }
    r
}

fn methods_agree(file: &str) {
    let mut scene = scene_file(file);
    let res = 128;
    scene.set_resolution(res, res);
    let regs = regions(&scene);
    let runs = [
        (
            "independent",
            render_with(
                &mut scene,
                res,
                256,
                1,
                Spectral::Hwss,
                Shifting::Independent,
            ),
        ),
        (
            "constant",
            render_with(&mut scene, res, 256, 2, Spectral::Hwss, Shifting::Constant),
        ),
        (
            "mono",
            render_with(
                &mut scene,
                res,
                1024,
                3,
                Spectral::Mono,
                Shifting::Independent,
            ),
        ),
    ];
    assert_all_agree(file, &runs, &regs, 4.0);
}

#[test]
fn mono_constant_and_independent_agree_under_d65() {
    methods_agree("fluorescent-surfaces.toml");
}

#[test]
fn mono_constant_and_independent_agree_under_440nm() {
    methods_agree("fluorescent-surfaces-440nm.toml");
}

#[test]
fn narrow_band_light_gives_no_nan_or_inf() {
    // Under 440 nm most lanes of most paths have zero shift probability at the dyes.
    for shifting in [Shifting::Independent, Shifting::Constant] {
        let mut scene = scene_file("fluorescent-surfaces-440nm.toml");
        let film = render_with(&mut scene, 48, 16, 9, Spectral::Hwss, shifting);
        assert!(film.mean().iter().all(|p| p.iter().all(|v| v.is_finite())));
        assert!(film
            .variance_of_mean()
            .iter()
            .all(|p| p.iter().all(|v| v.is_finite())));
    }
}

/// A fluorescent quad facing the camera inside a black box whose walls emit `light`.
fn plane_scene() -> String {
    r#"
[camera]
position = [0, 0, -3]
look_at = [0, 0, 0]
fov = 30
resolution = [16, 16]

[materials.dye]
type = "fluorescent_diffuse"
reflectance = { wavelengths = [360, 480, 520, 830], values = [0.1, 0.1, 0.8, 0.85] }
dye = { absorption = { wavelengths = [360, 420, 460, 500, 520], values = [0.4, 0.8, 0.85, 0.3, 0] }, emission = { wavelengths = [480, 510, 530, 560, 620], values = [0, 0.6, 1, 0.4, 0] }, quantum_yield = 0.9 }

[[shapes]]
type = "box"
min = [-20, -20, -20]
max = [20, 20, 20]
emission = { radiance = "D65", scale = 0.01, two_sided = true }

[[shapes]]
type = "quad"
origin = [-1, -1, 0]
edge_u = [0, 2, 0]
edge_v = [2, 0, 0]
material = "dye"
"#
    .to_string()
}

/// L_o(λo) = D(λo)·L(λo) + ∫ F(λi, λo) L(λi) dλi for the uniform light L.
fn closed_form(scene: &Scene, lambda_o: f32) -> f64 {
    let rr = match &scene.materials[0] {
        Material::FluorescentDiffuse { reradiation, .. } => reradiation.clone(),
        _ => panic!("expected the fluorescent material first"),
    };
    let light = Spectrum::Scaled(Box::new(illuminant("D65").unwrap()), 0.01);
    let mut integral = 0.0f64;
    let h = 0.05f32;
    let mut li = 360.0 + h / 2.0;
    while li < lambda_o {
        integral += (rr.f(li, lambda_o) * light.eval(li)) as f64 * h as f64;
        li += h;
    }
    (rr.d(lambda_o) * light.eval(lambda_o)) as f64 + integral
}

#[test]
fn fluorescent_plane_matches_the_closed_form_per_wavelength() {
    let scene = scene_from(&plane_scene());
    let ray = scene.camera.ray(8.0, 8.0);
    for lambda_o in [450.0f32, 505.0, 530.0, 560.0, 620.0] {
        let want = closed_form(&scene, lambda_o);
        let (mean, se) = mono_estimate(&scene, ray, lambda_o, 40_000, 3);
        let z = (mean - want) / se.max(1e-12);
        eprintln!("λo = {lambda_o}: {mean:.5} ± {se:.5}, closed form {want:.5}, z = {z:.2}");
        assert!(
            z.abs() < 4.0,
            "λo = {lambda_o}: {mean} vs {want} (z = {z:.2})"
        );
        // The fluorescent part matters here, so the test can tell it apart from D·L alone.
        if (505.0..=560.0).contains(&lambda_o) {
            let rr_only = match &scene.materials[0] {
                Material::FluorescentDiffuse { reradiation, .. } => reradiation.d(lambda_o) as f64,
                _ => unreachable!(),
            } * (0.01 * illuminant("D65").unwrap().eval(lambda_o)) as f64;
            assert!(
                (mean - rr_only).abs() > 6.0 * se,
                "λo = {lambda_o}: no fluorescence seen"
            );
        }
    }
}

#[test]
fn fluorescent_plane_colour_matches_the_closed_form_in_every_mode() {
    // XYZ of the closed-form spectrum against the rendered plane, HWSS (both shiftings) and mono.
    let mut scene = scene_from(&plane_scene());
    let mut xyz = Vec3::ZERO;
    let h = 0.5f32;
    let mut l = 360.0 + h / 2.0;
    while l < 830.0 {
        xyz += stokes::spectrum::cie_xyz(l) * closed_form(&scene, l) as f32 * h;
        l += h;
    }
    let want = xyz_to_linear_srgb(xyz / stokes::spectrum::CIE_Y_INTEGRAL);
    for (spectral, shifting, spp) in [
        (Spectral::Hwss, Shifting::Independent, 1024),
        (Spectral::Hwss, Shifting::Constant, 1024),
        (Spectral::Mono, Shifting::Independent, 4096),
    ] {
        let film = render_with(&mut scene, 16, spp, 21, spectral, shifting);
        let centre: Vec<usize> = (0..256usize)
            .filter(|i| (i % 16).abs_diff(8) < 4 && (i / 16).abs_diff(8) < 4)
            .collect();
        let got = region_mean(&film, &centre);
        assert_agree(
            &format!("plane {spectral:?} {shifting:?}"),
            got,
            (want.to_array().map(|v| v as f64), [0.0; 3]),
            4.0,
        );
    }
}

/// A sphere under a quad light in a white box; `sphere_material` is inserted verbatim.
fn sphere_scene(sphere_material: &str) -> String {
    format!(
        r#"
[camera]
position = [0, 1, -3]
look_at = [0, 1, 0]
fov = 45
resolution = [32, 32]

[materials.white]
type = "diffuse"
reflectance = 0.7

[materials.sphere]
{sphere_material}

[[shapes]]
type = "box"
min = [-2, 0, -4]
max = [2, 3, 2]
material = "white"

[[shapes]]
type = "sphere"
center = [0, 1, 0]
radius = 0.8
stacks = 24
material = "sphere"

[[shapes]]
type = "quad"
origin = [-0.5, 2.99, -0.5]
edge_u = [1, 0, 0]
edge_v = [0, 0, 1]
emission = {{ radiance = "D65", scale = 0.1 }}
"#
    )
}

#[test]
fn a_diagonal_only_matrix_renders_like_plain_diffuse() {
    // A measured-format matrix with only its diagonal, against the plain diffuse material
    // with the same reflectance (cell centres, held constant to the outer cell edges).
    let dir = scratch("diagonal");
    let centres: Vec<f32> = (0..47).map(|k| 365.0 + 10.0 * k as f32).collect();
    let diag: Vec<f32> = centres
        .iter()
        .map(|l| 0.2 + 0.6 * ((l - 360.0) / 470.0))
        .collect();
    let mut csv = String::from("nm");
    for c in &centres {
        csv += &format!(",{c}");
    }
    csv += "\n";
    for (i, c) in centres.iter().enumerate() {
        csv += &format!("{c}");
        for j in 0..centres.len() {
            csv += &format!(",{}", if i == j { diag[i] } else { 0.0 });
        }
        csv += "\n";
    }
    let csv_path = dir.join("diag.csv");
    std::fs::write(&csv_path, csv).unwrap();
    let mut w = vec![360.0];
    w.extend(&centres);
    w.push(830.0);
    let mut v = vec![diag[0]];
    v.extend(&diag);
    v.push(*diag.last().unwrap());
    let fmt = |x: &[f32]| {
        x.iter()
            .map(|a| a.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let plain = format!(
        "type = \"diffuse\"\nreflectance = {{ wavelengths = [{}], values = [{}] }}",
        fmt(&w),
        fmt(&v)
    );
    let fluo = format!(
        "type = \"fluorescent_diffuse\"\nmatrix = \"{}\"",
        csv_path.display()
    );
    let dyed = "type = \"fluorescent_diffuse\"\nreflectance = 0.3\ndye = { absorption = 0.5, emission = { narrow_band = 600, fwhm = 40 }, quantum_yield = 0.8 }";
    for (spectral, shifting) in [
        (Spectral::Hwss, Shifting::Independent),
        (Spectral::Hwss, Shifting::Constant),
        (Spectral::Mono, Shifting::Independent),
    ] {
        let a = render_with(
            &mut scene_from(&sphere_scene(&plain)),
            32,
            8,
            5,
            spectral,
            shifting,
        )
        .mean();
        let b = render_with(
            &mut scene_from(&sphere_scene(&fluo)),
            32,
            8,
            5,
            spectral,
            shifting,
        )
        .mean();
        let worst = a
            .iter()
            .zip(&b)
            .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / p[c].abs().max(1e-3)))
            .fold(0.0f32, f32::max);
        // Same random numbers, same arithmetic up to the order of float multiplications.
        assert!(
            worst < 1e-4,
            "{spectral:?} {shifting:?}: largest relative pixel difference {worst}"
        );
        // And the comparison can fail: a real dye changes the image.
        let c = render_with(
            &mut scene_from(&sphere_scene(dyed)),
            32,
            8,
            5,
            spectral,
            shifting,
        )
        .mean();
        let diff = a
            .iter()
            .zip(&c)
            .filter(|(p, q)| (p[0] - q[0]).abs() > 1e-3)
            .count();
        assert!(
            diff > 50,
            "a fluorescent sphere rendered like the plain one"
        );
    }
}

/// `plane_scene` with the dye under a dispersive coat (η = 1.45 + 20000/λ²) whose
/// absorption falls from 2.5 at 360 nm to 0.5 at 830 nm over a thickness of 0.2, so that
/// the coat's Fresnel, absorption and internal reflection all differ between the two
/// sides of a shift.
fn coated_plane_scene() -> String {
    plane_scene().replace(
        "[materials.dye]\ntype = \"fluorescent_diffuse\"\nreflectance",
        "[materials.dye]\ntype = \"coated\"\nior = { cauchy = [1.45, 20000] }\n\
         absorption = { wavelengths = [360, 830], values = [2.5, 0.5] }\nthickness = 0.2\n\
         [materials.dye.base]\ntype = \"fluorescent_diffuse\"\nreflectance",
    )
}

/// The coat's index and optical depth at `lambda`.
fn coat_at(lambda: f32) -> (f64, f64) {
    let l = f64::from(lambda);
    let sigma = 2.5 + (0.5 - 2.5) * (l - 360.0) / (830.0 - 360.0);
    (1.45 + 20_000.0 / (l * l), sigma * 0.2)
}

/// Unpolarised Fresnel reflectance, `eta` = n_t/n_i (total reflection beyond critical).
fn fresnel_f64(c: f64, eta: f64) -> f64 {
    let s2 = (1.0 - c * c) / (eta * eta);
    if s2 >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - s2).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}

/// One crossing of the coat at cosine `c` outside: (1 − F)·e^(−τ/cos θ').
fn coat_crossing(c: f64, lambda: f32) -> f64 {
    let (eta, tau) = coat_at(lambda);
    let ct = (1.0 - (1.0 - c * c) / (eta * eta)).sqrt();
    (1.0 - fresnel_f64(c, eta)) * (-tau / ct).exp()
}

/// The coat's internal reflectance of diffuse light, round trip's absorption included:
/// 2∫ F(μ, 1/η)·e^(−2τ/μ)·μ dμ (μ inside).
fn coat_internal_reflectance(lambda: f32) -> f64 {
    let (eta, tau) = coat_at(lambda);
    let n = 20_000;
    (0..n)
        .map(|i| {
            let mu = (i as f64 + 0.5) / n as f64;
            2.0 * fresnel_f64(mu, 1.0 / eta) * (-2.0 * tau / mu).exp() * mu / n as f64
        })
        .sum()
}

/// What diffuse light keeps entering the coat at `lambda`: 2∫ crossing(μ)·μ dμ.
fn coat_diffuse_transmittance(lambda: f32) -> f64 {
    let n = 1000;
    (0..n)
        .map(|i| {
            let mu = (i as f64 + 0.5) / n as f64;
            2.0 * coat_crossing(mu, lambda) * mu / n as f64
        })
        .sum()
}

/// The layer model under the uniform light L seen at `cos_o`, per wavelength:
/// F(θo, λo)·L(λo) + exit(θo, λo)·[D(λo)·T(λo)·L(λo) + ∫ F(λi, λo)·T(λi)·L(λi) dλi],
/// with exit = crossing(θo, λo)/(η(λo)²·(1 − D(λo)·r(λo))).
fn coated_closed_form(scene: &Scene, lambda_o: f32, cos_o: f64) -> f64 {
    let Material::Coated(c) = &scene.materials[0] else {
        panic!("expected the coated material first")
    };
    let rr = c.reradiation().expect("a Lambertian base").clone();
    let light = Spectrum::Scaled(Box::new(illuminant("D65").unwrap()), 0.01);
    // T on the integration grid, once per test binary.
    static T: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    let h = 0.25f32;
    let t = T.get_or_init(|| {
        (0..1880)
            .map(|k| coat_diffuse_transmittance(360.0 + h * (k as f32 + 0.5)))
            .collect()
    });
    let mut shifted = 0.0f64;
    for (k, t) in t.iter().enumerate() {
        let li = 360.0 + h * (k as f32 + 0.5);
        if li >= lambda_o {
            break;
        }
        shifted += f64::from(rr.f(li, lambda_o) * light.eval(li)) * t * f64::from(h);
    }
    let d = f64::from(rr.d(lambda_o));
    let l_o = f64::from(light.eval(lambda_o));
    let base = d * coat_diffuse_transmittance(lambda_o) * l_o + shifted;
    let (eta, _) = coat_at(lambda_o);
    let exit = coat_crossing(cos_o, lambda_o)
        / (eta * eta * (1.0 - d * coat_internal_reflectance(lambda_o)));
    fresnel_f64(cos_o, eta) * l_o + exit * base
}

#[test]
fn coated_fluorescent_plane_matches_the_layer_model_per_wavelength() {
    let scene = scene_from(&coated_plane_scene());
    let ray = scene.camera.ray(8.0, 8.0);
    let cos_o = f64::from(ray.dir.normalize().z.abs());
    for lambda_o in [450.0f32, 505.0, 530.0, 560.0, 620.0] {
        let want = coated_closed_form(&scene, lambda_o, cos_o);
        let (mean, se) = mono_estimate(&scene, ray, lambda_o, 160_000, 5);
        let z = (mean - want) / se.max(1e-12);
        eprintln!(
            "coated, λo = {lambda_o}: {mean:.5} ± {se:.5}, layer model {want:.5}, z = {z:.2}"
        );
        assert!(
            z.abs() < 4.0,
            "λo = {lambda_o}: {mean} vs {want} (z = {z:.2})"
        );
    }
}

/// `coated_plane_scene` under a rough coat (α 0.25).
fn rough_coated_plane_scene() -> String {
    coated_plane_scene().replace("thickness = 0.2\n", "thickness = 0.2\nroughness = 0.25\n")
}

/// The rough layer model under the uniform light L seen at `cos_o`, from the library's
/// own pieces (the coat's GGX albedo E, the crossings 1 − E, the exit factor), so that
/// what is tested is how the integrator puts them together across a shift:
/// E(θo, λo)·L(λo) + exit(θo, λo)·[D(λo)·T(λo)·L(λo) + ∫ F(λi, λo)·T(λi)·L(λi) dλi],
/// T(λ) = 2∫ crossing(μ, λ)·μ dμ.
fn rough_coated_closed_form(scene: &Scene, lambda_o: f32, cos_o: f64) -> f64 {
    use stokes::bsdf::{albedo, coated};
    use stokes::simd::Spec;
    let Material::Coated(c) = &scene.materials[0] else {
        panic!("expected the coated material first")
    };
    let rr = c.reradiation().expect("a Lambertian base").clone();
    let light = Spectrum::Scaled(Box::new(illuminant("D65").unwrap()), 0.01);
    let diffuse_t = |l: f32| {
        let (eta, tau) = (Spec::splat(c.ior.eval(l)), Spec::splat(c.tau.eval(l)));
        let n = 400;
        (0..n)
            .map(|i| {
                let mu = (i as f32 + 0.5) / n as f32;
                2.0 * f64::from(coated::crossing(mu, &eta, &tau, c.alpha)[0] * mu) / n as f64
            })
            .sum::<f64>()
    };
    let h = 1.0f32;
    let mut shifted = 0.0f64;
    let mut li = 360.0 + h / 2.0;
    while li < lambda_o {
        shifted += f64::from(rr.f(li, lambda_o) * light.eval(li)) * diffuse_t(li) * f64::from(h);
        li += h;
    }
    let d = f64::from(rr.d(lambda_o));
    let l_o = f64::from(light.eval(lambda_o));
    let base = d * diffuse_t(lambda_o) * l_o + shifted;
    let exit = f64::from(c.exit(cos_o as f32, &Spec::splat(lambda_o), true)[0]);
    let e = albedo::reflection_albedo(cos_o as f32, c.ior.eval(lambda_o), c.alpha);
    f64::from(e) * l_o + exit * base
}

#[test]
fn rough_coated_fluorescent_plane_matches_the_layer_model_per_wavelength() {
    let scene = scene_from(&rough_coated_plane_scene());
    let ray = scene.camera.ray(8.0, 8.0);
    let cos_o = f64::from(ray.dir.normalize().z.abs());
    for lambda_o in [450.0f32, 530.0, 560.0, 620.0] {
        let want = rough_coated_closed_form(&scene, lambda_o, cos_o);
        let (mean, se) = mono_estimate(&scene, ray, lambda_o, 160_000, 6);
        // 4 standard errors and 0.3 % for the quadratures of E and of the shift integral.
        let tol = 4.0 * se + 3e-3 * want;
        eprintln!("rough coat, λo = {lambda_o}: {mean:.5} ± {se:.5}, layer model {want:.5}");
        assert!(
            (mean - want).abs() < tol,
            "λo = {lambda_o}: {mean} vs {want} (tolerance {tol})"
        );
    }
}

#[test]
fn rough_coated_fluorescent_plane_agrees_in_every_mode() {
    let mut scene = scene_from(&rough_coated_plane_scene());
    let centre: Vec<usize> = (0..256usize)
        .filter(|i| (i % 16).abs_diff(8) < 3 && (i / 16).abs_diff(8) < 3)
        .collect();
    let mono = render_with(
        &mut scene,
        16,
        8192,
        29,
        Spectral::Mono,
        Shifting::Independent,
    );
    let mono = region_mean(&mono, &centre);
    for shifting in [Shifting::Independent, Shifting::Constant] {
        let film = render_with(&mut scene, 16, 2048, 31, Spectral::Hwss, shifting);
        let got = region_mean(&film, &centre);
        eprintln!("rough-coated plane HWSS {shifting:?}: {got:?}, mono {mono:?}");
        assert_agree(
            &format!("rough coat, HWSS {shifting:?} vs mono"),
            got,
            mono,
            4.0,
        );
    }
}

#[test]
fn coated_fluorescent_plane_colour_agrees_in_every_mode() {
    let mut scene = scene_from(&coated_plane_scene());
    let ray = scene.camera.ray(8.0, 8.0);
    let cos_o = f64::from(ray.dir.normalize().z.abs());
    let mut xyz = Vec3::ZERO;
    let h = 0.5f32;
    let mut l = 360.0 + h / 2.0;
    while l < 830.0 {
        xyz += stokes::spectrum::cie_xyz(l) * coated_closed_form(&scene, l, cos_o) as f32 * h;
        l += h;
    }
    let want = xyz_to_linear_srgb(xyz / stokes::spectrum::CIE_Y_INTEGRAL);
    // The pixels near the centre see the plane within 4° of its normal: the coat's Fresnel
    // changes by < 0.1 % there.
    let centre: Vec<usize> = (0..256usize)
        .filter(|i| (i % 16).abs_diff(8) < 3 && (i / 16).abs_diff(8) < 3)
        .collect();
    for (spectral, shifting, spp) in [
        (Spectral::Hwss, Shifting::Independent, 2048),
        (Spectral::Hwss, Shifting::Constant, 2048),
        (Spectral::Mono, Shifting::Independent, 8192),
    ] {
        let film = render_with(&mut scene, 16, spp, 23, spectral, shifting);
        let got = region_mean(&film, &centre);
        eprintln!("coated plane {spectral:?} {shifting:?}: {got:?}, layer model {want}");
        assert_agree(
            &format!("coated plane {spectral:?} {shifting:?}"),
            got,
            (want.to_array().map(|v| v as f64), [0.0; 3]),
            4.0,
        );
    }
}
