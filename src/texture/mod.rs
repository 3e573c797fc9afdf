//! Textures: a reflectance that varies over a surface with its texture coordinates (u, v).
//!
//! - An **image** (PNG, 8 or 16 bits per channel, sRGB-decoded; or OpenEXR, linear) holds
//!   linear sRGB albedo. A lookup filters the four nearest texels bilinearly in RGB and
//!   upsamples the result to a reflectance spectrum ([`RgbSpectrum::albedo`]). Texel
//!   (0, 0) is the image's top-left corner and v runs up: (u, v) = (0, 0) is the
//!   bottom-left of the image, as in OBJ files. Outside [0, 1) the coordinates wrap:
//!   `repeat` (default), `clamp` to the edge, or `mirror`.
//! - A **checkerboard** of two spectra, `checks` squares per unit of u and v.
//!
//! ```toml
//! reflectance = { texture = "paper.png", wrap = "repeat" }
//! reflectance = { checkerboard = [0.2, "white"], checks = [8, 8] }
//! ```

pub mod scalar;

use crate::error::{Detail, Key, KeyError};
use crate::simd::{Float, Spec};
use crate::spectrum::upsample::RgbSpectrum;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec4};
use std::path::Path;
use std::sync::Arc;

/// What happens to texture coordinates outside [0, 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles the plane.
    Repeat,
    /// The edge texels continue outwards.
    Clamp,
    /// The image tiles the plane, every other copy mirrored.
    Mirror,
}

impl Wrap {
    /// The names a scene file uses.
    pub const NAMES: [&'static str; 3] = ["repeat", "clamp", "mirror"];

    /// The mode named `name`.
    pub fn named(name: &str) -> Option<Wrap> {
        match name {
            "repeat" => Some(Wrap::Repeat),
            "clamp" => Some(Wrap::Clamp),
            "mirror" => Some(Wrap::Mirror),
            _ => None,
        }
    }

    /// The mode `name` given at `key` (default `repeat`).
    pub fn from_desc(name: Option<&str>, key: &Key) -> Result<Wrap, KeyError> {
        let name = name.unwrap_or("repeat");
        Wrap::named(name).ok_or_else(|| {
            key.expected(
                format!("one of {}", Wrap::NAMES.join(", ")),
                format!("{name:?}"),
            )
        })
    }

    /// Texel index `i` (any integer) of a row or column of `n` texels.
    fn index(self, i: i64, n: usize) -> usize {
        let n = n as i64;
        let k = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Mirror => {
                let k = i.rem_euclid(2 * n);
                if k < n {
                    k
                } else {
                    2 * n - 1 - k
                }
            }
        };
        k as usize
    }
}

/// An image of `N` linear channels per texel: RGB albedo ([`ImageTexture`]) or one
/// channel of data ([`scalar::ScalarImage`]), filtered bilinearly.
#[derive(Debug, Clone)]
pub struct Image<const N: usize> {
    /// Texels across.
    pub width: usize,
    /// Texels down.
    pub height: usize,
    /// Row by row from the top.
    texels: Vec<[f32; N]>,
    /// Coordinates outside [0, 1).
    pub wrap: Wrap,
    /// The file it came from (for `stokes info`).
    pub file: String,
}

/// An RGB image of linear sRGB albedo.
pub type ImageTexture = Image<3>;

impl<const N: usize> Image<N> {
    /// The image of `width` × `height` `texels` (row 0 at the top); an error for a texel
    /// that is not finite or outside `range` (`what` names the values in the message).
    pub fn with_range(
        width: usize,
        height: usize,
        texels: Vec<[f32; N]>,
        wrap: Wrap,
        file: String,
        range: std::ops::RangeInclusive<f32>,
        what: &str,
    ) -> Result<Image<N>, String> {
        assert_eq!(texels.len(), width * height);
        if width == 0 || height == 0 {
            return Err("expected an image with texels, found an empty one".into());
        }
        if let Some(k) = texels
            .iter()
            .position(|t| !t.iter().all(|v| range.contains(v)))
        {
            return Err(format!(
                "expected {what} texels in [{}, {}], found {:?} at texel ({}, {})",
                range.start(),
                range.end(),
                texels[k],
                k % width,
                k / width
            ));
        }
        Ok(Image {
            width,
            height,
            texels,
            wrap,
            file,
        })
    }

    /// Bytes the texels take.
    pub fn memory(&self) -> usize {
        self.texels.len() * std::mem::size_of::<[f32; N]>()
    }

    /// The texel at column `x`, row `y` (wrapped).
    fn texel(&self, x: i64, y: i64) -> [f32; N] {
        let (i, j) = (
            self.wrap.index(x, self.width),
            self.wrap.index(y, self.height),
        );
        self.texels[j * self.width + i]
    }

    /// The bilinearly filtered texel at texture coordinates `uv`: texel centres sit at
    /// ((i + ½)/w, 1 − (j + ½)/h).
    pub fn sample(&self, uv: Vec2) -> [f32; N] {
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i, j) = (x0 as i64, y0 as i64);
        let (a, b) = (self.texel(i, j), self.texel(i + 1, j));
        let (c, d) = (self.texel(i, j + 1), self.texel(i + 1, j + 1));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }
}

impl Image<3> {
    /// The image of `width` × `height` linear sRGB `texels` (row 0 at the top); an error for
    /// a texel that is not finite or outside [0, 1] (an albedo).
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<[f32; 3]>,
        wrap: Wrap,
        file: String,
    ) -> Result<ImageTexture, String> {
        Image::with_range(width, height, texels, wrap, file, 0.0..=1.0, "albedo")
    }

    /// Reads a PNG (sRGB-decoded) or an OpenEXR (linear) image, by its extension.
    pub fn load(path: &Path, wrap: Wrap) -> Result<ImageTexture, Detail> {
        let what = path.display().to_string();
        let texels = read_rgb(path)
            .and_then(|(w, h, texels)| ImageTexture::new(w, h, texels, wrap, what.clone()));
        texels.map_err(|e| Detail::Text(format!("{what}: {e}")))
    }

    /// The bilinearly filtered linear sRGB at texture coordinates `uv`.
    pub fn rgb(&self, uv: Vec2) -> [f32; 3] {
        self.sample(uv)
    }
}

/// The extension of `path`, lower-case.
fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// The linear RGB texels of a PNG (sRGB-decoded, RGB or RGBA) or an OpenEXR image.
fn read_rgb(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>), String> {
    match extension(path).as_deref() {
        Some("png") => {
            let png = read_png(path)?;
            if png.channels < 3 {
                let kind = ["grey", "grey and alpha"][png.channels - 1];
                return Err(format!("expected an RGB or RGBA image, found {kind}"));
            }
            let texels = (0..png.width * png.height)
                .map(|p| {
                    std::array::from_fn(|c| {
                        crate::color::srgb_decode(png.values[p * png.channels + c])
                    })
                })
                .collect();
            Ok((png.width, png.height, texels))
        }
        Some("exr") => read_exr(path),
        _ => Err("expected a .png or .exr image".to_string()),
    }
}

/// A reflectance over a surface.
#[derive(Debug, Clone)]
pub enum Texture {
    /// An RGB image, upsampled per lookup.
    Image(Arc<ImageTexture>),
    /// Two spectra in alternating squares, `checks` per unit of u and of v; (0, 0) starts
    /// with the first.
    Checkerboard {
        /// The two spectra.
        spectra: [Spectrum; 2],
        /// Squares per unit of u and v.
        checks: [f32; 2],
    },
}

/// A texture's reflectance at one point: a spectrum of the scene, or an upsampled RGB.
#[derive(Debug, Clone, Copy)]
pub enum Texel<'a> {
    /// One of a checkerboard's spectra.
    Spectrum(&'a Spectrum),
    /// An image's filtered RGB, upsampled as an albedo.
    Rgb(RgbSpectrum),
}

impl Texel<'_> {
    /// The reflectance at `lambda`.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        match self {
            Texel::Spectrum(s) => s.eval(lambda),
            Texel::Rgb(s) => s.eval(lambda),
        }
    }

    /// The reflectance at four wavelengths.
    #[inline]
    pub fn eval4(&self, lambda: Vec4) -> Vec4 {
        match self {
            Texel::Spectrum(s) => s.eval4(lambda),
            Texel::Rgb(s) => s.eval4(lambda),
        }
    }
}

impl Texture {
    /// The reflectance at `uv`: one image lookup and upsampling, for any wavelengths.
    #[inline]
    pub fn at(&self, uv: Vec2) -> Texel<'_> {
        match self {
            Texture::Image(img) => Texel::Rgb(RgbSpectrum::albedo(img.rgb(uv))),
            Texture::Checkerboard { spectra, checks } => {
                Texel::Spectrum(&spectra[checker(uv, *checks)])
            }
        }
    }

    /// The reflectance at `uv` and four wavelengths.
    pub fn eval4(&self, uv: Vec2, lambda: Vec4) -> Vec4 {
        self.at(uv).eval4(lambda)
    }

    /// The reflectance of the W paths in `m` at their coordinates `uv` and wavelengths (0
    /// for the other paths): path by path, as [`Texture::eval4`].
    #[inline]
    pub fn eval_w<F: Float>(&self, lambda: &Spec<F>, m: F::Mask, uv: &F::Arr<Vec2>) -> Spec<F> {
        let mut out = Spec::zero();
        for i in crate::simd::Mask::iter(m) {
            out.set_path(i, self.eval4(uv[i], lambda.path(i)));
        }
        out
    }

    /// The image, if it is one.
    pub fn image(&self) -> Option<&ImageTexture> {
        match self {
            Texture::Image(img) => Some(img),
            Texture::Checkerboard { .. } => None,
        }
    }
}

/// Which of a checkerboard's two spectra lies at `uv`.
pub(crate) fn checker(uv: Vec2, checks: [f32; 2]) -> usize {
    let i = (uv.x * checks[0]).floor() as i64 + (uv.y * checks[1]).floor() as i64;
    i.rem_euclid(2) as usize
}

/// A PNG's stored values, each scaled to [0, 1] (not decoded).
struct Png {
    width: usize,
    height: usize,
    /// 1 (grey), 2 (grey, alpha), 3 (RGB) or 4 (RGBA).
    channels: usize,
    /// Texel by texel, channel by channel.
    values: Vec<f32>,
}

/// Reads a PNG of 8 or 16 bits per channel (palettes expanded).
fn read_png(path: &Path) -> Result<Png, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder
        .read_info()
        .map_err(|e| format!("not a readable PNG: {e}"))?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| format!("not a readable PNG: {e}"))?;
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        other => {
            return Err(format!(
                "expected a grey, RGB or RGBA image, found {other:?}"
            ))
        }
    };
    let (width, height) = (info.width as usize, info.height as usize);
    let bytes = &buf[..info.buffer_size()];
    let values = match info.bit_depth {
        png::BitDepth::Sixteen => bytes
            .chunks_exact(2)
            .map(|b| f32::from(u16::from_be_bytes([b[0], b[1]])) / 65535.0)
            .collect(),
        _ => bytes.iter().map(|&b| f32::from(b) / 255.0).collect(),
    };
    Ok(Png {
        width,
        height,
        channels,
        values,
    })
}

/// The RGB channels of an OpenEXR image (linear): width, height and texels row by row.
pub(crate) fn read_exr(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>), String> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| {
            (
                size.width(),
                vec![[0.0f32; 3]; size.width() * size.height()],
            )
        },
        |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .map_err(|e| format!("not a readable RGB OpenEXR image: {e}"))?;
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    Ok((size.width(), size.height(), texels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_modes_fold_indices_into_the_image() {
        let n = 4;
        let idx = |w: Wrap| [-5, -1, 0, 3, 4, 7, 9].map(|i| w.index(i, n));
        assert_eq!(idx(Wrap::Repeat), [3, 3, 0, 3, 0, 3, 1]);
        assert_eq!(idx(Wrap::Clamp), [0, 0, 0, 3, 3, 3, 3]);
        assert_eq!(idx(Wrap::Mirror), [3, 0, 0, 3, 3, 0, 1]);
    }

    #[test]
    fn a_checkerboard_alternates_from_its_first_spectrum() {
        let checks = [2.0, 2.0];
        assert_eq!(checker(Vec2::new(0.1, 0.1), checks), 0);
        assert_eq!(checker(Vec2::new(0.6, 0.1), checks), 1);
        assert_eq!(checker(Vec2::new(0.6, 0.6), checks), 0);
        assert_eq!(checker(Vec2::new(-0.1, 0.1), checks), 1);
    }
}
