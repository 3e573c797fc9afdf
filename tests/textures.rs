//! Textures: bilinear filtering against a hand computation, a 2×2 PNG on the right
//! quadrants of a rendered quad, a checkerboard averaging to the mean of its spectra under
//! a uniform sky, `stokes info`, and bad textures.

mod common;
use common::*;
use glam::Vec2;
use std::path::Path;
use stokes::color::{srgb_decode, xyz_to_linear_srgb};
use stokes::spectrum::upsample::{d65_unit_luminance, RgbSpectrum};
use stokes::spectrum::{reflectance_to_xyz, Spectrum};
use stokes::texture::{ImageTexture, Wrap};

/// Writes an 8-bit RGB PNG of `w` × `h` pixels, row 0 at the top.
fn write_png(path: &Path, w: u32, h: u32, rgb: &[[u8; 3]]) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().unwrap();
    writer.write_image_data(&rgb.concat()).unwrap();
}

#[test]
fn bilinear_filtering_matches_a_hand_computation() {
    // Texels a b / c d (row 0 at the top); v runs up, so uv (0.25, 0.75) is a's centre.
    let (a, b, c, d) = (
        [0.1, 0.2, 0.3],
        [0.5, 0.6, 0.7],
        [0.9, 0.0, 0.4],
        [0.3, 0.3, 0.3],
    );
    let tex = |wrap| ImageTexture::new(2, 2, vec![a, b, c, d], wrap, "t".into()).unwrap();
    let repeat = tex(Wrap::Repeat);
    let near = |x: [f32; 3], y: [f32; 3]| x.iter().zip(&y).all(|(p, q)| (p - q).abs() < 1e-6);
    assert!(near(repeat.rgb(Vec2::new(0.25, 0.75)), a));
    assert!(near(repeat.rgb(Vec2::new(0.75, 0.25)), d));
    // Halfway between all four centres: their mean.
    let mean: [f32; 3] = std::array::from_fn(|k| (a[k] + b[k] + c[k] + d[k]) / 4.0);
    assert!(near(repeat.rgb(Vec2::new(0.5, 0.5)), mean));
    // A quarter of the way from a's centre to b's: x = 0.375·2 − 0.5 = 0.25.
    let ab: [f32; 3] = std::array::from_fn(|k| a[k] + 0.25 * (b[k] - a[k]));
    assert!(near(repeat.rgb(Vec2::new(0.375, 0.75)), ab));
    // At u = 0 the left neighbour is b again under repeat, a under clamp, a under mirror.
    let half_ab: [f32; 3] = std::array::from_fn(|k| 0.5 * (a[k] + b[k]));
    assert!(near(repeat.rgb(Vec2::new(0.0, 0.75)), half_ab));
    assert!(near(tex(Wrap::Clamp).rgb(Vec2::new(0.0, 0.75)), a));
    assert!(near(tex(Wrap::Mirror).rgb(Vec2::new(0.0, 0.75)), a));
    assert!(near(tex(Wrap::Clamp).rgb(Vec2::new(-3.0, 0.75)), a));
    assert!(near(repeat.rgb(Vec2::new(1.25, 1.75)), a));
}

/// A unit quad filling a 32² image exactly (90° field of view at distance 1), reflectance
/// `reflectance`, under a uniform sky of D65 with luminance 1: a plane reflects ρ·L.
fn quad_under_sky(reflectance: &str) -> String {
    format!(
        r#"
[camera]
position = [0, 0, 1]
look_at = [0, 0, 0]
fov = 90
resolution = [32, 32]

[materials.paper]
type = "diffuse"
reflectance = {reflectance}

[[shapes]]
type = "quad"
origin = [-1, -1, 0]
edge_u = [2, 0, 0]
edge_v = [0, 2, 0]
material = "paper"

[[lights]]
type = "environment"
radiance = {{ rgb = [1, 1, 1] }}
"#
    )
}

/// Linear sRGB of the albedo `rgb` (upsampled) under the sky of [`quad_under_sky`].
fn seen(rgb: [f32; 3]) -> [f64; 3] {
    let r = Spectrum::Rgb(RgbSpectrum::albedo(rgb));
    let sky = Spectrum::Tabulated(d65_unit_luminance().clone());
    xyz_to_linear_srgb(reflectance_to_xyz(&r, &sky))
        .to_array()
        .map(f64::from)
}

#[test]
fn each_quadrant_of_a_texture_lands_on_its_quadrant() {
    let dir = scratch("texture-quadrants");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("quadrants.png");
    let bytes = [[200, 30, 30], [30, 200, 30], [30, 30, 200], [220, 220, 220]];
    // Each quadrant 2 × 2 texels of a 4 × 4 image (a square of side 2 would not tell
    // width × height texels from width + height).
    let texels: Vec<[u8; 3]> = (0..16).map(|t| bytes[(t / 8) * 2 + (t % 4) / 2]).collect();
    write_png(&file, 4, 4, &texels);
    let text = quad_under_sky(&format!("{{ texture = {:?}, wrap = \"clamp\" }}", s(&file)));
    let mut scene = scene_from(&text);
    let film = TestRender::at(32, 32).spp(64).seed(9).film(&mut scene);
    // The outer 8 × 8 corner of each quadrant sees its texel alone (clamped).
    let corner = |x0: usize, y0: usize| -> Vec<usize> {
        (y0..y0 + 8)
            .flat_map(|y| (x0..x0 + 8).map(move |x| y * 32 + x))
            .collect()
    };
    for (k, (x0, y0)) in [(0, 0), (24, 0), (0, 24), (24, 24)].into_iter().enumerate() {
        let want = seen(bytes[k].map(|b| srgb_decode(f32::from(b) / 255.0)));
        let (m, se) = region_mean(&film, &corner(x0, y0));
        for c in 0..3 {
            let z = (m[c] - want[c]) / se[c].max(1e-9);
            assert!(
                z.abs() < 4.5 || (m[c] - want[c]).abs() < 1e-4,
                "quadrant {k} channel {c}: {} vs {} (z {z:.2})",
                m[c],
                want[c]
            );
        }
    }
}

#[test]
fn a_checkerboard_averages_to_the_mean_of_its_spectra() {
    // 4 × 4 checks over 32 × 32 pixels: 8 × 8 pixels each, half of them of each spectrum.
    let text = quad_under_sky("{ checkerboard = [0.2, { wavelengths = [360, 830], values = [0.9, 0.5] }], checks = [4, 4] }");
    let mut scene = scene_from(&text);
    let film = TestRender::at(32, 32).spp(64).seed(10).film(&mut scene);
    let (m, se) = region_mean(&film, &all_pixels(&film));
    let a = Spectrum::Constant(0.2);
    let b = Spectrum::Tabulated(
        stokes::spectrum::Tabulated::new(vec![360.0, 830.0], vec![0.9, 0.5]).unwrap(),
    );
    let sky = Spectrum::Tabulated(d65_unit_luminance().clone());
    let xyz = (reflectance_to_xyz(&a, &sky) + reflectance_to_xyz(&b, &sky)) * 0.5;
    let want = xyz_to_linear_srgb(xyz);
    for c in 0..3 {
        let z = (m[c] - f64::from(want[c])) / se[c];
        assert!(
            z.abs() < 4.5,
            "channel {c}: {} vs {} (z {z:.2})",
            m[c],
            want[c]
        );
    }
    // And the checks alternate: pixel (1, 1) (u, v near 0, 1) and pixel (9, 1) differ.
    let mean = film.mean();
    assert!(
        (mean[33][1] - mean[41][1]).abs() > 0.1,
        "{:?} {:?}",
        mean[33],
        mean[41]
    );
}

#[test]
fn bad_textures_are_rejected_naming_the_file_and_key() {
    let dir = scratch("texture-bad");
    std::fs::create_dir_all(&dir).unwrap();
    let gray = dir.join("gray.png");
    {
        let file = std::fs::File::create(&gray).unwrap();
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), 2, 2);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header()
            .unwrap()
            .write_image_data(&[0, 50, 100, 150])
            .unwrap();
    }
    let nan = dir.join("nan.exr");
    exr::prelude::write_rgb_file(&nan, 2, 2, |x, y| {
        if (x, y) == (1, 0) {
            (f32::NAN, 0.5, 0.5)
        } else {
            (0.5f32, 0.5f32, 0.5f32)
        }
    })
    .unwrap();
    let bright = dir.join("bright.exr");
    exr::prelude::write_rgb_file(&bright, 2, 2, |_, _| (1.5f32, 0.5f32, 0.5f32)).unwrap();
    let text_file = dir.join("text.png");
    std::fs::write(&text_file, "not a png").unwrap();
    let tga = dir.join("image.tga");
    std::fs::write(&tga, "x").unwrap();
    let cases = [
        (dir.join("missing.png"), "cannot open"),
        (text_file, "not a readable PNG"),
        (gray, "expected an RGB or RGBA image, found grey"),
        (
            nan,
            "expected albedo texels in [0, 1], found [NaN, 0.5, 0.5] at texel (1, 0)",
        ),
        (
            bright,
            "expected albedo texels in [0, 1], found [1.5, 0.5, 0.5] at texel (0, 0)",
        ),
        (tga, "expected a .png or .exr image"),
    ];
    let load =
        |text: &str| match stokes::scene::Scene::from_str(text, &root().join("scenes/inline.toml"))
        {
            Ok(_) => panic!("loaded:\n{text}"),
            Err(e) => e.to_string(),
        };
    for (file, want) in cases {
        let err = load(&quad_under_sky(&format!("{{ texture = {:?} }}", s(&file))));
        assert!(err.contains("materials.paper.reflectance.texture"), "{err}");
        assert!(
            err.contains(&s(&file)) && err.contains(want),
            "{}: {err}",
            file.display()
        );
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    let more = [
        (
            "{ texture = \"a.png\", wrap = \"tile\" }",
            "materials.paper.reflectance.wrap: expected one of repeat, clamp, mirror",
        ),
        (
            "{ checkerboard = [0.2] }",
            "materials.paper.reflectance.checkerboard: expected two spectra",
        ),
        (
            "{ checkerboard = [0.2, 1.5] }",
            "materials.paper.reflectance.checkerboard[1]",
        ),
        (
            "{ checkerboard = [0.2, 0.4], checks = [0, 4] }",
            "materials.paper.reflectance.checks: expected two positive numbers",
        ),
        (
            "{ constant = 0.5, wrap = \"clamp\" }",
            "materials.paper.reflectance.wrap: only allowed together with `texture`",
        ),
    ];
    for (desc, want) in more {
        let err = load(&quad_under_sky(desc));
        assert!(err.contains(want), "{desc}: {err}");
    }
    // Textures only where a material takes them; and a shape needs texture coordinates.
    let metal = quad_under_sky("0.5").replace(
        "type = \"diffuse\"\nreflectance = 0.5",
        "type = \"conductor\"\neta = { checkerboard = [0.2, 0.4] }\nk = 1",
    );
    let err = load(&metal);
    assert!(
        err.contains("materials.paper.eta")
            && err.contains("only a diffuse, fluorescent diffuse or mirror material's `reflectance` takes a texture"),
        "{err}"
    );
    let boxed = quad_under_sky("{ checkerboard = [0.2, 0.4] }").replace(
        "type = \"quad\"\norigin = [-1, -1, 0]\nedge_u = [2, 0, 0]\nedge_v = [0, 2, 0]",
        "type = \"box\"\nmin = [-1, -1, -1]\nmax = [1, 1, 0]",
    );
    let err = load(&boxed);
    assert!(
        err.contains(
            "shapes[0].material: a textured material on a box shape without texture coordinates"
        ),
        "{err}"
    );
}

#[test]
fn a_mirror_takes_a_reflectance_texture() {
    // A mirror plate facing the camera reflects a constant sky: each quadrant of a 2 × 2
    // checkerboard shows the sky times that square's reflectance, noise-free, as the
    // mirror of the constant reflectance does.
    use common::plate::{corner, plate, CORNERS};
    let values = [0.9f32, 0.2, 0.2, 0.9];
    let body = |r: &str| format!("type = \"mirror\"\nreflectance = {r}");
    let film = |text: &str| {
        TestRender::at(32, 32)
            .spp(4)
            .seed(5)
            .film(&mut scene_from(text))
    };
    let mapped = film(&plate(&body(
        "{ checkerboard = [0.2, 0.9], checks = [2, 2] }",
    )));
    for (k, (x0, y0)) in CORNERS.into_iter().enumerate() {
        let px = corner(x0, y0);
        let constant = film(&plate(&body(&values[k].to_string())));
        let (got, want) = (region_mean(&mapped, &px).0, region_mean(&constant, &px).0);
        for c in 0..3 {
            assert!(
                (got[c] - want[c]).abs() <= 1e-5 * want[c].abs() && want[c] > 0.0,
                "corner {k} (reflectance {}): {got:?} vs {want:?}",
                values[k]
            );
        }
    }
    let info = scene_from(&plate(&body("{ checkerboard = [0.2, 0.9] }")));
    assert!(info.features.textured);
}
