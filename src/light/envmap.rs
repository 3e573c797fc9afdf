//! An environment map: radiance from every direction read from a lat-long (equirectangular)
//! RGB OpenEXR image, each texel's linear sRGB upsampled to an illuminant spectrum
//! ([`RgbSpectrum::illuminant`]: RGB (1, 1, 1) is D65 of luminance 1), and directions
//! importance-sampled by a piecewise-constant density on the texels' luminance × sin θ.
//!
//! The image is twice as wide as it is high. Row 0 looks straight up (+y), the middle row
//! at the horizon; going right, the azimuth φ = 2πx turns from −z towards +x, so the
//! direction of image point (x, y) ∈ [0, 1)² is, with θ = πy,
//! ω = (sin θ sin φ, cos θ, −sin θ cos φ) (Mitsuba 3's convention, so that one map lights
//! both renderers alike). A texel's radiance is constant over it (no filtering), the same
//! function the density samples.

use super::piecewise::Piecewise2d;
use super::MAX_RADIANCE;
use crate::error::Detail;
use crate::spectrum::upsample::RgbSpectrum;
use glam::{Vec3, Vec4};
use std::f32::consts::PI;
use std::path::Path;

/// A lat-long environment map, upsampled and ready to sample.
#[derive(Debug, Clone)]
pub struct EnvMap {
    /// Texels across.
    pub width: usize,
    /// Texels down (width / 2).
    pub height: usize,
    /// Each texel's radiance spectrum (× the light's scale), row by row.
    texels: Vec<RgbSpectrum>,
    /// Directions by luminance × sin θ.
    density: Piecewise2d,
    /// The mean luminance over the sphere (× scale): the light's power per 4π·πr².
    pub mean_luminance: f32,
}

/// Luminance Y of linear sRGB.
fn luminance(rgb: [f32; 3]) -> f64 {
    0.2126 * f64::from(rgb[0]) + 0.7152 * f64::from(rgb[1]) + 0.0722 * f64::from(rgb[2])
}

impl EnvMap {
    /// Reads the RGB channels of the lat-long EXR at `path` (× `scale`).
    pub fn load(path: &Path, scale: f32) -> Result<EnvMap, Detail> {
        let what = path.display();
        let (w, h, rgb) = crate::texture::read_exr(path)
            .map_err(|e| Detail::Text(format!("cannot read {what}: {e}")))?;
        EnvMap::from_rgb(w, h, &rgb, scale).map_err(|e| Detail::Text(format!("{what}: {e}")))
    }

    /// The map of `width` × `height` linear sRGB texels `rgb` (row 0 at the top) × `scale`;
    /// an error for a size that is not 2:1, a texel that is negative or not finite, or an
    /// image that is black.
    pub fn from_rgb(
        width: usize,
        height: usize,
        rgb: &[[f32; 3]],
        scale: f32,
    ) -> Result<EnvMap, String> {
        if height == 0 || width != 2 * height {
            return Err(format!(
                "expected a lat-long image twice as wide as it is high, found {width}x{height}"
            ));
        }
        if let Some(k) = rgb
            .iter()
            .position(|t| !t.iter().all(|v| v.is_finite() && *v >= 0.0))
        {
            return Err(format!(
                "expected finite non-negative radiance, found {:?} at texel ({}, {})",
                rgb[k],
                k % width,
                k / width
            ));
        }
        let peak = rgb.iter().flatten().fold(0.0f32, |a, &b| a.max(b));
        if f64::from(peak) * f64::from(scale) > f64::from(MAX_RADIANCE) {
            return Err(format!(
                "expected texels × scale ≤ {MAX_RADIANCE:e} (larger ones overflow 32-bit floats in a path's estimate), found {peak:e} × {scale:e}"
            ));
        }
        let sin_row = |row: usize| (PI * (row as f32 + 0.5) / height as f32).sin();
        let weights: Vec<f64> = rgb
            .iter()
            .enumerate()
            .map(|(k, &t)| luminance(t) * f64::from(sin_row(k / width)))
            .collect();
        let density = Piecewise2d::new(width, height, &weights)
            .ok_or_else(|| "the image is black (no texel has luminance)".to_string())?;
        // ∫ Y dω / 4π, by the midpoint rule in θ: each texel spans (2π/w)(π/h) sin θ.
        let total: f64 = weights.iter().sum();
        let mean = total * f64::from(2.0 * PI * PI) / (width * height) as f64 / f64::from(4.0 * PI);
        let texels = rgb
            .iter()
            .map(|&t| RgbSpectrum::illuminant(t.map(|v| v * scale)))
            .collect();
        Ok(EnvMap {
            width,
            height,
            texels,
            density,
            mean_luminance: (mean * f64::from(scale)) as f32,
        })
    }

    /// Bytes its texels and density take (`stokes info` reports them).
    pub fn memory(&self) -> usize {
        self.texels.len() * std::mem::size_of::<RgbSpectrum>() + self.density.memory()
    }

    /// The direction of image point (x, y) ∈ [0, 1)².
    pub fn direction(x: f32, y: f32) -> Vec3 {
        let (sin_t, cos_t) = (PI * y).sin_cos();
        let (sin_p, cos_p) = (2.0 * PI * x).sin_cos();
        Vec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p)
    }

    /// The image point (x, y) ∈ [0, 1)² of unit direction `d`.
    pub fn image_point(d: Vec3) -> (f32, f32) {
        let phi = d.x.atan2(-d.z);
        let x = (phi / (2.0 * PI)).rem_euclid(1.0);
        let y = d.y.clamp(-1.0, 1.0).acos() / PI;
        (x.min(1.0 - f32::EPSILON), y.min(1.0 - f32::EPSILON))
    }

    /// A direction from two uniforms, its solid-angle density and its texel; `None` where
    /// the density is zero (a black texel or a pole).
    pub fn sample(&self, u: [f32; 2]) -> Option<(Vec3, f32, u32)> {
        let ([x, y], [col, row], pdf_xy) = self.density.sample(u);
        let sin_t = (PI * y).sin();
        let pdf = pdf_xy / (2.0 * PI * PI * sin_t);
        (pdf > 0.0 && pdf.is_finite()).then(|| {
            (
                EnvMap::direction(x, y),
                pdf,
                (row * self.width + col) as u32,
            )
        })
    }

    /// The solid-angle density with which [`EnvMap::sample`] gives unit direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let (x, y) = EnvMap::image_point(d);
        let sin_t = (PI * y).sin();
        if sin_t <= 0.0 {
            return 0.0;
        }
        self.density.pdf(x, y) / (2.0 * PI * PI * sin_t)
    }

    /// The texel seen in unit direction `d`.
    pub fn texel(&self, d: Vec3) -> u32 {
        let (x, y) = EnvMap::image_point(d);
        let [col, row] = self.density.cell(x, y);
        (row * self.width + col) as u32
    }

    /// The radiance of texel `k` at four wavelengths.
    #[inline]
    pub fn radiance(&self, k: u32, lambda: Vec4) -> Vec4 {
        self.texels[k as usize].eval4(lambda)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `stokes info` reports for a map: per texel its spectrum, one cumulative
    /// weight (f64) and one density (f32); per row one cumulative weight (f64).
    #[test]
    fn a_map_reports_the_bytes_it_holds() {
        for (w, h) in [(4, 2), (16, 8)] {
            let rgb = vec![[0.5, 0.25, 1.0]; w * h];
            let map = EnvMap::from_rgb(w, h, &rgb, 1.0).unwrap();
            let texel = std::mem::size_of::<RgbSpectrum>() + 8 + 4;
            assert_eq!(map.memory(), w * h * texel + h * 8, "{w}x{h}");
        }
    }
}
