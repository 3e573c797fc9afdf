//! Point, spot, directional and environment lights against their analytic answers: the
//! irradiance I·cos θ / r² of a point light on a plane (a Z-test per pixel row), a spot's
//! cone edge, a directional light's E·cos θ, white furnaces in a constant environment;
//! and their scene-file errors.

mod common;
use common::*;
use glam::Vec3;
use stokes::method::Spectral;

/// A white diffuse floor (reflectance `rho`) at y = 0, 8 × 8 wide, seen from straight
/// above at height 3; `lights` are the scene's `[[lights]]` (and any other TOML).
fn floor_scene(rho: f32, lights: &str) -> String {
    format!(
        r#"
[camera]
position = [0, 3, 0]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov = 70
resolution = [24, 24]

[materials.floor]
type = "diffuse"
reflectance = {rho}

[[shapes]]
type = "quad"
origin = [-4, 0, -4]
edge_u = [0, 0, 8]
edge_v = [8, 0, 0]
material = "floor"

{lights}
"#
    )
}

/// The floor point (y = 0) seen through film position (x, y).
fn floor_point(scene: &stokes::scene::Scene, x: f32, y: f32) -> Vec3 {
    let r = scene.camera.ray(x, y);
    let (o, d) = (r.org, r.dir);
    o + d * (-o.y / d.y)
}

/// Per pixel, the mean over an 8 × 8 grid of film positions of the floor's radiance
/// `radiance(point)` (the pixel's box filter, integrated by the midpoint rule).
fn expected_image(scene: &stokes::scene::Scene, radiance: impl Fn(Vec3) -> f64) -> Vec<f64> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let n = 8;
    let mut out = Vec::new();
    for py in 0..h {
        for px in 0..w {
            let mut sum = 0.0;
            for j in 0..n {
                for i in 0..n {
                    let x = px as f32 + (i as f32 + 0.5) / n as f32;
                    let y = py as f32 + (j as f32 + 0.5) / n as f32;
                    sum += radiance(floor_point(scene, x, y));
                }
            }
            out.push(sum / (n * n) as f64);
        }
    }
    out
}

/// Renders `text` and checks every pixel row's mean (green channel: a constant spectrum
/// of 1 has green [`white_rgb`]`[1]`) against `radiance` × that, a Z-test per row, and
/// that the pixels expected black are exactly black. Returns the largest |z|.
fn assert_rows_match(what: &str, text: &str, radiance: impl Fn(Vec3) -> f64, spp: u32) -> f64 {
    let mut scene = scene_from(text);
    let expected = expected_image(&scene, radiance);
    let white = white_rgb()[1];
    let film = TestRender::at(scene.camera.width, scene.camera.height)
        .spp(spp)
        .seed(7)
        .film(&mut scene);
    let (w, h) = (film.width as usize, film.height as usize);
    let mean = film.mean();
    let var = film.variance_of_mean();
    let mut worst: f64 = 0.0;
    for row in 0..h {
        let px: Vec<usize> = (row * w..(row + 1) * w).collect();
        let want = px.iter().map(|&i| expected[i]).sum::<f64>() / w as f64 * white;
        let got = px.iter().map(|&i| f64::from(mean[i][1])).sum::<f64>() / w as f64;
        let se = px.iter().map(|&i| f64::from(var[i][1])).sum::<f64>().sqrt() / w as f64;
        // A pixel whose neighbours are black too lies wholly outside the light.
        let dark = |x: usize, y: usize| expected[y.min(h - 1) * w + x.min(w - 1)] == 0.0;
        for x in 0..w {
            let around = (x.saturating_sub(1)..=x + 1)
                .all(|u| (row.saturating_sub(1)..=row + 1).all(|v| dark(u, v)));
            if around {
                let i = row * w + x;
                assert_eq!(mean[i], [0.0; 3], "{what}: pixel {i} should be black");
            }
        }
        if want == 0.0 {
            assert_eq!(got, 0.0, "{what}: row {row} should be black");
            continue;
        }
        let z = (got - want) / se.max(1e-12);
        assert!(
            z.abs() < 4.5,
            "{what}: row {row}: {got:.6} vs {want:.6} (z = {z:.2}, se {se:.2e})"
        );
        worst = worst.max(z.abs());
    }
    eprintln!("{what}: largest |z| over {h} rows {worst:.2}");
    worst
}

#[test]
fn a_point_light_lights_a_plane_with_intensity_cos_over_r_squared() {
    let (rho, i) = (0.8, 2.5);
    let light = Vec3::new(0.7, 1.5, -0.4);
    let text = floor_scene(
        rho,
        &format!(
            "[[lights]]\ntype = \"point\"\nposition = [{}, {}, {}]\nintensity = {i}\n",
            light.x, light.y, light.z
        ),
    );
    let radiance = |p: Vec3| {
        let to = light - p;
        let r2 = f64::from(to.length_squared());
        let cos = f64::from(to.normalize().y);
        f64::from(rho) / std::f64::consts::PI * i * cos / r2
    };
    assert_rows_match("point light", &text, radiance, 16);
}

#[test]
fn a_spot_light_is_a_point_light_inside_its_cone_and_black_outside() {
    let (rho, i) = (0.8, 2.5);
    let light = Vec3::new(0.3, 1.5, 0.2);
    let target = Vec3::new(0.3, 0.0, 0.5);
    let (angle, falloff) = (45.0f32, 10.0f32);
    let text = floor_scene(
        rho,
        &format!(
            "[[lights]]\ntype = \"spot\"\nposition = [{}, {}, {}]\nlook_at = [{}, {}, {}]\nangle = {angle}\nfalloff = {falloff}\nintensity = {i}\n",
            light.x, light.y, light.z, target.x, target.y, target.z
        ),
    );
    let axis = (target - light).normalize();
    let (cos_o, cos_i) = (
        angle.to_radians().cos(),
        (angle - falloff).to_radians().cos(),
    );
    let radiance = |p: Vec3| {
        let to = light - p;
        let r2 = f64::from(to.length_squared());
        let wi = to.normalize();
        // Smoothstep from the outer cone to the inner one, written out here.
        let t = f64::from((axis.dot(-wi) - cos_o) / (cos_i - cos_o)).clamp(0.0, 1.0);
        let edge = t * t * (3.0 - 2.0 * t);
        f64::from(rho) / std::f64::consts::PI * i * edge * f64::from(wi.y) / r2
    };
    // The cone covers a part of the image only: the rest must be exactly black.
    let scene = scene_from(&text);
    let expected = expected_image(&scene, radiance);
    let black = expected.iter().filter(|&&v| v == 0.0).count();
    assert!(
        black > 100 && black < expected.len() - 100,
        "{black} black pixels"
    );
    assert_rows_match("spot light", &text, radiance, 16);
}

#[test]
fn a_directional_light_gives_irradiance_times_cos() {
    let (rho, e) = (0.6, 1.7f32);
    let theta = 50f32.to_radians();
    let d = Vec3::new(theta.sin(), -theta.cos(), 0.0);
    let text = floor_scene(
        rho,
        &format!(
            "[[lights]]\ntype = \"directional\"\ndirection = [{}, {}, {}]\nirradiance = {e}\n",
            d.x, d.y, d.z
        ),
    );
    let want = f64::from(rho) / std::f64::consts::PI * f64::from(e) * f64::from(theta.cos());
    // Deterministic but for the wavelengths: 4 spp decide it.
    let z = assert_rows_match("directional light", &text, |_| want, 4);
    assert!(z < 4.5);
}

#[test]
fn a_point_light_in_an_absorbing_medium_is_dimmed_by_the_transmittance() {
    // The floor, the light and the lower part of the camera rays lie in a box of
    // absorbing medium (index-matched): L = ρ/π·I·cos θ/r²·e^{−σ r}·e^{−σ s}, s the camera
    // ray's length inside the box.
    let (rho, i, sigma, top) = (0.8, 2.5, 0.35f32, 2.5f32);
    let light = Vec3::new(0.4, 1.5, -0.3);
    let text = floor_scene(
        rho,
        &format!(
            "[media.ink]\nsigma_a = {sigma}\nsigma_s = 0.0\n\n[[shapes]]\ntype = \"box\"\nmin = [-4.5, -0.5, -4.5]\nmax = [4.5, {top}, 4.5]\ninterior = \"ink\"\n\n[[lights]]\ntype = \"point\"\nposition = [{}, {}, {}]\nintensity = {i}\n",
            light.x, light.y, light.z
        ),
    );
    let radiance = |p: Vec3| {
        let to = light - p;
        let r = f64::from(to.length());
        let cos = f64::from(to.normalize().y);
        let eye = Vec3::new(0.0, 3.0, 0.0) - p;
        let s = f64::from(eye.length() * top / eye.y);
        let tr = (-f64::from(sigma) * (r + s)).exp();
        f64::from(rho) / std::f64::consts::PI * i * cos / (r * r) * tr
    };
    assert_rows_match("point light in a medium", &text, radiance, 16);
}

/// A unit sphere of reflectance `rho` in a constant environment of radiance 1 (and
/// nothing else), seen from outside.
fn sphere_in_sky(rho: f32) -> String {
    format!(
        r#"
[camera]
position = [0, 0, -2.5]
look_at = [0, 0, 0]
fov = 60
resolution = [16, 16]

[materials.ball]
type = "diffuse"
reflectance = {rho}

[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
stacks = 24
smooth = true
material = "ball"

[[lights]]
type = "environment"
radiance = 1
"#
    )
}

#[test]
fn a_white_sphere_in_a_constant_environment_is_a_white_furnace() {
    let white = white_rgb();
    for spectral in [Spectral::Hwss, Spectral::Mono] {
        let mut scene = scene_from(&sphere_in_sky(1.0));
        let spp = if spectral == Spectral::Hwss {
            1024
        } else {
            8192
        };
        let film = TestRender::at(16, 16)
            .spp(spp)
            .seed(3)
            .spectral(spectral)
            .film(&mut scene);
        let (m, se) = region_mean(&film, &all_pixels(&film));
        eprintln!("{spectral:?}: {m:?} ± {se:?}, expected {white:?}");
        for c in 0..3 {
            assert!(se[c] < 0.0015 * white[c], "too few samples: se {}", se[c]);
            let rel = (m[c] - white[c]).abs() / white[c];
            assert!(
                rel < 0.005,
                "{spectral:?} channel {c}: {} vs {} ({rel:.4})",
                m[c],
                white[c]
            );
        }
    }
}

#[test]
fn a_grey_convex_sphere_in_a_constant_environment_reflects_albedo_times_sky() {
    // Every direction above a convex surface sees the sky: L = ρ·L_sky at any depth, a
    // check that light sampling and escaping rays share the weight 1 between them.
    let rho = 0.4;
    let mut scene = scene_from(&sphere_in_sky(rho));
    let white = white_rgb();
    // The pixels wholly on the sphere: the projected disc is ±1/tan(30°)/√(2.5²−1) wide.
    let centre: Vec<usize> = (0..256)
        .filter(|i| {
            let (x, y) = ((i % 16) as f32 - 7.5, (i / 16) as f32 - 7.5);
            (x * x + y * y).sqrt() < 4.5
        })
        .collect();
    for depth in [2, -1] {
        let film = TestRender::at(16, 16)
            .spp(512)
            .seed(4)
            .max_depth(depth)
            .film(&mut scene);
        let (m, se) = region_mean(&film, &centre);
        for c in 0..3 {
            let want = f64::from(rho) * white[c];
            let z = (m[c] - want) / se[c];
            assert!(
                z.abs() < 4.5,
                "depth {depth}, channel {c}: {} vs {want} (z {z:.2})",
                m[c]
            );
        }
    }
}

#[test]
fn light_selection_weighs_every_kind_by_power() {
    // A point light of intensity I (power 4πI per nm) and a spot of the same intensity
    // and a 60° cone (power 2π(1 − cos)·I with the soft edge half counted) are picked in
    // proportion to their power.
    let text = floor_scene(
        0.5,
        "[[lights]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = 1\n\n[[lights]]\ntype = \"spot\"\nposition = [0, 1, 0]\nlook_at = [0, 0, 0]\nangle = 60\nfalloff = 0\nintensity = 1\n",
    );
    let scene = scene_from(&text);
    let lights = &scene.lights;
    assert_eq!(lights.delta.len(), 2);
    let (p_point, p_spot) = (lights.pmf_delta(0), lights.pmf_delta(1));
    let want = 4.0 / (4.0 + 2.0 * (1.0 - 0.5));
    assert!((p_point - want).abs() < 1e-6, "{p_point} vs {want}");
    assert!((p_point + p_spot - 1.0).abs() < 1e-6);
    // A point light against a constant sky of radiance 1: the sky weighs 4π·r² (its power
    // 4π·πr²·L over π) for the floor's bounding radius r = ½·|(8, 0, 8)|.
    let text = floor_scene(
        0.5,
        "[[lights]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = 1\n\n[[lights]]\ntype = \"environment\"\nradiance = 1\n",
    );
    let scene = scene_from(&text);
    let r2 = 32.0f32;
    let sky = 4.0 * std::f32::consts::PI * r2;
    let want = 4.0 / (4.0 + sky);
    let got = scene.lights.pmf_delta(0);
    assert!(
        (got - want).abs() < 1e-6 * want.max(1e-3),
        "{got} vs {want}"
    );
    let p_sky = scene.lights.pdf_environment(Vec3::Y) * 4.0 * std::f32::consts::PI;
    assert!((p_sky - sky / (4.0 + sky)).abs() < 1e-5, "{p_sky}");
}

#[test]
fn bad_lights_are_rejected_naming_the_key() {
    let cases: [(&str, &str); 9] = [
        ("type = \"laser\"\nposition = [0, 1, 0]", "lights[0].type: expected one of point, spot, directional, environment"),
        ("type = \"point\"\nintensity = 1", "lights[0]: missing key `position` for a point light"),
        ("type = \"point\"\nposition = [0, 1, 0]", "lights[0]: missing key `intensity` for a point light"),
        ("type = \"point\"\nposition = [0, 1, 0]\nintensity = 1\nangle = 30", "lights[0].angle: not a key of a point light"),
        ("type = \"spot\"\nposition = [0, 1, 0]\nlook_at = [0, 0, 0]\nangle = 190\nintensity = 1", "lights[0].angle: expected a half-angle in (0, 180] degrees"),
        ("type = \"spot\"\nposition = [0, 1, 0]\nlook_at = [0, 0, 0]\nangle = 0\nintensity = 1", "lights[0].angle: expected a half-angle in (0, 180] degrees"),
        ("type = \"spot\"\nposition = [0, 1, 0]\nlook_at = [0, 1, 0]\nangle = 30\nintensity = 1", "lights[0].look_at: expected a point other than `position`"),
        ("type = \"directional\"\ndirection = [0, 0, 0]\nirradiance = 1", "lights[0].direction: expected a non-zero direction"),
        ("type = \"environment\"\nradiance = -1", "lights[0].radiance"),
    ];
    let load = |text: &str| -> String {
        let path = root().join("scenes/inline.toml");
        match stokes::scene::Scene::from_str(text, &path) {
            Ok(_) => panic!("{text:?} loaded"),
            Err(e) => e.to_string(),
        }
    };
    for (light, want) in cases {
        let err = load(&floor_scene(0.5, &format!("[[lights]]\n{light}\n")));
        assert!(err.contains(want), "{light:?}: {err}");
    }
    let two = "[[lights]]\ntype = \"environment\"\nradiance = 1\n\n[[lights]]\ntype = \"environment\"\nradiance = 1\n";
    let err = load(&floor_scene(0.5, two));
    assert!(
        err.contains("lights[1].type: a second environment light"),
        "{err}"
    );
}

#[test]
fn stokes_info_lists_the_lights_by_kind() {
    let scene = root().join("scenes/product-shot-spot.toml");
    let (ok, out, err) = run(stokes().args(["info", &s(&scene)]));
    assert!(ok, "{err}");
    assert!(
        out.contains("lights      1 spot, 1 constant environment"),
        "{out}"
    );
    let cbox = root().join("scenes/cornell-box.toml");
    let (_, out, _) = run(stokes().args(["info", &s(&cbox)]));
    assert!(out.contains("lights      1 area (2 triangles)"), "{out}");
}
