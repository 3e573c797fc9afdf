//! Textured bases under a coat: a diffuse base's reflectance texture, and a fluorescent
//! base's dye strength map. Each quadrant of a 2 × 2 texture renders as the same coated
//! material over a base with that quadrant's constant value does (Z-test per corner, in
//! renders where the values give clearly different images), under a smooth clear coat and
//! under a rough absorbing one, in HWSS and mono.

mod common;
use common::plate::{corners_match, plate, write_png_2x2};
use common::*;
use stokes::integrator::render::Film;
use stokes::method::{Method, Spectral};

const DYE: &str = "dye = { absorption = { wavelengths = [380, 420, 470, 500], values = [0.2, 0.6, 0.4, 0] }, emission = { narrow_band = 530, fwhm = 40 }, quantum_yield = 0.9 }";

/// The coats: smooth and clear; rough (α 0.2) and absorbing.
const COATS: [&str; 2] = [
    "type = \"coated\"\nior = 1.5",
    "type = \"coated\"\nior = 1.5\nroughness = 0.2\nabsorption = 2\nthickness = 0.1",
];

fn film(text: &str, spectral: Spectral) -> Film {
    TestRender::at(32, 32)
        .spp(256)
        .seed(23)
        .method(Method {
            spectral,
            ..Method::default()
        })
        .film(&mut scene_from(text))
}

/// The coated material `coat` over the base `base` (an inline table's body).
fn coated(coat: &str, base: &str) -> String {
    plate(&format!("{coat}\nbase = {{ {base} }}"))
}

#[test]
fn a_diffuse_base_takes_a_reflectance_checkerboard_under_a_coat() {
    // 2 × 2 squares: top left and bottom right take the second value.
    let values = [0.9f32, 0.15, 0.15, 0.9];
    for coat in COATS {
        let base = |r: &str| format!("type = \"diffuse\", reflectance = {r}");
        let mapped = film(
            &coated(
                coat,
                &base("{ checkerboard = [0.15, 0.9], checks = [2, 2] }"),
            ),
            Spectral::Hwss,
        );
        let constant = values.map(|v| film(&coated(coat, &base(&v.to_string())), Spectral::Hwss));
        corners_match(coat, &mapped, &constant, values);
    }
}

#[test]
fn a_diffuse_base_takes_an_rgb_image_under_a_coat() {
    // An 8-bit sRGB texture: each texel is the constant `{ rgb = … }` of its decoded value.
    let dir = scratch("coated-texture-rgb");
    let png = dir.join("base.png");
    let texels: [[u8; 3]; 4] = [[230, 40, 40], [40, 200, 60], [50, 60, 220], [240, 240, 240]];
    write_png_2x2(&png, 3, texels.as_flattened());
    let decode = |v: u8| {
        let c = f64::from(v) / 255.0;
        let l = match c <= 0.04045 {
            true => c / 12.92,
            false => ((c + 0.055) / 1.055).powf(2.4),
        };
        format!("{l:.6}")
    };
    let rgb = |t: [u8; 3]| format!("{{ rgb = [{}] }}", t.map(decode).join(", "));
    let base = |r: &str| format!("type = \"diffuse\", reflectance = {r}");
    let coat = COATS[1];
    let mapped = film(
        &coated(
            coat,
            &base(&format!("{{ texture = {:?}, wrap = \"clamp\" }}", s(&png))),
        ),
        Spectral::Hwss,
    );
    let constant = texels.map(|t| film(&coated(coat, &base(&rgb(t))), Spectral::Hwss));
    // Texel rows run down the image, v up it: the image's top row is the render's top.
    corners_match(
        "rgb image under a rough coat",
        &mapped,
        &constant,
        [0.0, 1.0, 2.0, 3.0],
    );
}

#[test]
fn a_fluorescent_base_takes_a_strength_map_under_a_coat() {
    // Where the map is 0 the base is the plain diffuse reflectance, where 1 the full dye:
    // the references carry no map at all (a number for `fluorescence` is a constant map,
    // which would share the mapped path's arithmetic).
    let values = [1.0f32, 0.0, 0.0, 1.0];
    let dyed = format!("type = \"fluorescent_diffuse\", reflectance = 0.3, {DYE}");
    let plain = "type = \"diffuse\", reflectance = 0.3".to_string();
    for spectral in [Spectral::Hwss, Spectral::Mono] {
        for coat in COATS {
            let mapped = film(
                &coated(
                    coat,
                    &format!("{dyed}, fluorescence = {{ checkerboard = [0, 1], checks = [2, 2] }}"),
                ),
                spectral,
            );
            let constant = values.map(|v| {
                let base = if v == 1.0 { &dyed } else { &plain };
                film(&coated(coat, base), spectral)
            });
            corners_match(
                &format!("{coat} ({spectral:?})"),
                &mapped,
                &constant,
                values,
            );
        }
    }
}

#[test]
fn stokes_info_lists_a_coated_base_texture() {
    let dir = scratch("coated-texture-info");
    let png = dir.join("base.png");
    write_png_2x2(&png, 1, &[0, 64, 128, 255]);
    let file = dir.join("plate.toml");
    let base = format!(
        "type = \"fluorescent_diffuse\", reflectance = 0.3, fluorescence = {{ texture = {:?} }}, {DYE}",
        s(&png)
    );
    std::fs::write(&file, coated(COATS[0], &base)).unwrap();
    let (ok, out, err) = run(stokes().arg("info").arg(&file));
    assert!(ok, "{err}");
    let line = out
        .lines()
        .find(|l| l.starts_with("textures"))
        .unwrap_or("");
    assert!(
        line.contains("plate dye strength: ") && line.contains("base.png (2x2"),
        "{out}"
    );
}
