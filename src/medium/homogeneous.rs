//! A homogeneous medium, optionally fluorescent: a dye dissolved in it, or a general
//! re-radiation matrix.
//!
//! # Units
//! Coefficients σ are in 1/scene-unit (the unit of the scene's coordinates). The
//! re-emission density F(λi, λo) is per scene-unit and per nm of λi; σ_se and σ_sa are in
//! 1/scene-unit. A shift sample's `value` is σ_s(λo) for a kept wavelength and F(λi, λo) for
//! a shift, and value/pdf = σ̂_s(λo) either way.
//!
//! # The dye and σ_sa
//! The dye is given by its absorption coefficient σ_dye(λ) = concentration × absorption
//! spectrum (1/scene-unit), an emission shape E and a quantum yield Φ. It re-emits with the
//! convention of [`Reradiation::from_dye`], taking its "absorbed fraction" A to be σ_dye:
//!
//! F(λi, λo) = Φ · σ_dye(λi) · E(λo) · 𝟙(λo > λi) / ∫_{λ' > λi} E(λ') dλ'
//!
//! on the cells of `cell_nm` nm (σ_dye and E at the cell centres). Hence the out-shifting
//! coefficient is σ_sa(λ) = Φ·σ_dye(c) where c is the centre of λ's cell and some emission
//! lies in a cell above it, and 0 elsewhere: σ_sa ≤ Φ·σ_dye up to the discretisation of
//! σ_dye over a cell. The rest of the dye's absorption, (1 − Φ)·σ_dye, and all of it where
//! nothing can be emitted above λ, is lost.
//!
//! On a camera path every absorption by the dye removes light from λ (either lost or moved
//! to a longer wavelength), so the dye adds its full σ_dye(λ), evaluated continuously at λ,
//! to the extinction:
//!
//! σ̂_t(λ) = σ_a(λ) + σ_s(λ) + σ_f(λ),   σ̂_s(λ) = σ_s(λ) + σ_se(λ),
//!
//! with σ_f = σ_dye for a dye. (In docs/design.md's notation σ̂_t = σ_a' + σ_s + σ_sa with
//! σ_a' = σ_a + σ_dye − σ_sa the absorption that does not re-emit.) σ̂_s may exceed σ̂_t:
//! in the emission band outside the absorption band σ̂_t can even be 0 while σ̂_s > 0.
//!
//! # A re-radiation matrix
//! Not every fluorescent medium is a dye: the EGSR 2018 paper's medium re-radiates with
//! M(λi → λo) = d₀·min(tentₐ(λi), tentₑ(λo)), which no absorption × emission product
//! reproduces. [`Homogeneous::with_matrix`] takes F from a measured or generated matrix
//! (m[i][o] the fraction per cell, as a fluorescent surface reads it) times a coefficient
//! `scale` per scene unit. Its out-shifting σ_sa is then all the extinction it adds,
//! σ_f = σ_sa: the matrix says what is re-emitted, and any absorption that is lost is
//! σ_a's. The matrix's diagonal is not used (elastic scattering is σ_s).
//!
//! [`Reradiation::from_dye`] takes A as a fraction ≤ 1, but a coefficient may exceed 1.
//! Since F is linear in A and the shift-sampling CDFs do not depend on its scale, the dye is
//! stored as a [`Reradiation`] built from σ_dye/s with s = max(1, max σ_dye), whose diagonal
//! is σ_s/s; σ_se, σ_sa and shift values are multiplied back by s, pdfs are unchanged. A
//! matrix is stored as read, with s its `scale`.

use super::phase::HenyeyGreenstein;
use crate::error::Detail;
use crate::fluoro::{Reradiation, ShiftSample};
use crate::simd::{map4, Float};
use crate::spectrum::{Spectrum, LAMBDA_MAX, LAMBDA_MIN};
use glam::Vec4;

/// A coefficient per lane as used here: negative and NaN count as 0.
#[inline]
fn nonneg4(v: Vec4) -> Vec4 {
    map4(v, Float::nonneg)
}

/// What a fluorescent medium adds to the extinction on camera paths (module docs).
#[derive(Clone, Debug)]
enum Absorber {
    /// A dye: all of σ_dye (1/scene-unit) is extinction, re-emitted or not.
    Dye {
        sigma_dye: Spectrum,
        quantum_yield: f32,
    },
    /// A re-radiation matrix: its out-shifting σ_sa is the extinction.
    Matrix,
}

/// The fluorescent part of a medium.
#[derive(Clone, Debug)]
struct Fluorescence {
    absorber: Absorber,
    /// F/`scale` with diagonal σ_s/`scale` (see the module docs).
    shift: Reradiation,
    /// s > 0: the factor that brings the stored matrix back to 1/scene-unit.
    scale: f32,
}

/// A homogeneous medium: absorption σ_a, elastic scattering σ_s with a Henyey–Greenstein
/// phase function, and optionally a fluorescent dye or re-radiation matrix (module docs).
#[derive(Clone, Debug)]
pub struct Homogeneous {
    sigma_a: Spectrum,
    sigma_s: Spectrum,
    phase: HenyeyGreenstein,
    fluorescence: Option<Fluorescence>,
}

impl Homogeneous {
    /// A non-fluorescent medium from its absorption and scattering coefficients
    /// (1/scene-unit; negative or NaN values count as 0).
    pub fn new(sigma_a: Spectrum, sigma_s: Spectrum, phase: HenyeyGreenstein) -> Homogeneous {
        Homogeneous {
            sigma_a,
            sigma_s,
            phase,
            fluorescence: None,
        }
    }

    /// A grey medium from its single-scattering albedo (clamped to [0, 1]) and extinction
    /// coefficient σ_t (1/scene-unit): σ_s = albedo·σ_t, σ_a = (1 − albedo)·σ_t.
    pub fn from_albedo(albedo: f32, sigma_t: f32, phase: HenyeyGreenstein) -> Homogeneous {
        let a = if albedo.is_nan() {
            0.0
        } else {
            albedo.clamp(0.0, 1.0)
        };
        let st = sigma_t.nonneg();
        Homogeneous::new(
            Spectrum::Constant((1.0 - a) * st),
            Spectrum::Constant(a * st),
            phase,
        )
    }

    /// Dissolves a fluorescent dye in the medium (replacing any previous one):
    /// `absorption_coefficient` σ_dye (1/scene-unit, concentration × absorption spectrum,
    /// may exceed 1), `emission` a non-negative shape (its scale does not matter),
    /// `quantum_yield` Φ ∈ [0, 1], on cells of `cell_nm` nm (see
    /// [`Reradiation::from_dye`]; the module docs say how σ_sa follows).
    pub fn with_dye(
        mut self,
        absorption_coefficient: &Spectrum,
        emission: &Spectrum,
        quantum_yield: f32,
        cell_nm: f32,
    ) -> Result<Homogeneous, Detail> {
        let peak = absorption_coefficient.max_value();
        if !peak.is_finite() {
            return Err(Detail::Text(format!(
                "dye absorption coefficient must be finite, found a maximum of {peak}"
            )));
        }
        let scale = peak.max(1.0);
        let fraction = absorption_coefficient.clone().scaled(1.0 / scale);
        let shift = Reradiation::from_dye(
            Spectrum::Constant(0.0),
            &fraction,
            emission,
            quantum_yield,
            cell_nm,
        )
        .map_err(|e| {
            Detail::Text(format!(
                "fluorescent medium: {e} (absorption coefficient divided by {scale})"
            ))
        })?
        .with_diagonal(self.sigma_s.clone().scaled(1.0 / scale));
        self.fluorescence = Some(Fluorescence {
            absorber: Absorber::Dye {
                sigma_dye: absorption_coefficient.clone(),
                quantum_yield,
            },
            shift,
            scale,
        });
        Ok(self)
    }

    /// Makes the medium re-radiate with `matrix`'s off-diagonal F times `scale`
    /// (1/scene-unit; replacing any dye or matrix): σ_f = σ_sa (module docs). The matrix's
    /// diagonal is replaced by σ_s. An error unless `scale` is positive and finite and the
    /// matrix shifts some light inside the renderer's range.
    pub fn with_matrix(mut self, matrix: Reradiation, scale: f32) -> Result<Homogeneous, Detail> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(Detail::expected(
                "a positive coefficient per scene unit",
                scale,
            ));
        }
        if !matrix.is_fluorescent() {
            return Err(Detail::Text(format!(
                "the re-radiation matrix shifts no light between {LAMBDA_MIN} and {LAMBDA_MAX} nm (every entry above the diagonal is 0 there): the medium would not fluoresce"
            )));
        }
        let shift = matrix.with_diagonal(self.sigma_s.clone().scaled(1.0 / scale));
        self.fluorescence = Some(Fluorescence {
            absorber: Absorber::Matrix,
            shift,
            scale,
        });
        Ok(self)
    }

    /// The phase function of elastic scattering (fluorescent re-emission is taken to be
    /// isotropic in the real world; this renderer uses the same lobe for both).
    #[inline]
    pub fn phase(&self) -> &HenyeyGreenstein {
        &self.phase
    }

    /// Whether the medium shifts wavelengths (a dye or matrix with some F > 0 in range).
    #[inline]
    pub fn is_fluorescent(&self) -> bool {
        self.fluorescence
            .as_ref()
            .is_some_and(|f| f.shift.is_fluorescent())
    }

    /// The dye's quantum yield Φ, if there is a dye.
    pub fn quantum_yield(&self) -> Option<f32> {
        match self.fluorescence.as_ref().map(|f| &f.absorber) {
            Some(Absorber::Dye { quantum_yield, .. }) => Some(*quantum_yield),
            _ => None,
        }
    }

    /// σ_a per lane (absorption not due to the dye).
    #[inline]
    pub fn sigma_a(&self, lambda: Vec4) -> Vec4 {
        nonneg4(self.sigma_a.eval4(lambda))
    }

    /// σ_s per lane (elastic scattering).
    #[inline]
    pub fn sigma_s(&self, lambda: Vec4) -> Vec4 {
        nonneg4(self.sigma_s.eval4(lambda))
    }

    /// σ_f per lane: the extinction the fluorescent part adds, σ_dye for a dye (all its
    /// absorption), σ_sa for a matrix; 0 for a plain medium.
    #[inline]
    pub fn sigma_f(&self, lambda: Vec4) -> Vec4 {
        match &self.fluorescence {
            Some(Fluorescence {
                absorber: Absorber::Dye { sigma_dye, .. },
                ..
            }) => nonneg4(sigma_dye.eval4(lambda)),
            Some(Fluorescence {
                absorber: Absorber::Matrix,
                ..
            }) => self.sigma_sa(lambda),
            None => Vec4::ZERO,
        }
    }

    /// In-shifting σ_se(λ) = ∫ F(λi, λ) dλi per lane (0 when not fluorescent).
    #[inline]
    pub fn sigma_se(&self, lambda: Vec4) -> Vec4 {
        match &self.fluorescence {
            Some(f) => map4(lambda, |l| f.shift.sigma_se(l)) * f.scale,
            None => Vec4::ZERO,
        }
    }

    /// Out-shifting σ_sa(λ) = ∫ F(λ, λo) dλo per lane (0 when not fluorescent); see the
    /// module docs for its relation to σ_dye.
    #[inline]
    pub fn sigma_sa(&self, lambda: Vec4) -> Vec4 {
        match &self.fluorescence {
            Some(f) => map4(lambda, |l| f.shift.sigma_sa(l)) * f.scale,
            None => Vec4::ZERO,
        }
    }

    /// Camera-path extinction σ̂_t = σ_a + σ_s + σ_f per lane.
    #[inline]
    pub fn sigma_t_hat(&self, lambda: Vec4) -> Vec4 {
        self.sigma_a(lambda) + self.sigma_s(lambda) + self.sigma_f(lambda)
    }

    /// Camera-path scattering σ̂_s = σ_s + σ_se per lane: the value over pdf of
    /// [`Self::sample_shift`].
    #[inline]
    pub fn sigma_s_hat(&self, lambda: Vec4) -> Vec4 {
        self.sigma_s(lambda) + self.sigma_se(lambda)
    }

    /// Shift sampling at a real collision for one lane with output wavelength `lambda_o`:
    /// keep λo (elastic scattering) with probability σ_s/σ̂_s (`u_choice` below it), else
    /// draw λi ∝ F(·, λo) with `u_lambda`. value/pdf = σ̂_s(λo). `None` when σ̂_s(λo) = 0:
    /// nothing scatters into λo and the lane cannot continue.
    #[inline]
    pub fn sample_shift(&self, lambda_o: f32, u_choice: f32, u_lambda: f32) -> Option<ShiftSample> {
        match &self.fluorescence {
            Some(f) => f
                .shift
                .sample_input(lambda_o, u_choice, u_lambda)
                .map(|s| ShiftSample {
                    value: s.value * f.scale,
                    ..s
                }),
            None => {
                let s = self.sigma_s.eval(lambda_o).nonneg();
                (s > 0.0 && s.is_finite()).then_some(ShiftSample {
                    lambda_i: lambda_o,
                    kept: true,
                    pdf: 1.0,
                    value: s,
                })
            }
        }
    }

    /// The pdf with which [`Self::sample_shift`]`(lambda_o, ..)` produces the event: the
    /// probability σ_s/σ̂_s when `kept` (`lambda_i` ignored), else the density
    /// F(λi, λo)/σ̂_s (nm⁻¹). 0 when σ̂_s(λo) = 0.
    #[inline]
    pub fn shift_pdf(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        match &self.fluorescence {
            Some(f) => f.shift.pdf_input(lambda_i, lambda_o, kept),
            None => {
                let s = self.sigma_s.eval(lambda_o).nonneg();
                if kept && s > 0.0 && s.is_finite() {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }

    /// The event's value: σ_s(λo) when `kept` (`lambda_i` ignored), else F(λi, λo)
    /// (1/(scene-unit·nm)).
    #[inline]
    pub fn shift_value(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        match &self.fluorescence {
            Some(f) => f.shift.value(lambda_i, lambda_o, kept) * f.scale,
            None if kept => self.sigma_s.eval(lambda_o).nonneg(),
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::Tabulated;

    fn assert_traits<T: Send + Sync + Clone + std::fmt::Debug>() {}

    #[test]
    fn types_are_send_sync_clone_debug() {
        assert_traits::<Homogeneous>();
    }

    #[test]
    fn plain_medium_keeps_the_wavelength() {
        let m = Homogeneous::from_albedo(0.25, 2.0, HenyeyGreenstein::isotropic());
        let l = Vec4::new(400.0, 500.0, 600.0, 700.0);
        assert_eq!(m.sigma_t_hat(l), Vec4::splat(2.0));
        assert_eq!(m.sigma_s_hat(l), Vec4::splat(0.5));
        assert!(!m.is_fluorescent());
        let s = m.sample_shift(500.0, 0.9, 0.9).unwrap();
        assert!(s.kept && s.lambda_i == 500.0 && s.value / s.pdf == 0.5);
        assert_eq!(m.shift_pdf(500.0, 500.0, true), 1.0);
        assert_eq!(m.shift_pdf(450.0, 500.0, false), 0.0);
        let black = Homogeneous::from_albedo(0.0, 2.0, HenyeyGreenstein::isotropic());
        assert!(black.sample_shift(500.0, 0.5, 0.5).is_none());
    }

    #[test]
    fn dye_coefficient_above_one_is_accepted_and_scaled_back() {
        let band = |a: f32, b: f32, v: f32| {
            Spectrum::Tabulated(
                Tabulated::new(vec![a - 1e-3, a, b, b + 1e-3], vec![0.0, v, v, 0.0]).unwrap(),
            )
        };
        let m = Homogeneous::new(
            Spectrum::Constant(0.0),
            Spectrum::Constant(0.0),
            HenyeyGreenstein::isotropic(),
        )
        .with_dye(
            &band(440.0, 480.0, 25.0),
            &band(500.0, 600.0, 1.0),
            0.5,
            10.0,
        )
        .unwrap();
        assert!(m.is_fluorescent());
        let l = Vec4::new(455.0, 520.0, 700.0, 400.0);
        let sa = m.sigma_sa(l);
        assert!((sa.x - 12.5).abs() < 1e-4, "{sa}");
        assert_eq!(m.sigma_t_hat(l), Vec4::new(25.0, 0.0, 0.0, 0.0));
        // All 40 nm of absorption feed 100 nm of emission: σ_se = 12.5·40/100 = 5.
        let se = m.sigma_s_hat(l);
        assert!((se.y - 5.0).abs() < 1e-4, "{se}");
        let s = m.sample_shift(520.0, 0.5, 0.3).unwrap();
        assert!(!s.kept && (440.0..480.0).contains(&s.lambda_i));
        assert!((s.value / s.pdf - 5.0).abs() < 1e-4);
        assert!(m.sample_shift(455.0, 0.5, 0.5).is_none());
    }
}
