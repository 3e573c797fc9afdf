//! Roughness maps: a GGX width that varies over a rough conductor or dielectric
//! (`roughness = { texture = … }`). Each square of a map renders as the same material with
//! that square's constant width does (Z-test per corner, in a scene where the widths give
//! clearly different images); map values are data (no sRGB decoding), no smaller than
//! 0.001; maps a coat cannot take are refused.

mod common;
use common::*;
use std::path::Path;
use stokes::scene::Scene;

/// A 2 × 2 quad filling a 32 × 32 view, lit by a point light beside the camera and a dim
/// sky; `material` is the quad's material body.
fn plate(material: &str) -> String {
    format!(
        r#"
[camera]
position = [0, 0, 1]
look_at = [0, 0, 0]
fov = 90
resolution = [32, 32]

[materials.plate]
{material}

[[shapes]]
type = "quad"
origin = [-1, -1, 0]
edge_u = [2, 0, 0]
edge_v = [0, 2, 0]
material = "plate"

[[lights]]
type = "point"
position = [0.4, 0.3, 1.2]
intensity = {{ illuminant = "D65", scale = 0.02 }}

[[lights]]
type = "environment"
radiance = {{ illuminant = "D65", scale = 0.001 }}
"#
    )
}

/// The outer 8 × 8 pixels of the quadrant whose top-left pixel is (x0, y0).
fn corner(x0: usize, y0: usize) -> Vec<usize> {
    (y0..y0 + 8)
        .flat_map(|y| (x0..x0 + 8).map(move |x| y * 32 + x))
        .collect()
}

/// Top-left, top-right, bottom-left, bottom-right; u runs right, v up.
const CORNERS: [(usize, usize); 4] = [(0, 0), (24, 0), (0, 24), (24, 24)];

fn film(text: &str) -> stokes::integrator::render::Film {
    TestRender::at(32, 32)
        .spp(256)
        .seed(17)
        .film(&mut scene_from(text))
}

/// The map's corners against constant widths `alphas` (TL, TR, BL, BR) of `kind` (the
/// material body without its roughness).
fn corners_match_constant_widths(kind: &str, map: &str, alphas: [f32; 4]) {
    let mapped = film(&plate(&format!("{kind}\nroughness = {map}")));
    let constant = alphas.map(|a| film(&plate(&format!("{kind}\nroughness = {a}"))));
    for (k, (x0, y0)) in CORNERS.into_iter().enumerate() {
        let px = corner(x0, y0);
        assert_agree(
            &format!("{kind} {map}: corner {k} (α {})", alphas[k]),
            region_mean(&mapped, &px),
            region_mean(&constant[k], &px),
            4.5,
        );
        // The test can tell the widths apart there: another width looks different.
        let j = (0..4).find(|&j| alphas[j] != alphas[k]).unwrap();
        let (a, se_a) = region_mean(&constant[k], &px);
        let (b, se_b) = region_mean(&constant[j], &px);
        let z = (a[1] - b[1]) / (se_a[1].hypot(se_b[1])).max(1e-12);
        assert!(
            z.abs() > 6.0,
            "corner {k}: α {} and {} look alike (z {z:.1})",
            alphas[k],
            alphas[j]
        );
    }
}

/// Writes a 2 × 2 8-bit grey PNG, row 0 at the top.
fn write_grey_png(path: &Path, values: [u8; 4]) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), 2, 2);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()
        .unwrap()
        .write_image_data(&values)
        .unwrap();
}

#[test]
fn a_conductor_roughness_map_renders_each_texel_as_its_constant_width() {
    let dir = scratch("roughness-map");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("rough.png");
    let values = [13u8, 128, 255, 51];
    write_grey_png(&file, values);
    let map = format!("{{ texture = {:?}, wrap = \"clamp\" }}", s(&file));
    corners_match_constant_widths(
        "type = \"conductor\"\nmetal = \"Au\"",
        &map,
        values.map(|v| f32::from(v) / 255.0),
    );
}

#[test]
fn a_rough_dielectric_takes_a_checkerboard_of_widths() {
    // 2 × 2 squares: top left and bottom right take the second width.
    corners_match_constant_widths(
        "type = \"dielectric\"\nior = 1.5",
        "{ checkerboard = [0.05, 0.4], checks = [2, 2] }",
        [0.4, 0.05, 0.05, 0.4],
    );
}

#[test]
fn a_zero_texel_is_the_narrowest_rough_lobe() {
    let dir = scratch("roughness-map-zero");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("zero.png");
    write_grey_png(&file, [0; 4]);
    let body = "type = \"conductor\"\nmetal = \"Au\"";
    let mapped = film(&plate(&format!(
        "{body}\nroughness = {{ texture = {:?} }}",
        s(&file)
    )));
    let narrowest = film(&plate(&format!("{body}\nroughness = 0.001")));
    let all = all_pixels(&mapped);
    assert_agree(
        "zero map",
        region_mean(&mapped, &all),
        region_mean(&narrowest, &all),
        4.5,
    );
}

#[test]
fn roughness_maps_a_material_cannot_take_are_refused() {
    let refuse =
        |body: &str| match Scene::from_str(&plate(body), &root().join("scenes/inline.toml")) {
            Ok(_) => panic!("loaded:\n{body}"),
            Err(e) => e.to_string(),
        };
    let map = "{ checkerboard = [0.1, 0.3] }";
    let cases = [
        (
            format!("type = \"coated\"\nroughness = {map}\nbase = {{ type = \"diffuse\", reflectance = 0.5 }}"),
            "materials.plate.roughness",
            "a roughness map on a coat",
        ),
        (
            format!("type = \"coated\"\nbase = {{ type = \"conductor\", metal = \"Au\", roughness = {map} }}"),
            "materials.plate.base.roughness",
            "under a coat",
        ),
        (
            "type = \"conductor\"\nmetal = \"Au\"\nroughness = { checkerboard = [0.1, 1.5] }".into(),
            "materials.plate.roughness.checkerboard[1]",
            "GGX width in [0, 1]",
        ),
        (
            "type = \"conductor\"\nmetal = \"Au\"\nroughness = { rough = 1 }".into(),
            "unknown field `rough`",
            "(in `roughness = {",
        ),
        (
            format!("type = \"diffuse\"\nreflectance = 0.5\nroughness = {map}"),
            "materials.plate",
            "roughness",
        ),
    ];
    for (body, key, want) in cases {
        let err = refuse(&body);
        assert!(err.contains(key) && err.contains(want), "{body}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
}

#[test]
fn stokes_info_lists_roughness_maps() {
    let dir = scratch("roughness-map-info");
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("scratches.png");
    write_grey_png(&png, [0, 64, 128, 255]);
    for (body, want) in [
        (
            format!(
                "type = \"conductor\"\nmetal = \"Al\"\nroughness = {{ texture = {:?} }}",
                s(&png)
            ),
            "plate roughness: ".to_string() + &s(&png) + " (2x2, 0.0 KiB)",
        ),
        (
            "type = \"dielectric\"\nior = 1.5\nroughness = { checkerboard = [0.1, 0.4] }".into(),
            "plate roughness: a checkerboard".into(),
        ),
        (
            "type = \"conductor\"\nmetal = \"Al\"\nroughness = 0.2".into(),
            "textures    none".into(),
        ),
    ] {
        let file = dir.join("plate.toml");
        std::fs::write(&file, plate(&body)).unwrap();
        let (ok, out, err) = run(stokes().arg("info").arg(&file));
        assert!(ok, "{err}");
        let line = out
            .lines()
            .find(|l| l.starts_with("textures"))
            .unwrap_or("");
        assert!(line.contains(&want), "{body}: {out}");
    }
}
