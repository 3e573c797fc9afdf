//! Spectra as a scene file writes them, and their parser.
//!
//! ```toml
//! reflectance = 0.5                                   # a constant
//! reflectance = "white"                               # a [spectra] entry, or D65, A, F2, F11
//! radiance = { blackbody = 2700 }                     # kelvin; peak 1 unless normalise = false
//! radiance = { illuminant = "D65", scale = 0.3 }      # any kind takes a scale (default 1)
//! reflectance = { csv = "data/cc.csv", column = "red" }   # relative to the scene file
//! reflectance = { wavelengths = [400, 500, 600], values = [0.1, 0.5, 0.2] }
//! reflectance = { exr = "data/swatch.exr" }          # a spectral OpenEXR (T.<λ>nm or S0.<λ>nm)
//! radiance = { narrow_band = 440, fwhm = 10 }         # a Gaussian line of unit integral
//! reflectance = { rgb = [0.8, 0.2, 0.1] }             # linear sRGB as a smooth spectrum
//! radiance = { rgb = [1, 0.9, 0.7], scale = 5 }       # an emitter's colour (× D65, Y = 1)
//! ```
//!
//! An `rgb` becomes a sigmoid-polynomial spectrum ([`super::upsample`]) whose use follows
//! the key it is given at: a reflectance (`Range::Unit`) is an albedo, each channel in
//! [0, 1]; a radiance an illuminant (the colour times D65 of luminance 1, so `[1, 1, 1]`
//! is as bright as a constant 1); anything else (`[spectra]` entries, coefficients) an
//! unbounded multiple of a reflectance. `rgb_use = "albedo" | "unbounded" | "illuminant"`
//! overrides the choice.
//!
//! `[spectra]` entries may name other entries (resolved in dependency order by the scene
//! loader); every use of a spectrum says which values it takes ([`Range`]).

use super::{blackbody_peak_value, csv_column, illuminant, RgbSpectrum, Spectrum, Tabulated};
use super::{LAMBDA_MAX, LAMBDA_MIN};
use crate::error::{Key, KeyError};
use crate::scene::Context;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use std::fmt;

/// A spectrum as written: a number (constant), a string (a name from `[spectra]` or a CIE
/// illuminant `D65`, `A`, `F2`, `F11`), or a table with exactly one kind of key.
#[derive(Debug, Clone)]
pub enum SpectrumDesc {
    /// `0.5`
    Constant(f64),
    /// `"white"` or `"D65"`
    Name(String),
    /// `{ ... }` (boxed: it is much larger than the other forms)
    Table(Box<SpectrumTable>),
}

/// The table form of a spectrum; exactly one of the kinds must be given.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpectrumTable {
    /// `{ constant = 0.5 }`
    pub constant: Option<f32>,
    /// `{ blackbody = 6500 }` in kelvin, normalised to a peak of 1 unless `normalise = false`.
    pub blackbody: Option<f32>,
    /// With `blackbody`: divide by the peak (default true).
    pub normalise: Option<bool>,
    /// `{ illuminant = "D65" }`
    pub illuminant: Option<String>,
    /// `{ csv = "file.csv", column = "white" }` (path relative to the scene file).
    pub csv: Option<String>,
    /// With `csv`: the column's header name (needed when the file has several).
    pub column: Option<String>,
    /// `{ exr = "file.exr" }`: a spectral OpenEXR image (path relative to the scene file),
    /// its reflective channels `T.<λ>nm` or else its emissive `S0.<λ>nm`, each averaged
    /// over the pixels ([`crate::spectral_exr::spectrum`]).
    pub exr: Option<String>,
    /// `{ wavelengths = [...], values = [...] }`, linear between, zero outside.
    pub wavelengths: Option<Vec<f32>>,
    /// With `wavelengths`.
    pub values: Option<Vec<f32>>,
    /// `{ narrow_band = 440, fwhm = 10 }`: a Gaussian band of unit integral (nm).
    pub narrow_band: Option<f32>,
    /// With `narrow_band`: full width at half maximum in nm.
    pub fwhm: Option<f32>,
    /// `{ rgb = [r, g, b] }`: linear sRGB, upsampled to a smooth spectrum.
    pub rgb: Option<Vec<f32>>,
    /// With `rgb`: "albedo", "unbounded" or "illuminant" instead of what the key implies.
    pub rgb_use: Option<String>,
    /// `{ texture = "paper.png" }`: an image texture ([`crate::texture`]), only where a
    /// material takes a texture (a diffuse reflectance).
    pub texture: Option<String>,
    /// With `texture`: "repeat" (default), "clamp" or "mirror".
    pub wrap: Option<String>,
    /// `{ checkerboard = [a, b] }`: two spectra in alternating squares, where a material
    /// takes a texture.
    pub checkerboard: Option<Vec<SpectrumDesc>>,
    /// With `checkerboard`: squares per unit of u and v (default [8, 8]).
    pub checks: Option<[f32; 2]>,
    /// Multiplies any of the above (default 1).
    pub scale: Option<f32>,
}

impl<'de> Deserialize<'de> for SpectrumDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = SpectrumDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a spectrum: a number, a name, or a table such as { csv = \"file.csv\" }",
                )
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Self::Value, E> {
                Ok(SpectrumDesc::Constant(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Self::Value, E> {
                Ok(SpectrumDesc::Constant(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Self::Value, E> {
                Ok(SpectrumDesc::Constant(v as f64))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
                Ok(SpectrumDesc::Name(v.to_string()))
            }
            fn visit_map<M: MapAccess<'de>>(self, m: M) -> Result<Self::Value, M::Error> {
                SpectrumTable::deserialize(de::value::MapAccessDeserializer::new(m))
                    .map(|t| SpectrumDesc::Table(Box::new(t)))
            }
        }
        d.deserialize_any(V)
    }
}

/// Which values a spectrum may take where it is used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Range {
    /// A reflectance or albedo: [0, 1].
    Unit,
    /// An emitter's radiance: ≥ 0.
    Radiance,
    /// A coefficient or emission shape: ≥ 0.
    NonNegative,
}

impl Spectrum {
    /// The spectrum `desc` at `key`, checked against `range` (`None`: any finite values,
    /// for `[spectra]` entries, which are checked where they are used).
    pub fn from_desc(
        desc: &SpectrumDesc,
        key: &Key,
        ctx: &Context,
        range: Option<Range>,
    ) -> Result<Spectrum, KeyError> {
        let spec = match desc {
            SpectrumDesc::Constant(v) => Spectrum::Constant(*v as f32),
            SpectrumDesc::Name(n) => match ctx.named(n).cloned().or_else(|| illuminant(n)) {
                Some(s) => s,
                None => {
                    return Err(key.error(format!(
                        "no spectrum named {n:?} (named spectra: {}; illuminants: D65, A, F2, F11)",
                        ctx.spectrum_names()
                    )))
                }
            },
            SpectrumDesc::Table(t) => from_table(t, key, ctx, range)?,
        };
        if let Some(range) = range {
            check_range(key, &spec, range)?;
        }
        Ok(spec)
    }
}

/// [`Spectrum::from_desc`] of the table form.
fn from_table(
    t: &SpectrumTable,
    key: &Key,
    ctx: &Context,
    range: Option<Range>,
) -> Result<Spectrum, KeyError> {
    let kinds = [
        ("constant", t.constant.is_some()),
        ("blackbody", t.blackbody.is_some()),
        ("illuminant", t.illuminant.is_some()),
        ("csv", t.csv.is_some()),
        ("exr", t.exr.is_some()),
        ("wavelengths", t.wavelengths.is_some()),
        ("narrow_band", t.narrow_band.is_some()),
        ("rgb", t.rgb.is_some()),
    ];
    if t.texture.is_some() || t.checkerboard.is_some() {
        return Err(key.error(
            "a texture here: only a diffuse, fluorescent diffuse or mirror material's `reflectance` takes a texture or checkerboard (numbers: `fluorescence`, `roughness`)",
        ));
    }
    let given: Vec<&str> = kinds.iter().filter(|k| k.1).map(|k| k.0).collect();
    if given.len() != 1 {
        return Err(key.error(format!(
            "expected exactly one of constant, blackbody, illuminant, csv, exr, wavelengths, narrow_band, rgb; found {}",
            if given.is_empty() { "none".to_string() } else { given.join(", ") }
        )));
    }
    let stray = |k: &str, present: bool, with: &str| -> Result<(), KeyError> {
        if present && given[0] != with {
            Err(key
                .field(k)
                .error(format!("only allowed together with `{with}`")))
        } else {
            Ok(())
        }
    };
    stray("normalise", t.normalise.is_some(), "blackbody")?;
    stray("column", t.column.is_some(), "csv")?;
    stray("values", t.values.is_some(), "wavelengths")?;
    stray("fwhm", t.fwhm.is_some(), "narrow_band")?;
    stray("rgb_use", t.rgb_use.is_some(), "rgb")?;
    let spec = match given[0] {
        "constant" => Spectrum::Constant(t.constant.unwrap_or(0.0)),
        "blackbody" => blackbody(t, &key.field("blackbody"))?,
        "illuminant" => {
            let n = t.illuminant.as_deref().unwrap_or("");
            illuminant(n).ok_or_else(|| {
                key.field("illuminant")
                    .expected("one of D65, A, F2, F11", format!("{n:?}"))
            })?
        }
        "csv" => {
            let file = t.csv.as_deref().unwrap_or("");
            let tab = csv_column(&ctx.resolve(file), t.column.as_deref())
                .map_err(|e| key.field("csv").error(e))?;
            Spectrum::Tabulated(tab)
        }
        "exr" => {
            let file = t.exr.as_deref().unwrap_or("");
            let tab = crate::spectral_exr::spectrum(&ctx.resolve(file))
                .map_err(|e| key.field("exr").error(e))?;
            Spectrum::Tabulated(tab)
        }
        "wavelengths" => {
            let w = t.wavelengths.clone().unwrap_or_default();
            let v = t
                .values
                .clone()
                .ok_or_else(|| key.error("missing key `values` next to `wavelengths`"))?;
            Spectrum::Tabulated(Tabulated::new(w, v).map_err(|e| key.error(e))?)
        }
        "narrow_band" => {
            let c = t.narrow_band.unwrap_or(0.0);
            let w = t
                .fwhm
                .ok_or_else(|| key.error("missing key `fwhm` next to `narrow_band`"))?;
            if !(c.is_finite() && c > 0.0 && w.is_finite() && w > 0.0) {
                return Err(key.expected(
                    "a positive centre and full width at half maximum (nm)",
                    format!("{c} and {w}"),
                ));
            }
            Spectrum::NarrowBand { centre: c, fwhm: w }
        }
        "rgb" => rgb(t, key, range)?,
        _ => unreachable!("one kind was given"),
    };
    Ok(match t.scale {
        Some(s) if !(s.is_finite() && s >= 0.0) => {
            return Err(key.field("scale").expected("a non-negative number", s))
        }
        Some(s) if s != 1.0 => Spectrum::Scaled(Box::new(spec), s),
        _ => spec,
    })
}

/// How an `rgb` becomes a spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RgbUse {
    Albedo,
    Unbounded,
    Illuminant,
}

/// `{ rgb = [r, g, b], rgb_use = … }`: three finite non-negative channels (each ≤ 1 for an
/// albedo), upsampled as the range (or `rgb_use`) says.
fn rgb(t: &SpectrumTable, key: &Key, range: Option<Range>) -> Result<Spectrum, KeyError> {
    let use_ = match t.rgb_use.as_deref() {
        None => match range {
            Some(Range::Unit) => RgbUse::Albedo,
            Some(Range::Radiance) => RgbUse::Illuminant,
            Some(Range::NonNegative) | None => RgbUse::Unbounded,
        },
        Some("albedo") => RgbUse::Albedo,
        Some("unbounded") => RgbUse::Unbounded,
        Some("illuminant") => RgbUse::Illuminant,
        Some(other) => {
            return Err(key.field("rgb_use").expected(
                "one of \"albedo\", \"unbounded\", \"illuminant\"",
                format!("{other:?}"),
            ))
        }
    };
    let k = key.field("rgb");
    let c = t.rgb.as_deref().unwrap_or_default();
    let list = |c: &[f32]| {
        let v: Vec<String> = c.iter().map(|x| x.to_string()).collect();
        format!("[{}]", v.join(", "))
    };
    let &[r, g, b] = c else {
        return Err(k.expected(
            "three channels [r, g, b] (linear sRGB)",
            format!("{} entries {}", c.len(), list(c)),
        ));
    };
    if !c.iter().all(|v| v.is_finite() && *v >= 0.0) {
        return Err(k.expected("finite non-negative channels", list(c)));
    }
    if use_ == RgbUse::Albedo && c.iter().any(|&v| v > 1.0) {
        return Err(k.expected("each channel in [0, 1] (a reflectance)", list(c)));
    }
    let rgb = [r, g, b];
    Ok(Spectrum::Rgb(match use_ {
        RgbUse::Albedo => RgbSpectrum::albedo(rgb),
        RgbUse::Unbounded => RgbSpectrum::unbounded(rgb),
        RgbUse::Illuminant => RgbSpectrum::illuminant(rgb),
    }))
}

/// `{ blackbody = K, normalise = … }`, with a temperature whose peak can normalise it.
fn blackbody(t: &SpectrumTable, key: &Key) -> Result<Spectrum, KeyError> {
    let k = t.blackbody.unwrap_or(0.0);
    if !(k.is_finite() && k > 0.0) {
        return Err(key.expected("a temperature in kelvin > 0", k));
    }
    let normalise = t.normalise.unwrap_or(true);
    let peak = blackbody_peak_value(k);
    if normalise && !(peak.is_finite() && peak > 0.0) {
        return Err(key.expected(
            "a temperature whose peak radiance, which normalises it, is a finite non-zero 32-bit number",
            format!("{k:e} K (peak {peak:e} W·sr⁻¹·m⁻²·nm⁻¹)"),
        ));
    }
    Ok(Spectrum::Blackbody {
        kelvin: k,
        normalise,
    })
}

/// Checks the values of `spec` against `range`: on a 1 nm grid over the rendered range
/// (tabulated data is checked where it matters: the wavelengths the renderer samples),
/// and at its analytic maximum, which a band narrower than 1 nm cannot hide.
fn check_range(key: &Key, spec: &Spectrum, range: Range) -> Result<(), KeyError> {
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    let mut at = (0.0, 0.0);
    for i in 0..=(LAMBDA_MAX - LAMBDA_MIN) as u32 {
        let l = LAMBDA_MIN + i as f32;
        let v = spec.eval(l);
        if !v.is_finite() {
            return Err(key.expected("finite values", format!("{v} at {l} nm")));
        }
        if v < lo {
            lo = v;
            at.0 = l;
        }
        if v > hi {
            hi = v;
            at.1 = l;
        }
    }
    let max = spec.max_value();
    if !max.is_finite() {
        return Err(key.expected("finite values", format!("a maximum of {max}")));
    }
    if max > hi {
        hi = max;
        at.1 = f32::NAN;
    }
    if lo < 0.0 {
        let what = match range {
            Range::Unit => "a reflectance in [0, 1]",
            Range::Radiance => "a non-negative radiance",
            Range::NonNegative => "non-negative values",
        };
        return Err(key.expected(what, format!("{lo} at {} nm", at.0)));
    }
    if range == Range::Unit && hi > 1.0 + 1e-6 {
        let at = if at.1.is_nan() {
            "as its maximum".to_string()
        } else {
            format!("at {} nm", at.1)
        };
        return Err(key.expected(
            "a reflectance in [0, 1]",
            format!("{hi} {at} (energy would be created)"),
        ));
    }
    Ok(())
}
