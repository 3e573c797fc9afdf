//! Materials as a scene file writes them (`[materials.NAME]`), and their parser. The
//! syntax of every kind is in the [module documentation](super).

use super::{albedo, metals, CoatBase, Coated, Ior, Material, MIN_ALPHA};
use crate::error::{Key, KeyError};
use crate::fluoro::map::FluorescenceMap;
use crate::fluoro::{self, Reradiation};
use crate::scene::context::reject_keys;
use crate::scene::Context;
use crate::spectrum::{Range, Spectrum, SpectrumDesc, LAMBDA_MAX, LAMBDA_MIN};
use crate::texture::scalar::{ScalarDesc, ScalarTexture};
use crate::texture::{ImageTexture, Texture, Wrap};
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use std::fmt;
use std::sync::Arc;

/// A material; `type` selects the model.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialDesc {
    /// `diffuse`, `mirror`, `dielectric` or `fluorescent_diffuse`.
    #[serde(rename = "type")]
    pub kind: String,
    /// `diffuse` (required), `mirror` (default 1), `fluorescent_diffuse` (the diagonal):
    /// spectral reflectance in [0, 1].
    pub reflectance: Option<SpectrumDesc>,
    /// `dielectric`: interior index of refraction.
    pub ior: Option<IorDesc>,
    /// `dielectric`: exterior index (default 1).
    pub ext_ior: Option<f32>,
    /// `fluorescent_diffuse`: a parametric dye.
    pub dye: Option<DyeDesc>,
    /// `fluorescent_diffuse`: a measured re-radiation matrix (CSV grid or a Labsphere
    /// BFC-450 file).
    pub matrix: Option<String>,
    /// `fluorescent_diffuse`: the dye strength in [0, 1] (default 1), a number or a map
    /// ([`crate::texture::scalar`], [`crate::fluoro::map`]).
    pub fluorescence: Option<ScalarDesc>,
    /// `conductor`, `dielectric`: GGX width α in [0, 1] (0: smooth), or `[αu, αv]`;
    /// `coated`: the coat's (isotropic) width.
    pub roughness: Option<RoughnessDesc>,
    /// `conductor`: a shipped metal's symbol (`"Au"`, `"Ag"`, `"Cu"`, `"Al"`).
    pub metal: Option<String>,
    /// `conductor`: real part of the index of refraction (> 0), instead of `metal`.
    pub eta: Option<SpectrumDesc>,
    /// `conductor`: extinction coefficient (≥ 0), with `eta`.
    pub k: Option<SpectrumDesc>,
    /// `coated`: the material under the coat (inline: a diffuse, fluorescent_diffuse or
    /// conductor).
    pub base: Option<Box<MaterialDesc>>,
    /// `coated`: the coat's absorption coefficient σ_a per scene unit (default 0).
    pub absorption: Option<SpectrumDesc>,
    /// `coated`: the coat's thickness in scene units (needed with `absorption`).
    pub thickness: Option<f32>,
}

/// A GGX roughness: `0.2` (isotropic), `[0.1, 0.4]` (along the two tangents), or an
/// isotropic map `{ texture = "rough.png" }` ([`ScalarTexture`]).
#[derive(Debug, Clone)]
pub enum RoughnessDesc {
    /// α on both axes.
    Isotropic(f64),
    /// α along the first and the second tangent.
    Anisotropic([f64; 2]),
    /// α on both axes, varying over the surface.
    Map(ScalarDesc),
}

impl<'de> Deserialize<'de> for RoughnessDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RoughnessDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a GGX width α, a pair [αu, αv], or a map such as { texture = \"rough.png\" }",
                )
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RoughnessDesc, E> {
                Ok(RoughnessDesc::Isotropic(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RoughnessDesc, E> {
                Ok(RoughnessDesc::Isotropic(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RoughnessDesc, E> {
                Ok(RoughnessDesc::Isotropic(v as f64))
            }
            fn visit_seq<A: de::SeqAccess<'de>>(self, seq: A) -> Result<RoughnessDesc, A::Error> {
                let pair = <[f64; 2]>::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
                Ok(RoughnessDesc::Anisotropic(pair))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RoughnessDesc, A::Error> {
                let d = ScalarDesc::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(RoughnessDesc::Map(d))
            }
        }
        d.deserialize_any(V)
    }
}

impl RoughnessDesc {
    /// The widths, each 0 (smooth) or in [[`MIN_ALPHA`], 1]; both 0 or neither.
    fn alpha(&self, key: &Key) -> Result<[f32; 2], KeyError> {
        let a = match *self {
            RoughnessDesc::Isotropic(a) => [a, a],
            RoughnessDesc::Anisotropic(a) => a,
            // The map's own widths are checked by [`Self::map`]; the nominal one is rough.
            RoughnessDesc::Map(_) => return Ok([1.0; 2]),
        };
        let ok = |x: f64| x == 0.0 || (MIN_ALPHA..=1.0).contains(&(x as f32));
        if !(a.iter().all(|&x| ok(x)) && (a[0] == 0.0) == (a[1] == 0.0)) {
            return Err(key.expected(
                format!("0 (smooth) or a GGX width in [{MIN_ALPHA}, 1] (both axes smooth or both rough)"),
                format!("{a:?}"),
            ));
        }
        Ok(a.map(|x| x as f32))
    }

    /// The roughness map, if it is one: α per texel in [0, 1], looked up no smaller than
    /// [`MIN_ALPHA`] ([`super::Material::alpha_at`]).
    fn map(&self, key: &Key, ctx: &Context) -> Result<Option<Arc<ScalarTexture>>, KeyError> {
        let RoughnessDesc::Map(d) = self else {
            return Ok(None);
        };
        let map = ScalarTexture::from_desc(d, key, ctx, 0.0..=1.0, "GGX width")?;
        Ok(Some(Arc::new(map)))
    }
}

/// A fluorescent dye on a surface:
/// `dye = { absorption = SPECTRUM, emission = SPECTRUM, quantum_yield = 0.9 }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DyeDesc {
    /// Fraction of the light absorbed by the dye, in [0, 1].
    pub absorption: SpectrumDesc,
    /// Shape of the emission spectrum (normalised by the renderer).
    pub emission: SpectrumDesc,
    /// Fraction of the absorbed light re-emitted, in [0, 1].
    pub quantum_yield: f32,
    /// Width of the re-radiation grid's cells in nm (default 2).
    pub cell_nm: Option<f32>,
}

/// An index of refraction: `1.5`, `{ cauchy = [A, B] }` (n = A + B/λ², λ in nm) or
/// `{ sellmeier = { b = [B1, B2, B3], c = [C1, C2, C3] } }` (n² = 1 + Σ Bᵢλ²/(λ² − Cᵢ),
/// λ in µm, Cᵢ in µm²).
#[derive(Debug, Clone)]
pub enum IorDesc {
    /// A constant index.
    Constant(f64),
    /// A table with `cauchy` or `sellmeier`.
    Table(IorTable),
}

/// The table form of an index of refraction.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IorTable {
    /// `[A, B]` with B in nm².
    pub cauchy: Option<[f32; 2]>,
    /// Sellmeier coefficients.
    pub sellmeier: Option<SellmeierDesc>,
}

/// Sellmeier coefficients (three terms).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SellmeierDesc {
    /// B₁, B₂, B₃.
    pub b: [f32; 3],
    /// C₁, C₂, C₃ in µm².
    pub c: [f32; 3],
}

impl<'de> Deserialize<'de> for IorDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = IorDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an index of refraction: a number, { cauchy = [A, B] } or { sellmeier = { b = [..], c = [..] } }")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Self::Value, E> {
                Ok(IorDesc::Constant(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Self::Value, E> {
                Ok(IorDesc::Constant(v as f64))
            }
            fn visit_map<M: MapAccess<'de>>(self, m: M) -> Result<Self::Value, M::Error> {
                IorTable::deserialize(de::value::MapAccessDeserializer::new(m)).map(IorDesc::Table)
            }
        }
        d.deserialize_any(V)
    }
}

impl Ior {
    /// The index `d` at `key`, which must be ≥ 1 over the rendered range.
    pub fn from_desc(d: &IorDesc, key: &Key) -> Result<Ior, KeyError> {
        let ior = match d {
            IorDesc::Constant(n) => Ior::Constant(*n as f32),
            IorDesc::Table(t) => match (&t.cauchy, &t.sellmeier) {
                (Some([a, b]), None) => Ior::Cauchy { a: *a, b: *b },
                (None, Some(s)) => Ior::Sellmeier { b: s.b, c: s.c },
                _ => {
                    return Err(key.error(
                        "expected exactly one of `cauchy = [A, B]` or `sellmeier = { b = [..], c = [..] }`",
                    ))
                }
            },
        };
        for l in [LAMBDA_MIN, 550.0, LAMBDA_MAX] {
            let n = ior.eval(l);
            if !(n.is_finite() && n >= 1.0) {
                return Err(key.expected("an index ≥ 1 over 360–830 nm", format!("{n} at {l} nm")));
            }
        }
        Ok(ior)
    }
}

impl Material {
    /// The material `m`, `[materials.NAME]` at `key`; warnings (clamped matrix entries,
    /// energy gain) go to `ctx`.
    pub fn from_desc(m: &MaterialDesc, key: &Key, ctx: &mut Context) -> Result<Material, KeyError> {
        let kind = m.kind.as_str();
        let reject = |keys: &[(&str, bool)]| reject_keys(key, kind, "material", keys);
        let reflectance = |ctx: &Context, r: &SpectrumDesc| {
            Spectrum::from_desc(r, &key.field("reflectance"), ctx, Some(Range::Unit))
        };
        if kind != "fluorescent_diffuse" {
            reject(&[
                ("dye", m.dye.is_some()),
                ("matrix", m.matrix.is_some()),
                ("fluorescence", m.fluorescence.is_some()),
            ])?;
        }
        if kind != "conductor" {
            reject(&[
                ("metal", m.metal.is_some()),
                ("eta", m.eta.is_some()),
                ("k", m.k.is_some()),
            ])?;
        }
        if !matches!(kind, "conductor" | "dielectric" | "coated") {
            reject(&[("roughness", m.roughness.is_some())])?;
        }
        if kind != "coated" {
            reject(&[
                ("base", m.base.is_some()),
                ("absorption", m.absorption.is_some()),
                ("thickness", m.thickness.is_some()),
            ])?;
        }
        let alpha = match &m.roughness {
            Some(r) => r.alpha(&key.field("roughness"))?,
            None => [0.0; 2],
        };
        let alpha_map = match (&m.roughness, kind) {
            (Some(r), "conductor" | "dielectric") => r.map(&key.field("roughness"), ctx)?,
            (Some(RoughnessDesc::Map(_)), _) => {
                return Err(key.field("roughness").error(
                    "a roughness map on a coat (not supported yet: give the coat one width)",
                ))
            }
            _ => None,
        };
        let ior_keys = [("ior", m.ior.is_some()), ("ext_ior", m.ext_ior.is_some())];
        match kind {
            "coated" => coated(m, key, alpha, ctx),
            "conductor" => {
                reject(&ior_keys)?;
                reject(&[("reflectance", m.reflectance.is_some())])?;
                let (eta, k) = conductor_index(m, key, ctx)?;
                Ok(Material::Conductor {
                    eta,
                    k,
                    alpha,
                    alpha_map,
                })
            }
            "diffuse" => {
                reject(&ior_keys)?;
                let r = m
                    .reflectance
                    .as_ref()
                    .ok_or_else(|| key.error("missing key `reflectance` for a diffuse material"))?;
                let key = key.field("reflectance");
                if let Some(texture) = texture_from_desc(r, &key, ctx)? {
                    return Ok(Material::TexturedDiffuse {
                        texture: Arc::new(texture),
                    });
                }
                Ok(Material::Diffuse {
                    reflectance: reflectance(ctx, r)?,
                })
            }
            "mirror" => {
                reject(&ior_keys)?;
                let reflectance = match &m.reflectance {
                    Some(r) => {
                        if let Some(texture) = texture_from_desc(r, &key.field("reflectance"), ctx)?
                        {
                            return Ok(Material::TexturedMirror {
                                texture: Arc::new(texture),
                            });
                        }
                        reflectance(ctx, r)?
                    }
                    None => Spectrum::Constant(1.0),
                };
                Ok(Material::Mirror { reflectance })
            }
            "dielectric" => {
                reject(&[("reflectance", m.reflectance.is_some())])?;
                let ior = m
                    .ior
                    .as_ref()
                    .ok_or_else(|| key.error("missing key `ior` for a dielectric material"))?;
                let ior = Ior::from_desc(ior, &key.field("ior"))?;
                let ext_ior = m.ext_ior.unwrap_or(1.0);
                if !(ext_ior.is_finite() && ext_ior >= 1.0) {
                    return Err(key.field("ext_ior").expected("a number ≥ 1", ext_ior));
                }
                Ok(match alpha {
                    [0.0, 0.0] => Material::Dielectric { ior, ext_ior },
                    alpha => Material::RoughDielectric {
                        ior,
                        ext_ior,
                        alpha,
                        alpha_map,
                    },
                })
            }
            "fluorescent_diffuse" => fluorescent_diffuse(m, key, ctx),
            other => {
                let names: Vec<String> = KINDS.iter().map(|(k, _)| format!("{k:?}")).collect();
                Err(key
                    .field("type")
                    .expected(format!("one of {}", names.join(", ")), format!("{other:?}")))
            }
        }
    }
}

/// Every material kind (`type = ...`) and the keys it takes, for `stokes info` and the
/// error on an unknown kind.
pub const KINDS: [(&str, &str); 6] = [
    ("diffuse", "reflectance = SPECTRUM in [0, 1]"),
    ("mirror", "reflectance = SPECTRUM in [0, 1] (optional, default 1)"),
    (
        "dielectric",
        "ior = NUMBER | { cauchy = [A, B] } | { sellmeier = { b = [..], c = [..] } } (≥ 1); \
         ext_ior = NUMBER (optional, default 1); roughness = α | [αu, αv] (optional, 0 = smooth, \
         else 0.001–1)",
    ),
    (
        "conductor",
        "metal = \"Au\" | \"Ag\" | \"Cu\" | \"Al\", or eta = SPECTRUM (> 0) and k = SPECTRUM (≥ 0); \
         roughness = α | [αu, αv] (optional, 0 = smooth, else 0.001–1)",
    ),
    (
        "coated",
        "base = { a diffuse, fluorescent_diffuse or conductor material }; ior = index in [1, 3] \
         (optional, default 1.5); roughness = α (optional, 0 = smooth, else 0.001–1); \
         absorption = SPECTRUM (σ_a per scene unit, optional) with thickness = NUMBER",
    ),
    (
        "fluorescent_diffuse",
        "reflectance = SPECTRUM (the diagonal) and dye = { absorption, emission, quantum_yield, \
         cell_nm }, or matrix = \"file.csv\", \"file.BFC\" or \"file.exr\" (a measured matrix, \
         CSV, Labsphere BFC-450 or bispectral OpenEXR; reflectance optional)",
    ),
];

/// The text `stokes info` prints without a scene.
pub fn kinds_help() -> String {
    let mut s = String::from("materials ([materials.NAME] with type = KIND):\n");
    for (kind, keys) in KINDS {
        s.push_str(&format!("  {kind:<20} {keys}\n"));
    }
    s.push_str("spectra: a number, a [spectra] name, D65/A/F2/F11, or a table: see the scene syntax in the README\n");
    s
}

/// A smooth or rough clear coat (GGX width `alpha`, isotropic) over an inline diffuse,
/// fluorescent_diffuse or conductor `base`.
fn coated(
    m: &MaterialDesc,
    key: &Key,
    alpha: [f32; 2],
    ctx: &mut Context,
) -> Result<Material, KeyError> {
    reject_keys(
        key,
        "coated",
        "material",
        &[
            ("reflectance", m.reflectance.is_some()),
            ("ext_ior", m.ext_ior.is_some()),
        ],
    )?;
    if alpha[0] != alpha[1] {
        return Err(key.field("roughness").expected(
            "one GGX width (a coat's roughness is isotropic)",
            format!("{alpha:?}"),
        ));
    }
    let base_key = key.field("base");
    let base = m.base.as_ref().ok_or_else(|| {
        key.error("missing key `base` (the material under the coat) for a coated material")
    })?;
    let mut map = None;
    let base = match Material::from_desc(base, &base_key, ctx)? {
        Material::Diffuse { reflectance } => {
            CoatBase::Lambertian(Arc::new(Reradiation::diagonal_only(reflectance)))
        }
        Material::FluorescentDiffuse {
            reradiation,
            map: m,
        } => {
            map = m;
            CoatBase::Lambertian(reradiation)
        }
        Material::TexturedDiffuse { texture } => {
            // The diagonal comes from the map; the placeholder is never read.
            map = Some(Arc::new(FluorescenceMap {
                diagonal: Some(texture.as_ref().clone()),
                strength: ScalarTexture::Constant(1.0),
            }));
            let none = Reradiation::diagonal_only(Spectrum::Constant(0.0));
            CoatBase::Lambertian(Arc::new(none))
        }
        Material::Conductor {
            eta,
            k,
            alpha,
            alpha_map: None,
        } => CoatBase::Conductor { eta, k, alpha },
        Material::Conductor { .. } => {
            return Err(base_key.field("roughness").error(
                "a roughness map under a coat (not supported yet: give the base one width)",
            ))
        }
        _ => {
            return Err(base_key.field("type").expected(
                "\"diffuse\", \"fluorescent_diffuse\" or \"conductor\" (the coat's models)",
                format!("{:?}", base.kind),
            ))
        }
    };
    let ior = match &m.ior {
        Some(d) => Ior::from_desc(d, &key.field("ior"))?,
        None => Ior::Constant(1.5),
    };
    // A rough coat's albedo table covers indices up to ETA_MAX; check every nm.
    if alpha[0] >= MIN_ALPHA {
        for l in (LAMBDA_MIN as u32..=LAMBDA_MAX as u32).map(|l| l as f32) {
            let n = ior.eval(l);
            if n > albedo::ETA_MAX {
                return Err(key.field("ior").expected(
                    format!("a rough coat's index ≤ {} over 360–830 nm", albedo::ETA_MAX),
                    format!("{n} at {l} nm"),
                ));
            }
        }
    }
    let tau = match (&m.absorption, m.thickness) {
        (None, None) => Spectrum::Constant(0.0),
        (Some(a), Some(d)) => {
            if !(d.is_finite() && d > 0.0) {
                return Err(key.field("thickness").expected("a thickness > 0", d));
            }
            let a =
                Spectrum::from_desc(a, &key.field("absorption"), ctx, Some(Range::NonNegative))?;
            a.scaled(d)
        }
        (Some(_), None) => return Err(key.error("missing key `thickness` next to `absorption`")),
        (None, Some(_)) => {
            return Err(key.error("`thickness` without `absorption` (a clear coat needs neither)"))
        }
    };
    let coated = Coated::new(ior, tau, alpha[0], base);
    Ok(Material::Coated(Arc::new(match map {
        Some(map) => coated.with_map(map),
        None => coated,
    })))
}

/// A conductor's η and k: a shipped `metal`, or `eta` and `k` spectra (η > 0 and k ≥ 0
/// over the rendered range).
fn conductor_index(
    m: &MaterialDesc,
    key: &Key,
    ctx: &Context,
) -> Result<(Spectrum, Spectrum), KeyError> {
    match (&m.metal, &m.eta, &m.k) {
        (Some(name), None, None) => metals::metal(name).ok_or_else(|| {
            key.field("metal")
                .expected(format!("one of {}", metals::symbols()), format!("{name:?}"))
        }),
        (None, Some(eta), Some(k)) => {
            let eta_key = key.field("eta");
            let k_key = key.field("k");
            let eta = Spectrum::from_desc(eta, &eta_key, ctx, None)?;
            let k = Spectrum::from_desc(k, &k_key, ctx, None)?;
            for l in (LAMBDA_MIN as u32..=LAMBDA_MAX as u32).map(|l| l as f32) {
                let (e, kv) = (eta.eval(l), k.eval(l));
                if !(e.is_finite() && e > 0.0) {
                    return Err(eta_key
                        .expected("an index η > 0 over 360–830 nm", format!("{e} at {l} nm")));
                }
                if !(kv.is_finite() && kv >= 0.0) {
                    return Err(k_key.expected(
                        "an extinction coefficient k ≥ 0 over 360–830 nm",
                        format!("{kv} at {l} nm"),
                    ));
                }
            }
            Ok((eta, k))
        }
        _ => Err(key.error(format!(
            "a conductor needs either `metal` (one of {}) or both `eta` and `k`",
            metals::symbols()
        ))),
    }
}

/// A fluorescent_diffuse material: its re-radiation and, with a textured `reflectance` or
/// a `fluorescence` map, where its diagonal and dye strength vary ([`fluoro::map`]).
fn fluorescent_diffuse(
    m: &MaterialDesc,
    key: &Key,
    ctx: &mut Context,
) -> Result<Material, KeyError> {
    reject_keys(
        key,
        "fluorescent_diffuse",
        "material",
        &[("ior", m.ior.is_some()), ("ext_ior", m.ext_ior.is_some())],
    )?;
    let r_key = key.field("reflectance");
    let texture = match &m.reflectance {
        Some(r) => texture_from_desc(r, &r_key, ctx)?,
        None => None,
    };
    let diagonal = match (&m.reflectance, &texture) {
        (Some(r), None) => Some(Spectrum::from_desc(r, &r_key, ctx, Some(Range::Unit))?),
        // The texture gives the diagonal everywhere (the loader gives the shape texture
        // coordinates); the re-radiation's own diagonal is never read.
        (Some(_), Some(_)) => Some(Spectrum::Constant(0.0)),
        (None, _) => None,
    };
    let rr = reradiation(m, key, diagonal, ctx)?;
    let strength = match &m.fluorescence {
        Some(d) => Some(ScalarTexture::from_desc(
            d,
            &key.field("fluorescence"),
            ctx,
            0.0..=1.0,
            "dye strength",
        )?),
        None => None,
    };
    if strength.is_some() && !rr.is_fluorescent() {
        return Err(key
            .field("fluorescence")
            .error("a dye strength map for a material that does not fluoresce (its matrix shifts no light)"));
    }
    let map = match (texture, strength) {
        (None, None) => None,
        (diagonal, strength) => Some(FluorescenceMap {
            diagonal,
            strength: strength.unwrap_or(ScalarTexture::Constant(1.0)),
        }),
    };
    let gains = match &map {
        Some(map) => map.energy_gain_rows(&rr),
        None => rr.energy_gain_rows(),
    };
    if let Some(what) = energy_gain_summary(&gains) {
        ctx.warn(key, what);
    }
    Ok(Material::FluorescentDiffuse {
        reradiation: Arc::new(rr),
        map: map.map(Arc::new),
    })
}

/// One line for the rows (wavelength, total) where re-radiation totals more than 1: how
/// many, their span and the worst. A line per row would bury every other message.
fn energy_gain_summary(gains: &[(f32, f32)]) -> Option<String> {
    let (first, last) = (gains.first()?.0, gains.last()?.0);
    let (at, worst) = gains.iter().fold(
        (first, 0.0f32),
        |w, &(l, t)| if t > w.1 { (l, t) } else { w },
    );
    let span = match gains.len() {
        1 => format!("at {first} nm"),
        n => format!("at {n} wavelengths over {first}–{last} nm"),
    };
    Some(format!(
        "re-radiation totals more than 1 {span}, at most {worst:.3} at {at} nm (the surface creates energy there)"
    ))
}

/// A fluorescent_diffuse material's re-radiation: a parametric dye over the reflectance
/// `diagonal`, or a measured matrix (whose diagonal `reflectance` replaces, if given).
fn reradiation(
    m: &MaterialDesc,
    key: &Key,
    diagonal: Option<Spectrum>,
    ctx: &mut Context,
) -> Result<Reradiation, KeyError> {
    match (&m.dye, &m.matrix) {
        (Some(d), None) => {
            let diagonal = diagonal.ok_or_else(|| {
                key.error("missing key `reflectance` (the surface's ordinary reflectance) next to `dye`")
            })?;
            let dye = key.field("dye");
            let a = Spectrum::from_desc(&d.absorption, &dye.field("absorption"), ctx, Some(Range::Unit))?;
            warn_faint_line(&a, &dye.field("absorption"), ctx);
            let e = Spectrum::from_desc(&d.emission, &dye.field("emission"), ctx, Some(Range::NonNegative))?;
            let cell = fluoro::dye_cell_width(&dye, d.quantum_yield, d.cell_nm)?;
            Reradiation::from_dye(diagonal, &a, &e, d.quantum_yield, cell).map_err(|e| dye.error(e))
        }
        (None, Some(file)) => {
            let path = ctx.resolve(file);
            let matrix = key.field("matrix");
            let (rr, report) = Reradiation::from_file(&path).map_err(|e| matrix.error(e))?;
            if !report.is_clean() {
                ctx.warn(&matrix, format!("{}: {report}", path.display()));
            }
            Ok(match diagonal {
                Some(d) => rr.with_diagonal(d),
                None => rr,
            })
        }
        _ => Err(key.error(
            "expected exactly one of `dye = { ... }` or `matrix = \"file.csv\"` (or .BFC, .exr) for a fluorescent_diffuse material",
        )),
    }
}

/// A surface dye's absorption is the fraction absorbed, at most 1, but a `narrow_band` line
/// has unit *integral*: `{ narrow_band = 450, fwhm = 40 }` absorbs about 2 % at its peak,
/// and the dye does next to nothing. Almost never what was meant, so say so, with the
/// `scale` that would make the peak absorb 90 %.
fn warn_faint_line(a: &Spectrum, key: &Key, ctx: &mut Context) {
    let (line, scale) = match a {
        Spectrum::NarrowBand { .. } => (a, 1.0),
        Spectrum::Scaled(inner, k) if matches!(**inner, Spectrum::NarrowBand { .. }) => {
            (&**inner, *k)
        }
        _ => return,
    };
    let peak = a.max_value();
    if peak < FAINT_ABSORPTION {
        let want = 0.9 * scale / peak;
        ctx.warn(
            key,
            format!(
                "the dye absorbs at most {:.1} % of the light at any wavelength: a narrow_band has unit integral \
                 (its peak is {:.4} per nm), not unit peak; `scale = {want:.3}` would absorb 90 % at the peak",
                100.0 * peak,
                line.max_value()
            ),
        );
    }
}

/// A surface dye whose absorption peaks below this share is reported ([`warn_faint_line`]).
const FAINT_ABSORPTION: f32 = 0.05;

/// The texture `desc` at `key` if it is one (`texture` or `checkerboard`), else `None`.
fn texture_from_desc(
    desc: &SpectrumDesc,
    key: &Key,
    ctx: &Context,
) -> Result<Option<Texture>, KeyError> {
    let SpectrumDesc::Table(t) = desc else {
        return Ok(None);
    };
    let others = [
        ("wavelengths", t.wavelengths.is_some()),
        ("csv", t.csv.is_some()),
        ("rgb", t.rgb.is_some()),
        ("constant", t.constant.is_some()),
        ("scale", t.scale.is_some()),
    ];
    let stray = |k: &str, present: bool, with: &str| match present {
        true => Err(key
            .field(k)
            .error(format!("only allowed together with `{with}`"))),
        false => Ok(()),
    };
    match (&t.texture, &t.checkerboard) {
        (None, None) => {
            stray("wrap", t.wrap.is_some(), "texture")?;
            stray("checks", t.checks.is_some(), "checkerboard")?;
            Ok(None)
        }
        (Some(_), Some(_)) => {
            Err(key.error("expected one of `texture` and `checkerboard`, found both"))
        }
        (texture, checkerboard) => {
            if let Some((k, _)) = others.iter().find(|(_, present)| *present) {
                return Err(key.field(k).error("not a key of a texture"));
            }
            if let Some(file) = texture {
                stray("checks", t.checks.is_some(), "checkerboard")?;
                let wrap = Wrap::from_desc(t.wrap.as_deref(), &key.field("wrap"))?;
                let image = ImageTexture::load(&ctx.resolve(file), wrap)
                    .map_err(|e| key.field("texture").error(e))?;
                return Ok(Some(Texture::Image(Arc::new(image))));
            }
            stray("wrap", t.wrap.is_some(), "texture")?;
            let pair = checkerboard.as_deref().unwrap_or_default();
            let ck = key.field("checkerboard");
            let [a, b] = pair else {
                return Err(ck.expected("two spectra", format!("{} of them", pair.len())));
            };
            let one = |d: &SpectrumDesc, i: usize| {
                Spectrum::from_desc(d, &ck.index(i), ctx, Some(Range::Unit))
            };
            let checks = t.checks.unwrap_or([8.0, 8.0]);
            if !checks.iter().all(|c| c.is_finite() && *c > 0.0) {
                return Err(key.field("checks").expected(
                    "two positive numbers of squares per unit of u and v",
                    format!("{checks:?}"),
                ));
            }
            Ok(Some(Texture::Checkerboard {
                spectra: [one(a, 0)?, one(b, 1)?],
                checks,
            }))
        }
    }
}
