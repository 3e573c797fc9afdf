//! Spectra: wavelength sampling, spectral curves, and the CIE observer and illuminants.
//!
//! The renderer works over λ ∈ [[`LAMBDA_MIN`], [`LAMBDA_MAX`]) = [360, 830) nm, the
//! support of the CIE 1931 colour-matching functions. A path carries four wavelengths
//! ([`SampledWavelengths`], hero wavelength sampling); every spectrum is evaluated at those
//! four with [`Spectrum::eval4`].
//!
//! The kinds of [`Spectrum`] and their units (a scene's `scale` multiplies any of them):
//! - `Constant(c)`: the same value at every wavelength (reflectance, or radiance in
//!   W·sr⁻¹·m⁻²·nm⁻¹).
//! - `Tabulated`: measured samples, linear between them and zero outside (Mitsuba 3 and
//!   pbrt-v4 behave the same), e.g. from a CSV file ([`read_csv`], [`csv_column`]) or a CIE
//!   illuminant ([`illuminant`]: "D65", "A", "F2", "F11", relative power).
//! - `Blackbody { kelvin, normalise }`: Planck's law in W·sr⁻¹·m⁻²·nm⁻¹, or divided by its
//!   peak (so its maximum over all wavelengths is 1) when `normalise`.
//! - `NarrowBand { centre, fwhm }`: a Gaussian line (LED, laser) in nm⁻¹, normalised so
//!   that ∫ s(λ) dλ = 1 (λ in nm); `scale` is then the line's total radiance in W·sr⁻¹·m⁻².
//! - `Rgb`: a colour given as linear sRGB, made a smooth spectrum by a sigmoid of a
//!   quadratic ([`upsample`]): an albedo in [0, 1], an unbounded multiple of one, or an
//!   emitter's colour (times D65 with Y = 1).
//! - `Scaled(s, k)`: `k` times `s`.
//!
//! Colour: [`spectrum_to_xyz`] gives the exact XYZ of a radiance spectrum (Y = 1 for a
//! constant 1), [`xyz_estimate`] the Monte Carlo estimate of it from four lanes, and
//! [`RgbWeights`] the film's: each lane's linear sRGB in one look-up.

mod blackbody;
mod cie;
mod curve;
pub mod desc;
mod rgb_weights;
pub mod upsample;
mod wavelengths;

use crate::error::Detail;
use crate::simd::{map4, Float, Mask, Spec};
use glam::Vec4;

pub use blackbody::{peak_value as blackbody_peak_value, peak_wavelength, planck};
pub use cie::{
    cie_xyz, illuminant, reflectance_to_xyz, spectrum_to_xyz, xyz_estimate, CIE_Y_INTEGRAL,
    ILLUMINANT_NAMES,
};
pub use curve::{csv_column, parse_csv, read_csv, Tabulated};
pub use desc::{Range, SpectrumDesc, SpectrumTable};
pub use rgb_weights::RgbWeights;
pub use upsample::RgbSpectrum;
pub use wavelengths::{hwss, mono, SampledWavelengths, Wavelengths, VISIBLE_FLOOR};

/// Shortest wavelength the renderer samples (nm).
pub const LAMBDA_MIN: f32 = 360.0;
/// Longest wavelength the renderer samples (nm), exclusive.
pub const LAMBDA_MAX: f32 = 830.0;
/// `LAMBDA_MAX − LAMBDA_MIN`, the Δ of hero wavelength sampling.
pub const LAMBDA_RANGE: f32 = LAMBDA_MAX - LAMBDA_MIN;
/// The 1 nm cells of [`LAMBDA_MIN`, `LAMBDA_MAX`): what the integer-nm tables (tabulated
/// curves, the visible pdf, the film's colour weights) are indexed by.
const NM_CELLS: usize = LAMBDA_RANGE as usize;

/// FWHM = 2√(2 ln 2) σ for a Gaussian.
const FWHM_PER_SIGMA: f32 = 2.354_82;

/// A function of wavelength (nm): reflectance, radiance, or any coefficient.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same value at every wavelength.
    Constant(f32),
    /// Linear between samples, zero outside the first and last wavelength.
    Tabulated(Tabulated),
    /// Planck's law at `kelvin` in W·sr⁻¹·m⁻²·nm⁻¹; divided by its peak value (its
    /// maximum over all wavelengths becomes 1) when `normalise`. `kelvin` must be > 0
    /// (use [`Spectrum::blackbody`] to check).
    Blackbody { kelvin: f32, normalise: bool },
    /// A Gaussian line with full width at half maximum `fwhm` (nm), normalised so that
    /// ∫ s(λ) dλ = 1 over all λ: scaled by k it carries total radiance k W·sr⁻¹·m⁻².
    /// (A line whose tails reach past 360 or 830 nm loses the part outside.) `fwhm` must be
    /// > 0 (use [`Spectrum::narrow_band`] to check).
    NarrowBand { centre: f32, fwhm: f32 },
    /// An RGB colour as a smooth spectrum (see [`upsample`]).
    Rgb(RgbSpectrum),
    /// `factor` times the inner spectrum.
    Scaled(Box<Spectrum>, f32),
}

impl Spectrum {
    /// `f(a, b)` as a spectrum: exact for two constants, otherwise tabulated every
    /// nanometre over the rendered range (an error if a value is not finite).
    pub fn combine(
        a: &Spectrum,
        b: &Spectrum,
        f: impl Fn(f32, f32) -> f32,
    ) -> Result<Spectrum, Detail> {
        if let (Some(x), Some(y)) = (a.is_constant(), b.is_constant()) {
            return Ok(Spectrum::Constant(f(x, y)));
        }
        let w: Vec<f32> = (0..=LAMBDA_RANGE as u32)
            .map(|i| LAMBDA_MIN + i as f32)
            .collect();
        let v: Vec<f32> = w.iter().map(|&l| f(a.eval(l), b.eval(l))).collect();
        Ok(Spectrum::Tabulated(Tabulated::new(w, v)?))
    }

    /// A black body, checking that the temperature is positive and finite.
    pub fn blackbody(kelvin: f32, normalise: bool) -> Result<Spectrum, Detail> {
        if !(kelvin.is_finite() && kelvin > 0.0) {
            return Err(Detail::Text(format!(
                "blackbody temperature must be a positive number of kelvin, found {kelvin}"
            )));
        }
        Ok(Spectrum::Blackbody { kelvin, normalise })
    }

    /// A narrow band, checking that the centre is finite and the width positive.
    pub fn narrow_band(centre: f32, fwhm: f32) -> Result<Spectrum, Detail> {
        if !centre.is_finite() {
            return Err(Detail::Text(format!(
                "narrow band centre must be finite, found {centre}"
            )));
        }
        if !(fwhm.is_finite() && fwhm > 0.0) {
            return Err(Detail::Text(format!(
                "narrow band fwhm must be a positive number of nm, found {fwhm}"
            )));
        }
        Ok(Spectrum::NarrowBand { centre, fwhm })
    }

    /// `factor` times `self`, folding constants and nested scales.
    pub fn scaled(self, factor: f32) -> Spectrum {
        match self {
            _ if factor == 1.0 => self,
            Spectrum::Constant(c) => Spectrum::Constant(c * factor),
            Spectrum::Rgb(r) if factor >= 0.0 => Spectrum::Rgb(RgbSpectrum {
                scale: r.scale * factor,
                ..r
            }),
            Spectrum::Scaled(inner, k) => Spectrum::Scaled(inner, k * factor),
            other => Spectrum::Scaled(Box::new(other), factor),
        }
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        match self {
            Spectrum::Constant(c) => *c,
            Spectrum::Tabulated(t) => t.eval(lambda),
            Spectrum::Blackbody { kelvin, normalise } => {
                let b = planck(lambda, *kelvin);
                if *normalise {
                    b / blackbody_peak_value(*kelvin)
                } else {
                    b
                }
            }
            Spectrum::NarrowBand { centre, fwhm } => gaussian(lambda, *centre, *fwhm),
            Spectrum::Rgb(r) => r.eval(lambda),
            Spectrum::Scaled(inner, k) => k * inner.eval(lambda),
        }
    }

    /// The values at four wavelengths (one per lane).
    pub fn eval4(&self, lambda: Vec4) -> Vec4 {
        match self {
            Spectrum::Constant(c) => Vec4::splat(*c),
            Spectrum::Tabulated(t) => t.eval4(lambda),
            Spectrum::Blackbody { kelvin, normalise } => {
                let norm = if *normalise {
                    1.0 / blackbody_peak_value(*kelvin)
                } else {
                    1.0
                };
                map4(lambda, |l| planck(l, *kelvin) * norm)
            }
            Spectrum::NarrowBand { centre, fwhm } => map4(lambda, |l| gaussian(l, *centre, *fwhm)),
            Spectrum::Rgb(r) => r.eval4(lambda),
            Spectrum::Scaled(inner, k) => *k * inner.eval4(lambda),
        }
    }

    /// The values at the four wavelengths of the W paths of `m` (0 elsewhere): tables
    /// and constants at once for all paths, the rest path by path through
    /// [`Spectrum::eval4`] (the same numbers at every width).
    #[inline(always)]
    pub fn eval_w<F: Float>(&self, lambda: &Spec<F>, m: F::Mask) -> Spec<F> {
        match self {
            Spectrum::Constant(c) => Spec::splat(*c).masked(m),
            // Path by path, each path's four wavelengths in one SIMD evaluation (the same
            // bits as across the paths).
            Spectrum::Tabulated(t) => Spec::from_fn(|i| match m.get(i) {
                true => t.eval4(lambda.path(i)),
                false => Vec4::ZERO,
            }),
            _ => self.eval_w_rest(lambda, m),
        }
    }

    /// [`Spectrum::eval_w`] for the kinds other than constants and tables, out of line:
    /// a scaled spectrum recurses, and a recursive function is never inlined, so the hot
    /// kinds above would otherwise pay a call too.
    #[inline(never)]
    fn eval_w_rest<F: Float>(&self, lambda: &Spec<F>, m: F::Mask) -> Spec<F> {
        match self {
            Spectrum::Rgb(r) => r.eval_w(lambda, m),
            Spectrum::Scaled(inner, k) => inner.eval_w(lambda, m).map(|v| F::splat(*k) * v),
            _ => Spec::from_fn(|i| match m.get(i) {
                true => self.eval4(lambda.path(i)),
                false => Vec4::ZERO,
            }),
        }
    }

    /// An upper bound of the value over [`LAMBDA_MIN`, `LAMBDA_MAX`], e.g. for majorants
    /// and light selection. It is the maximum itself except under a negative scale, where
    /// it is the largest |value| times |scale|.
    pub fn max_value(&self) -> f32 {
        match self {
            Spectrum::Constant(c) => *c,
            Spectrum::Tabulated(t) => t.max_over(LAMBDA_MIN, LAMBDA_MAX),
            Spectrum::Blackbody { kelvin, .. } => {
                // Planck's law is unimodal in λ: the peak if it is in range, else an end.
                let peak = peak_wavelength(*kelvin);
                let at = peak.clamp(LAMBDA_MIN, LAMBDA_MAX);
                self.eval(at)
            }
            Spectrum::NarrowBand { centre, .. } => self.eval(centre.clamp(LAMBDA_MIN, LAMBDA_MAX)),
            Spectrum::Rgb(r) => r.max_value(),
            Spectrum::Scaled(inner, k) if *k >= 0.0 => k * inner.max_value(),
            Spectrum::Scaled(inner, k) => -k * inner.max_abs_value(),
        }
    }

    /// An upper bound of |value| over the range (lets [`Self::max_value`] bound a negative
    /// scale of a spectrum that has negative values).
    fn max_abs_value(&self) -> f32 {
        match self {
            Spectrum::Constant(c) => c.abs(),
            Spectrum::Tabulated(t) => t.max_abs_over(LAMBDA_MIN, LAMBDA_MAX),
            Spectrum::Scaled(inner, k) => k.abs() * inner.max_abs_value(),
            Spectrum::Blackbody { .. } | Spectrum::NarrowBand { .. } | Spectrum::Rgb(_) => {
                self.max_value()
            }
        }
    }

    /// `Some(c)` when the spectrum is the same `c` at every wavelength, so callers can skip
    /// per-lane work.
    pub fn is_constant(&self) -> Option<f32> {
        match self {
            Spectrum::Constant(c) => Some(*c),
            Spectrum::Scaled(inner, k) => inner.is_constant().map(|c| c * k),
            _ => None,
        }
    }
}

/// A unit-area Gaussian in λ with the given centre and FWHM.
fn gaussian(lambda: f32, centre: f32, fwhm: f32) -> f32 {
    let sigma = fwhm / FWHM_PER_SIGMA;
    let z = (lambda - centre) / sigma;
    (-0.5 * z * z).exp() / (sigma * (2.0 * std::f32::consts::PI).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_send_sync<T: Send + Sync + Clone + std::fmt::Debug>() {}

    #[test]
    fn spectrum_is_send_sync() {
        assert_send_sync::<Spectrum>();
        assert_send_sync::<SampledWavelengths>();
    }

    #[test]
    fn fwhm_constant_is_right() {
        let exact = 2.0 * (2.0 * 2.0f64.ln()).sqrt();
        assert!((f64::from(FWHM_PER_SIGMA) - exact).abs() < 1e-6);
        // Half the peak at centre ± fwhm/2.
        let s = Spectrum::narrow_band(550.0, 20.0).unwrap();
        assert!((s.eval(560.0) / s.eval(550.0) - 0.5).abs() < 1e-5);
        assert!((s.eval(540.0) / s.eval(550.0) - 0.5).abs() < 1e-5);
    }

    #[test]
    fn eval4_matches_eval_for_every_kind() {
        let t = Tabulated::new(vec![400.0, 500.0, 700.0], vec![0.2, 0.9, 0.4]).unwrap();
        let kinds = [
            Spectrum::Constant(0.7),
            Spectrum::Tabulated(t.clone()),
            Spectrum::Blackbody {
                kelvin: 3000.0,
                normalise: true,
            },
            Spectrum::Blackbody {
                kelvin: 6500.0,
                normalise: false,
            },
            Spectrum::NarrowBand {
                centre: 532.0,
                fwhm: 5.0,
            },
            Spectrum::Tabulated(t).scaled(2.5),
            Spectrum::Rgb(RgbSpectrum {
                coeffs: [-30.0, 25.0, -4.0],
                scale: 1.5,
                illuminant: false,
            }),
            Spectrum::Rgb(RgbSpectrum {
                coeffs: [12.0, -9.0, 1.0],
                scale: 0.7,
                illuminant: true,
            }),
        ];
        let l = Vec4::new(380.0, 455.5, 533.0, 829.0);
        for s in &kinds {
            let four = s.eval4(l).to_array();
            for k in 0..4 {
                let one = s.eval(l[k]);
                assert!(
                    (four[k] - one).abs() <= 1e-6 * one.abs().max(1.0),
                    "{s:?} at {}: {} vs {one}",
                    l[k],
                    four[k]
                );
            }
        }
    }

    /// Scans 360–830 nm in 0.1 nm steps: nothing may exceed `max_value`, and when `tight`
    /// the scan must reach it.
    fn check_bound(s: &Spectrum, tight: bool) {
        let m = s.max_value();
        let mut best = f32::MIN;
        for i in 0..=4700 {
            let l = LAMBDA_MIN + i as f32 * 0.1;
            let v = s.eval(l);
            assert!(v <= m * (1.0 + 1e-5), "{s:?}: {v} at {l} exceeds bound {m}");
            best = best.max(v);
        }
        if tight {
            assert!(
                best >= m * (1.0 - 1e-3),
                "{s:?}: bound {m} is loose ({best})"
            );
        }
    }

    #[test]
    fn max_value_bounds_every_kind() {
        let t = Tabulated::new(vec![300.0, 500.0, 900.0], vec![5.0, 1.0, 7.0]).unwrap();
        let kinds = [
            Spectrum::Constant(0.3),
            Spectrum::Tabulated(t.clone()),
            Spectrum::Tabulated(t.clone()).scaled(2.0),
            Spectrum::blackbody(2000.0, false).unwrap(), // peak at 1449 nm: out of range
            Spectrum::blackbody(5000.0, true).unwrap(),
            Spectrum::blackbody(20000.0, false).unwrap(), // peak at 145 nm: out of range
            Spectrum::narrow_band(600.0, 10.0).unwrap(),
            Spectrum::narrow_band(300.0, 100.0).unwrap(),
            // A hump (vertex inside the range), a rising and a falling sigmoid.
            Spectrum::Rgb(RgbSpectrum {
                coeffs: [-30.0, 25.0, -4.0],
                scale: 1.5,
                illuminant: false,
            }),
            Spectrum::Rgb(RgbSpectrum {
                coeffs: [2.0, 3.0, -2.0],
                scale: 1.0,
                illuminant: false,
            }),
            Spectrum::Rgb(RgbSpectrum {
                coeffs: [0.0, -8.0, 3.0],
                scale: 2.0,
                illuminant: false,
            }),
        ];
        for s in &kinds {
            check_bound(s, true);
        }
        check_bound(
            &Spectrum::Rgb(RgbSpectrum {
                coeffs: [-30.0, 25.0, -4.0],
                scale: 1.5,
                illuminant: true,
            }),
            false,
        );
        check_bound(&Spectrum::Tabulated(t).scaled(-2.0), false);
    }

    #[test]
    fn normalised_blackbody_peaks_at_one() {
        let s = Spectrum::blackbody(5000.0, true).unwrap();
        assert!((s.eval(peak_wavelength(5000.0)) - 1.0).abs() < 1e-6);
        assert!((s.max_value() - 1.0).abs() < 1e-6);
    }

    /// Scaling multiplies whatever the spectrum is, nested scales and RGB included.
    #[test]
    fn scaling_multiplies_every_kind_and_folds_nested_scales() {
        let band = Spectrum::narrow_band(500.0, 20.0).unwrap();
        let rgb = Spectrum::Rgb(RgbSpectrum {
            coeffs: [-30.0, 25.0, -4.0],
            scale: 1.5,
            illuminant: false,
        });
        for s in [band.clone(), band.scaled(2.0), rgb.clone(), rgb.scaled(2.0)] {
            for factor in [3.0, 0.25] {
                let scaled = s.clone().scaled(factor);
                for l in [450.0, 500.0, 620.0] {
                    let (got, want) = (scaled.eval(l), factor * s.eval(l));
                    assert!(
                        (got - want).abs() <= 1e-6 * want.abs(),
                        "{s:?} x {factor} at {l}: {got} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn constants_are_recognised() {
        assert_eq!(Spectrum::Constant(2.0).scaled(3.0).is_constant(), Some(6.0));
        let s = Spectrum::Scaled(Box::new(Spectrum::Constant(2.0)), 0.5);
        assert_eq!(s.is_constant(), Some(1.0));
        assert_eq!(
            Spectrum::narrow_band(500.0, 1.0).unwrap().is_constant(),
            None
        );
    }

    #[test]
    fn constructors_reject_bad_parameters() {
        assert!(Spectrum::blackbody(0.0, true).is_err());
        assert!(Spectrum::blackbody(f32::NAN, true).is_err());
        assert!(Spectrum::narrow_band(500.0, 0.0).is_err());
        assert!(Spectrum::narrow_band(f32::INFINITY, 1.0).is_err());
    }
}
