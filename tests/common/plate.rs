//! A 2 × 2 quad filling a 32 × 32 view, for textures whose four quadrants hold four
//! values: each corner of the textured render must match the render of the material with
//! that corner's value as a constant (a Z-test per corner), and the constants must look
//! different enough there for the test to be able to fail.

use super::{assert_agree, region_mean, scene_from, TestRender};
use stokes::integrator::render::Film;

/// The scene: `material` is the quad's material body (`[materials.plate]`), lit by a
/// point light beside the camera and a dim sky.
pub fn plate(material: &str) -> String {
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
pub fn corner(x0: usize, y0: usize) -> Vec<usize> {
    (y0..y0 + 8)
        .flat_map(|y| (x0..x0 + 8).map(move |x| y * 32 + x))
        .collect()
}

/// Top-left, top-right, bottom-left, bottom-right; u runs right, v up.
pub const CORNERS: [(usize, usize); 4] = [(0, 0), (24, 0), (0, 24), (24, 24)];

/// The scene `text` at 256 spp, seed 17, with the default method.
pub fn film(text: &str) -> Film {
    film_at(text, 256)
}

/// [`film`] at `spp` samples per pixel.
pub fn film_at(text: &str, spp: u32) -> Film {
    TestRender::at(32, 32)
        .spp(spp)
        .seed(17)
        .film(&mut scene_from(text))
}

/// Each corner of `mapped` against `constant[k]` (TL, TR, BL, BR; `values` names them),
/// and against the constant of another value, which must differ there by more than 6
/// standard errors in some channel.
pub fn corners_match(what: &str, mapped: &Film, constant: &[Film; 4], values: [f32; 4]) {
    for (k, (x0, y0)) in CORNERS.into_iter().enumerate() {
        let px = corner(x0, y0);
        assert_agree(
            &format!("{what}: corner {k} ({})", values[k]),
            region_mean(mapped, &px),
            region_mean(&constant[k], &px),
            4.5,
        );
        let j = (0..4).find(|&j| values[j] != values[k]).unwrap();
        let (a, se_a) = region_mean(&constant[k], &px);
        let (b, se_b) = region_mean(&constant[j], &px);
        let z = (0..3)
            .map(|c| (a[c] - b[c]) / (se_a[c].hypot(se_b[c])).max(1e-12))
            .fold(0.0f64, |m, z| if z.abs() > m.abs() { z } else { m });
        assert!(
            z.abs() > 6.0,
            "{what}, corner {k}: {} and {} look alike (z {z:.1})",
            values[k],
            values[j]
        );
    }
}

/// Writes a 2 × 2 8-bit PNG of 1 (grey) or 3 (RGB) channels, row 0 at the top.
pub fn write_png_2x2(path: &std::path::Path, channels: usize, texels: &[u8]) {
    write_png(path, [2, 2], channels, texels);
}

/// An 8-bit PNG of `size` = [width, height] texels, grey (1 channel) or RGB (3), row 0 at
/// the top.
pub fn write_png(path: &std::path::Path, size: [u32; 2], channels: usize, texels: &[u8]) {
    assert_eq!(texels.len(), (size[0] * size[1]) as usize * channels);
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), size[0], size[1]);
    enc.set_color(match channels {
        1 => png::ColorType::Grayscale,
        _ => png::ColorType::Rgb,
    });
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()
        .unwrap()
        .write_image_data(texels)
        .unwrap();
}

/// [`write_png_2x2`] with 16-bit grey texels.
pub fn write_grey16_png_2x2(path: &std::path::Path, texels: [u16; 4]) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), 2, 2);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Sixteen);
    let bytes: Vec<u8> = texels.iter().flat_map(|t| t.to_be_bytes()).collect();
    enc.write_header()
        .unwrap()
        .write_image_data(&bytes)
        .unwrap();
}
