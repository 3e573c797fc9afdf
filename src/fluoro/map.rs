//! Fluorescence maps: a fluorescent surface whose dye and ordinary reflectance vary over
//! it, such as a logo printed in fluorescent ink on paper.
//!
//! At texture coordinates (u, v) the surface re-radiates with
//! M_uv(λi → λo) = D_uv(λo)·δ(λi − λo) + s(u, v)·F(λi, λo):
//! - the diagonal D_uv is the material's `reflectance`, which may be a texture (the paper's
//!   and the ink's ordinary colours), or else the dye's or the matrix's own diagonal;
//! - the dye strength s ∈ [0, 1] (`fluorescence`, a [`ScalarTexture`]) scales the
//!   re-radiated part F. It is the share of the surface the ink covers (a halftone's
//!   coverage), or a concentration while the dye layer is optically thin (absorption, and
//!   with it F, linear in the amount of dye).
//!
//! F keeps its shape, so shift sampling keeps its tables: the kept/shifted choice takes
//! D_uv and s·σ_se, and a shift's cell is drawn from F's own column
//! ([`Reradiation::sample_input_with`]).

use super::Reradiation;
use crate::simd::Float;
use crate::texture::scalar::ScalarTexture;
use crate::texture::{Texel, Texture};
use glam::Vec2;

/// Where a fluorescent material's diagonal and dye strength come from.
#[derive(Debug, Clone)]
pub struct FluorescenceMap {
    /// The ordinary reflectance over the surface; `None`: the re-radiation's own diagonal.
    pub diagonal: Option<Texture>,
    /// The dye strength over the surface, in [0, 1].
    pub strength: ScalarTexture,
}

impl FluorescenceMap {
    /// Whether it reads texture coordinates.
    pub fn varies(&self) -> bool {
        self.diagonal.is_some() || self.strength.varies()
    }

    /// The re-radiation `rr` at texture coordinates `uv`.
    #[inline]
    pub fn at<'a>(&'a self, rr: &'a Reradiation, uv: Vec2) -> Printed<'a> {
        Printed {
            rr,
            diagonal: self.diagonal.as_ref().map(|t| t.at(uv)),
            strength: self.strength.eval(uv),
        }
    }

    /// The cells where the surface creates energy somewhere: the largest D_uv + s_uv·σ_sa
    /// over a grid of (u, v) at least as fine as the maps' texels (64² for procedural ones,
    /// at most 1024²), [`Reradiation::energy_gain_rows`].
    pub fn energy_gain_rows(&self, rr: &Reradiation) -> Vec<(f32, f32)> {
        let texels = |w: usize, h: usize| w.max(h);
        let sizes = [
            self.diagonal
                .as_ref()
                .and_then(|t| t.image())
                .map(|i| texels(i.width, i.height)),
            self.strength.image().map(|i| texels(i.width, i.height)),
        ];
        let n = sizes.into_iter().flatten().fold(64, usize::max).min(1024);
        let points: Vec<Printed> = (0..n * n)
            .map(|k| {
                let uv = Vec2::new(
                    ((k % n) as f32 + 0.5) / n as f32,
                    ((k / n) as f32 + 0.5) / n as f32,
                );
                self.at(rr, uv)
            })
            .collect();
        rr.energy_gain_rows_with(|c, out| {
            points
                .iter()
                .map(|p| f64::from(p.d(c)) + f64::from(p.strength) * out)
                .fold(0.0, f64::max)
        })
    }
}

/// A fluorescent surface at one point: M = D·δ + s·F.
#[derive(Debug, Clone, Copy)]
pub struct Printed<'a> {
    rr: &'a Reradiation,
    /// The diagonal there (`None`: the re-radiation's own).
    diagonal: Option<Texel<'a>>,
    /// The dye strength there.
    strength: f32,
}

impl Printed<'_> {
    /// D(λo), clamped to be non-negative as [`Reradiation::d`] is.
    #[inline]
    pub fn d(&self, lambda_o: f32) -> f32 {
        match &self.diagonal {
            Some(t) => t.eval(lambda_o).nonneg(),
            None => self.rr.d(lambda_o),
        }
    }

    /// The dye strength s.
    pub fn strength(&self) -> f32 {
        self.strength
    }

    /// The re-radiation whose F this scales.
    pub fn reradiation(&self) -> &Reradiation {
        self.rr
    }
}
