//! Fluorescence maps: a dye strength and a diagonal that vary over a surface
//! (`fluorescence = …`, a textured `reflectance` on a fluorescent_diffuse material). A
//! quad under a uniform sky re-radiates L_o(λo) = D_uv(λo)·L(λo) + s_uv·∫F(λi, λo)L(λi)dλi;
//! each region of the quad is checked against that closed form, per wavelength and in
//! colour, in every spectral mode; data maps are read without sRGB decoding; bad maps
//! are refused naming the file and key.

mod common;
use common::plate::{write_png, write_png_2x2};
use common::*;
use glam::Vec3;
use stokes::bsdf::Material;
use stokes::color::xyz_to_linear_srgb;
use stokes::fluoro::Reradiation;
use stokes::method::{Method, Shifting, Spectral};
use stokes::scene::Scene;
use stokes::spectrum::{illuminant, Spectrum, Tabulated};

/// The dye of tests/fluorescent_surfaces.rs: absorbs in the blue, emits in the green.
const DYE: &str = "dye = { absorption = { wavelengths = [360, 420, 460, 500, 520], values = [0.4, 0.8, 0.85, 0.3, 0] }, emission = { wavelengths = [480, 510, 530, 560, 620], values = [0, 0.6, 1, 0.4, 0] }, quantum_yield = 0.9 }";
/// The two diagonals the checkerboard tests use.
const D0: [f32; 4] = [0.1, 0.1, 0.8, 0.85];
const D1: [f32; 4] = [0.6, 0.5, 0.3, 0.2];
const D_NM: [f32; 4] = [360.0, 480.0, 520.0, 830.0];

fn diagonal(d: [f32; 4]) -> Spectrum {
    Spectrum::Tabulated(Tabulated::new(D_NM.to_vec(), d.to_vec()).unwrap())
}

fn diagonal_desc(d: [f32; 4]) -> String {
    format!("{{ wavelengths = {D_NM:?}, values = {d:?} }}")
}

/// A fluorescent quad filling a 32 × 32 view under a uniform D65 sky; `keys` are the
/// material's reflectance and fluorescence lines.
fn quad_scene(keys: &str) -> String {
    format!(
        r#"
[camera]
position = [0, 0, 1]
look_at = [0, 0, 0]
fov = 90
resolution = [32, 32]

[materials.print]
type = "fluorescent_diffuse"
{keys}
{DYE}

[[shapes]]
type = "quad"
origin = [-1, -1, 0]
edge_u = [2, 0, 0]
edge_v = [0, 2, 0]
material = "print"

[[lights]]
type = "environment"
radiance = {{ illuminant = "D65", scale = 0.01 }}
"#
    )
}

fn sky() -> Spectrum {
    Spectrum::Scaled(Box::new(illuminant("D65").unwrap()), 0.01)
}

fn reradiation(scene: &Scene) -> Reradiation {
    match &scene.materials[0] {
        Material::FluorescentDiffuse { reradiation, .. } => reradiation.as_ref().clone(),
        _ => panic!("expected the fluorescent material first"),
    }
}

/// L_o(λo) = D(λo)·L(λo) + s·∫F(λi, λo)L(λi)dλi under the sky.
fn closed_form(rr: &Reradiation, d: &Spectrum, s: f64, lambda_o: f32) -> f64 {
    let light = sky();
    let h = 0.05f32;
    let mut integral = 0.0f64;
    let mut li = 360.0 + h / 2.0;
    while li < lambda_o {
        integral += f64::from(rr.f(li, lambda_o) * light.eval(li)) * f64::from(h);
        li += h;
    }
    f64::from(d.eval(lambda_o) * light.eval(lambda_o)) + s * integral
}

/// Linear sRGB of [`closed_form`].
fn closed_form_rgb(rr: &Reradiation, d: &Spectrum, s: f64) -> [f64; 3] {
    let mut xyz = Vec3::ZERO;
    let h = 0.5f32;
    let mut l = 360.0 + h / 2.0;
    while l < 830.0 {
        xyz += stokes::spectrum::cie_xyz(l) * closed_form(rr, d, s, l) as f32 * h;
        l += h;
    }
    xyz_to_linear_srgb(xyz / stokes::spectrum::CIE_Y_INTEGRAL)
        .to_array()
        .map(f64::from)
}

/// The outer 8 × 8 pixels of the quadrant whose top-left pixel is (x0, y0).
fn corner(x0: usize, y0: usize) -> Vec<usize> {
    (y0..y0 + 8)
        .flat_map(|y| (x0..x0 + 8).map(move |x| y * 32 + x))
        .collect()
}

/// Top-left, top-right, bottom-left, bottom-right corners; u runs right, v up.
const CORNERS: [(usize, usize); 4] = [(0, 0), (24, 0), (0, 24), (24, 24)];

fn render(
    scene: &mut Scene,
    spectral: Spectral,
    shifting: Shifting,
    spp: u32,
) -> stokes::integrator::render::Film {
    let method = Method {
        spectral,
        shifting,
        ..Method::default()
    };
    TestRender::at(32, 32)
        .spp(spp)
        .seed(31)
        .method(method)
        .film(scene)
}

/// Each corner's colour against its closed form (diagonal, strength), in HWSS with both
/// shiftings and in mono.
fn corners_match(scene: &mut Scene, want: [(Spectrum, f64); 4], what: &str) {
    let rr = reradiation(scene);
    for (spectral, shifting, spp) in [
        (Spectral::Hwss, Shifting::Independent, 256),
        (Spectral::Hwss, Shifting::Constant, 256),
        (Spectral::Mono, Shifting::Independent, 1024),
    ] {
        let film = render(scene, spectral, shifting, spp);
        for (k, (x0, y0)) in CORNERS.into_iter().enumerate() {
            let (d, s) = &want[k];
            let rgb = closed_form_rgb(&rr, d, *s);
            assert_agree(
                &format!("{what}: corner {k} {spectral:?} {shifting:?}"),
                region_mean(&film, &corner(x0, y0)),
                (rgb, [0.0; 3]),
                4.5,
            );
        }
    }
}

#[test]
fn a_constant_strength_scales_the_reradiated_part_per_wavelength() {
    for s in [0.0f64, 0.35, 1.0] {
        let text = quad_scene(&format!(
            "reflectance = {}\nfluorescence = {s}",
            diagonal_desc(D0)
        ));
        let scene = scene_from(&text);
        let rr = reradiation(&scene);
        let ray = scene.camera.ray(16.0, 16.0);
        for lambda_o in [450.0f32, 505.0, 530.0, 560.0] {
            let want = closed_form(&rr, &diagonal(D0), s, lambda_o);
            let (mean, se) = mono_estimate(&scene, ray, lambda_o, 20_000, 5);
            let z = (mean - want) / se.max(1e-12);
            assert!(
                z.abs() < 4.5,
                "s = {s}, λo = {lambda_o}: {mean} vs {want} (z = {z:.2})"
            );
        }
        // The green re-emission is what s scales: it must be visible at full strength.
        let full = closed_form(&rr, &diagonal(D0), 1.0, 530.0);
        let none = closed_form(&rr, &diagonal(D0), 0.0, 530.0);
        assert!(
            full > 1.3 * none,
            "{full} vs {none}: the test cannot see the dye"
        );
    }
}

#[test]
fn checkerboards_of_diagonal_and_strength_land_on_their_squares() {
    // 2 × 2 squares: (u, v) near (0, 1) (top left) and (1, 0) (bottom right) take the
    // second entry, the other two corners the first.
    let keys = format!(
        "reflectance = {{ checkerboard = [{}, {}], checks = [2, 2] }}\nfluorescence = {{ checkerboard = [0.2, 1], checks = [2, 2] }}",
        diagonal_desc(D0),
        diagonal_desc(D1)
    );
    let mut scene = scene_from(&quad_scene(&keys));
    let first = || (diagonal(D0), 0.2);
    let second = || (diagonal(D1), 1.0);
    corners_match(
        &mut scene,
        [second(), first(), first(), second()],
        "checkerboards",
    );
}

#[test]
fn image_strength_maps_are_data_read_without_srgb_decoding() {
    let dir = scratch("fluorescence-map-images");
    let grey = dir.join("mask.png");
    let values = [0u8, 255, 128, 64];
    write_png_2x2(&grey, 1, &values);
    let rgb = dir.join("mask-rgb.png");
    // The map in the green channel, other values in red and blue.
    let texels: Vec<u8> = values.iter().flat_map(|&g| [255 - g, g, 7]).collect();
    write_png_2x2(&rgb, 3, &texels);
    let want = |k: usize| (diagonal(D0), f64::from(values[k]) / 255.0);
    for map in [
        format!("{{ texture = {:?}, wrap = \"clamp\" }}", s(&grey)),
        format!(
            "{{ texture = {:?}, channel = \"g\", wrap = \"clamp\" }}",
            s(&rgb)
        ),
    ] {
        let keys = format!("reflectance = {}\nfluorescence = {map}", diagonal_desc(D0));
        let mut scene = scene_from(&quad_scene(&keys));
        corners_match(&mut scene, [want(0), want(1), want(2), want(3)], &map);
    }
}

#[test]
fn bad_maps_are_refused_naming_the_file_and_key() {
    let dir = scratch("fluorescence-map-bad");
    let grey = dir.join("grey.png");
    write_png_2x2(&grey, 1, &[0, 10, 20, 30]);
    let rgb = dir.join("rgb.png");
    write_png_2x2(&rgb, 3, &[0; 12]);
    let bright = dir.join("bright.exr");
    exr::prelude::write_rgb_file(&bright, 2, 2, |_, _| (0.5f32, 1.5f32, 0.5f32)).unwrap();
    let d0 = diagonal_desc(D0);
    let cases = [
        (
            "fluorescence = 1.5".to_string(),
            "materials.print.fluorescence",
            "dye strength in [0, 1]",
        ),
        (
            "fluorescence = -0.1".into(),
            "materials.print.fluorescence",
            "found -0.1",
        ),
        (
            format!("fluorescence = {{ texture = {:?} }}", s(&rgb)),
            "materials.print.fluorescence.texture",
            "needs `channel = \"r\"`",
        ),
        (
            format!(
                "fluorescence = {{ texture = {:?}, channel = \"r\" }}",
                s(&grey)
            ),
            "materials.print.fluorescence.texture",
            "given for a grey image",
        ),
        (
            format!(
                "fluorescence = {{ texture = {:?}, channel = \"alpha\" }}",
                s(&rgb)
            ),
            "materials.print.fluorescence.texture",
            "found \"alpha\"",
        ),
        (
            format!(
                "fluorescence = {{ texture = {:?}, channel = \"g\" }}",
                s(&bright)
            ),
            "materials.print.fluorescence.texture",
            "expected dye strength texels in [0, 1], found [1.5]",
        ),
        (
            format!("fluorescence = {{ texture = {:?}, scale = 10 }}", s(&grey)),
            "materials.print.fluorescence.texture",
            "found [1.1764706] at texel (1, 1)",
        ),
        (
            format!(
                "fluorescence = {{ texture = {:?} }}",
                s(&dir.join("missing.png"))
            ),
            "materials.print.fluorescence.texture",
            "cannot open",
        ),
        (
            "fluorescence = { checkerboard = [0, 2] }".into(),
            "materials.print.fluorescence.checkerboard[1]",
            "found 2",
        ),
        (
            "fluorescence = { checks = [2, 2] }".into(),
            "materials.print.fluorescence",
            "expected a number or",
        ),
        (
            format!(
                "fluorescence = {{ texture = {:?}, checks = [2, 2] }}",
                s(&grey)
            ),
            "materials.print.fluorescence.checks",
            "only allowed together with `checkerboard`",
        ),
        (
            "fluorescence = { texture = \"x.png\", colour = 1 }".into(),
            "(in `fluorescence = {",
            "unknown field `colour`",
        ),
    ];
    for (line, key, want) in cases {
        let text = quad_scene(&format!("reflectance = {d0}\n{line}"));
        let err = match Scene::from_str(&text, &root().join("scenes/inline.toml")) {
            Ok(_) => panic!("loaded: {line}"),
            Err(e) => e.to_string(),
        };
        assert!(err.contains(key) && err.contains(want), "{line}: {err}");
        if key.ends_with(".texture") {
            assert!(err.contains(&s(&dir)), "{line}: {err} (names no file)");
        }
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    // A map on a plain diffuse material (under a coat it works: tests/coated_texture.rs).
    let on_diffuse = quad_scene(&format!("reflectance = {d0}"))
        .replace("type = \"fluorescent_diffuse\"", "type = \"diffuse\"")
        .replace(DYE, "fluorescence = 0.5");
    let refuse = |text: &str| match Scene::from_str(text, &root().join("scenes/inline.toml")) {
        Ok(_) => panic!("loaded:\n{text}"),
        Err(e) => e,
    };
    let err = refuse(&on_diffuse);
    assert!(err.to_string().contains("fluorescence"), "{err}");
}

#[test]
fn stokes_info_lists_the_strength_map() {
    let dir = scratch("fluorescence-map-info");
    let grey = dir.join("mask.png");
    write_png_2x2(&grey, 1, &[0, 255, 128, 64]);
    let file = dir.join("print.toml");
    let text = quad_scene(&format!(
        "reflectance = {}\nfluorescence = {{ texture = {:?} }}",
        diagonal_desc(D0),
        s(&grey)
    ));
    std::fs::write(&file, text).unwrap();
    let (ok, out, err) = run(stokes().arg("info").arg(&file));
    assert!(ok, "{err}");
    let line = out
        .lines()
        .find(|l| l.starts_with("textures"))
        .unwrap_or("");
    assert!(
        line.contains("print dye strength") && line.contains("mask.png (2x2, 0.0 KiB)"),
        "{out}"
    );
}

#[test]
fn the_energy_check_runs_over_the_maps() {
    // D + s·σ_sa with σ_sa = Φ·A peaking at 0.9 × 0.85: over 1 where a bright diagonal
    // meets full strength, under it everywhere if either stays low.
    let warns = |keys: &str| {
        let scene = Scene::from_str(&quad_scene(keys), &root().join("scenes/inline.toml"))
            .unwrap_or_else(|e| panic!("{keys}: {e}"));
        scene
            .warnings
            .iter()
            .any(|w| w.contains("materials.print") && w.contains("creates energy"))
    };
    let strength = |values: [f32; 2]| format!("fluorescence = {{ checkerboard = {values:?} }}");
    let reflectance = |values: [f32; 2]| {
        format!(
            "reflectance = {{ checkerboard = [{}, {}] }}",
            values[0], values[1]
        )
    };
    // A strength map: the diagonal is 0.5 everywhere.
    assert!(warns(&format!(
        "reflectance = 0.5\n{}",
        strength([0.0, 1.0])
    )));
    assert!(!warns(&format!(
        "reflectance = 0.5\n{}",
        strength([0.0, 0.5])
    )));
    // A textured diagonal at full strength: only its bright square overflows.
    assert!(warns(&format!(
        "{}\n{}",
        reflectance([0.1, 0.5]),
        strength([1.0, 1.0])
    )));
    assert!(!warns(&format!(
        "{}\n{}",
        reflectance([0.1, 0.2]),
        strength([1.0, 1.0])
    )));
    // Both vary, but the bright diagonal and the full strength never meet (the same
    // checkerboard: bright where the dye is weak).
    assert!(!warns(&format!(
        "{}\n{}",
        reflectance([0.1, 0.9]),
        strength([1.0, 0.05])
    )));
    // An image map is checked at every texel, not on a coarser grid: a 256-texel strip at
    // strength 0 but for one texel at full strength, which a 64-point grid would see only
    // as a blend of it and its neighbour (0.5 + 0.5 × 0.77 < 1).
    let dir = scratch("fluorescence-map-energy");
    let strip = dir.join("strip.png");
    let mut texels = [0u8; 256];
    texels[1] = 255;
    write_png(&strip, [256, 1], 1, &texels);
    let map = format!(
        "fluorescence = {{ texture = {:?}, wrap = \"clamp\" }}",
        s(&strip)
    );
    assert!(warns(&format!("reflectance = 0.5\n{map}")));
    texels[1] = 100;
    write_png(&strip, [256, 1], 1, &texels);
    assert!(!warns(&format!("reflectance = 0.5\n{map}")));
    // The same for an image diagonal: black but for one grey texel (sRGB 231, linear
    // 0.80), at strength 0.5: 0.80 + 0.38 there is over 1, a blend with its black
    // neighbour (0.40 + 0.38) is not; at strength 0.2 nothing is (0.80 + 0.15).
    let rgb_strip = dir.join("strip-rgb.png");
    let mut texels = [0u8; 3 * 256];
    texels[3..6].fill(231);
    write_png(&rgb_strip, [256, 1], 3, &texels);
    let reflectance = format!(
        "reflectance = {{ texture = {:?}, wrap = \"clamp\" }}",
        s(&rgb_strip)
    );
    assert!(warns(&format!("{reflectance}\nfluorescence = 0.5")));
    assert!(!warns(&format!("{reflectance}\nfluorescence = 0.2")));
}
