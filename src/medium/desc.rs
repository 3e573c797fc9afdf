//! Media as a scene file writes them (`[media.NAME]`), and their parser. The syntax is in
//! the [module documentation](super).

use super::{HenyeyGreenstein, Homogeneous};
use crate::error::{Key, KeyError};
use crate::fluoro::{self, Reradiation};
use crate::scene::Context;
use crate::spectrum::{Range, Spectrum, SpectrumDesc};
use serde::Deserialize;

/// A homogeneous participating medium: σ_a and σ_s (per scene unit), or albedo and σ_t;
/// a Henyey–Greenstein phase function; optionally a fluorescent dye or a re-radiation
/// matrix.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumDesc {
    /// Absorption coefficient.
    pub sigma_a: Option<SpectrumDesc>,
    /// Scattering coefficient.
    pub sigma_s: Option<SpectrumDesc>,
    /// Single-scattering albedo (with `sigma_t`).
    pub albedo: Option<SpectrumDesc>,
    /// Extinction coefficient (with `albedo`).
    pub sigma_t: Option<SpectrumDesc>,
    /// Henyey–Greenstein asymmetry in (−1, 1) (default 0, isotropic).
    pub g: Option<f32>,
    /// A fluorescent dye dissolved in the medium.
    pub dye: Option<MediumDyeDesc>,
    /// A general re-radiation matrix (instead of a dye).
    pub matrix: Option<MediumMatrixDesc>,
}

/// A medium's re-radiation matrix: a file as a `fluorescent_diffuse` material's `matrix`
/// reads it (CSV, BFC or bispectral OpenEXR; entries are fractions per cell), times
/// `scale` per scene unit.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumMatrixDesc {
    /// The matrix file, relative to the scene file.
    pub file: String,
    /// The coefficient per scene unit that multiplies the file's entries.
    pub scale: f32,
}

/// A fluorescent dye in a medium: its absorption coefficient is
/// `absorption × concentration` (per scene unit).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumDyeDesc {
    /// Absorption spectrum (per scene unit at concentration 1).
    pub absorption: SpectrumDesc,
    /// Multiplies `absorption` (default 1).
    pub concentration: Option<f32>,
    /// Shape of the emission spectrum (normalised by the renderer).
    pub emission: SpectrumDesc,
    /// Fraction of the absorbed light re-emitted, in [0, 1].
    pub quantum_yield: f32,
    /// Width of the re-radiation grid's cells in nm (default 2).
    pub cell_nm: Option<f32>,
}

/// The largest coefficient σ_a, σ_s, σ_t or σ_dye of a medium (per scene unit): a mean
/// free path of 10⁻³⁰ scene units is opaque at any scale 32-bit positions resolve, and
/// beyond it sums of coefficients (σ̂_t = σ_a + σ_s + σ_dye) and σ × distance overflow.
pub const MAX_COEFFICIENT: f32 = 1e30;

/// Checks a coefficient at `key` against [`MAX_COEFFICIENT`].
fn check_density(key: &Key, s: &Spectrum) -> Result<(), KeyError> {
    let max = s.max_value();
    if max > MAX_COEFFICIENT {
        return Err(key.expected(
            format!("a coefficient ≤ {MAX_COEFFICIENT:e} per scene unit (denser is opaque at any scale and overflows 32-bit floats)"),
            format!("a maximum of {max:e}"),
        ));
    }
    Ok(())
}

impl Homogeneous {
    /// The medium `m`, `[media.NAME]` at `key`.
    pub fn from_desc(
        m: &MediumDesc,
        key: &Key,
        ctx: &mut Context,
    ) -> Result<Homogeneous, KeyError> {
        let coefficient = |k: &str, s: &SpectrumDesc| {
            Spectrum::from_desc(s, &key.field(k), ctx, Some(Range::NonNegative))
        };
        let (sigma_a, sigma_s) = match (&m.sigma_a, &m.sigma_s, &m.albedo, &m.sigma_t) {
            (a, s, None, None) => {
                let or_zero = |k: &str, d: &Option<SpectrumDesc>| {
                    d.as_ref()
                        .map(|d| coefficient(k, d))
                        .transpose()
                        .map(|s| s.unwrap_or(Spectrum::Constant(0.0)))
                };
                let (sa, ss) = (or_zero("sigma_a", a)?, or_zero("sigma_s", s)?);
                check_density(&key.field("sigma_a"), &sa)?;
                check_density(&key.field("sigma_s"), &ss)?;
                (sa, ss)
            }
            (None, None, Some(al), Some(t)) => {
                let albedo = Spectrum::from_desc(al, &key.field("albedo"), ctx, Some(Range::Unit))?;
                let sigma_t = coefficient("sigma_t", t)?;
                let combine = |f: fn(f32, f32) -> f32| {
                    Spectrum::combine(&albedo, &sigma_t, f).map_err(|e| key.error(e))
                };
                let sa = combine(|al, st| (1.0 - al) * st)?;
                let ss = combine(|al, st| al * st)?;
                let st = Spectrum::combine(&sa, &ss, |a, s| a + s).map_err(|e| key.error(e))?;
                check_density(&key.field("sigma_t"), &st)?;
                (sa, ss)
            }
            _ => {
                return Err(key.error(
                    "expected `sigma_a` and/or `sigma_s`, or `albedo` together with `sigma_t`",
                ))
            }
        };
        let g = m.g.unwrap_or(0.0);
        if !(g.is_finite() && g > -1.0 && g < 1.0) {
            return Err(key.field("g").expected("a number in (−1, 1)", g));
        }
        let medium = Homogeneous::new(sigma_a, sigma_s, HenyeyGreenstein::new(g));
        match (&m.dye, &m.matrix) {
            (None, None) => Ok(medium),
            (Some(d), None) => with_dye(medium, d, &key.field("dye"), ctx),
            (None, Some(x)) => with_matrix(medium, x, &key.field("matrix"), ctx),
            (Some(_), Some(_)) => Err(key.error(
                "expected at most one of `dye = { ... }` and `matrix = { file = ..., scale = ... }`",
            )),
        }
    }
}

/// `medium` re-radiating with the matrix `x` (at `key`).
fn with_matrix(
    medium: Homogeneous,
    x: &MediumMatrixDesc,
    key: &Key,
    ctx: &mut Context,
) -> Result<Homogeneous, KeyError> {
    let path = ctx.resolve(&x.file);
    let file = key.field("file");
    let (rr, report) = Reradiation::from_file(&path).map_err(|e| file.error(e))?;
    if !report.is_clean() {
        ctx.warn(&file, format!("{}: {report}", path.display()));
    }
    let scale = key.field("scale");
    if !(x.scale.is_finite() && x.scale > 0.0) {
        return Err(scale.expected("a positive coefficient per scene unit", x.scale));
    }
    let peak = (0..rr.cells())
        .map(|k| rr.sigma_sa(rr.cell_centre(k)))
        .fold(0.0f32, f32::max);
    if f64::from(peak) * f64::from(x.scale) > f64::from(MAX_COEFFICIENT) {
        return Err(scale.expected(
            format!("scale × the largest row sum ≤ {MAX_COEFFICIENT:e} per scene unit (denser is opaque at any scale and overflows 32-bit floats)"),
            format!("{:e} × {peak:e}", x.scale),
        ));
    }
    let diagonal = rr.diagonal().max_value();
    if diagonal > 0.0 {
        ctx.warn(
            key,
            format!("{}: the diagonal (up to {diagonal}) is not used in a medium; elastic scattering is `sigma_s`", path.display()),
        );
    }
    medium.with_matrix(rr, x.scale).map_err(|e| file.error(e))
}

/// `medium` with the dye `d` (at `dye`) dissolved in it.
fn with_dye(
    medium: Homogeneous,
    d: &MediumDyeDesc,
    dye: &Key,
    ctx: &Context,
) -> Result<Homogeneous, KeyError> {
    let a = Spectrum::from_desc(
        &d.absorption,
        &dye.field("absorption"),
        ctx,
        Some(Range::NonNegative),
    )?;
    let e = Spectrum::from_desc(
        &d.emission,
        &dye.field("emission"),
        ctx,
        Some(Range::NonNegative),
    )?;
    let c = d.concentration.unwrap_or(1.0);
    if !(c.is_finite() && c > 0.0) {
        // Zero too: a dye at zero concentration does nothing (like one that absorbs
        // nothing, which `Reradiation::from_dye` rejects).
        return Err(dye.field("concentration").expected("a positive number", c));
    }
    if c * a.max_value() > MAX_COEFFICIENT {
        let peak = f64::from(c) * f64::from(a.max_value());
        let k = if c == 1.0 {
            "absorption"
        } else {
            "concentration"
        };
        return Err(dye.field(k).expected(
            format!("concentration × absorption ≤ {MAX_COEFFICIENT:e} per scene unit (denser is opaque at any scale and overflows 32-bit floats)"),
            format!("{c:e} × {:e} = {peak:.3e}", a.max_value()),
        ));
    }
    let cell = fluoro::dye_cell_width(dye, d.quantum_yield, d.cell_nm)?;
    let absorption = if c == 1.0 {
        a
    } else {
        Spectrum::Scaled(Box::new(a), c)
    };
    medium
        .with_dye(&absorption, &e, d.quantum_yield, cell)
        .map_err(|e| dye.error(e))
}
