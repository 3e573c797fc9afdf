//! Roughness maps: a GGX width that varies over a rough conductor or dielectric
//! (`roughness = { texture = … }`). Each square of a map renders as the same material with
//! that square's constant width does (Z-test per corner, in a scene where the widths give
//! clearly different images); map values are data (no sRGB decoding), no smaller than
//! 0.001; maps a coat cannot take are refused.

mod common;
use common::plate::{corners_match, film, film_at, plate, write_grey16_png_2x2, write_png_2x2};
use common::*;
use stokes::scene::Scene;

/// The map's corners against constant widths `alphas` (TL, TR, BL, BR) of `kind` (the
/// material body without its roughness), at 1024 spp: at 256 the rough dielectric's two
/// widths came out only 5.0 standard errors apart in one corner (13.2 at 1024), below
/// the 6 that `corners_match` asks of them.
fn corners_match_constant_widths(kind: &str, map: &str, alphas: [f32; 4]) {
    let film = |text: &str| film_at(text, 1024);
    let mapped = film(&plate(&format!("{kind}\nroughness = {map}")));
    let constant = alphas.map(|a| film(&plate(&format!("{kind}\nroughness = {a}"))));
    corners_match(&format!("{kind} {map}"), &mapped, &constant, alphas);
}

#[test]
fn a_conductor_roughness_map_renders_each_texel_as_its_constant_width() {
    let dir = scratch("roughness-map");
    let file = dir.join("rough.png");
    let values = [13u8, 128, 255, 51];
    write_png_2x2(&file, 1, &values);
    let map = format!("{{ texture = {:?}, wrap = \"clamp\" }}", s(&file));
    corners_match_constant_widths(
        "type = \"conductor\"\nmetal = \"Au\"",
        &map,
        values.map(|v| f32::from(v) / 255.0),
    );
}

#[test]
fn a_sixteen_bit_map_is_read_as_data() {
    let dir = scratch("roughness-map-16");
    let file = dir.join("rough16.png");
    let values = [3000u16, 30000, 65535, 12000];
    write_grey16_png_2x2(&file, values);
    let map = format!("{{ texture = {:?}, wrap = \"clamp\" }}", s(&file));
    corners_match_constant_widths(
        "type = \"conductor\"\nmetal = \"Au\"",
        &map,
        values.map(|v| f32::from(v) / 65535.0),
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
    let file = dir.join("zero.png");
    write_png_2x2(&file, 1, &[0; 4]);
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
    let png = dir.join("scratches.png");
    write_png_2x2(&png, 1, &[0, 64, 128, 255]);
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
