//! The scene file as written: TOML read with serde, unknown keys rejected.
//!
//! ```toml
//! [camera]                      # pinhole
//! position = [278, 273, -800]
//! look_at = [278, 273, 0]
//! up = [0, 1, 0]                # optional, default +y
//! fov = 39.3077                 # vertical field of view, degrees
//! resolution = [512, 512]
//!
//! [render]                      # defaults; the command line overrides them
//! spp = 64
//! max_depth = -1                # path segments from the camera, −1 unbounded
//! seed = 0
//!
//! [spectra]                     # named spectra, used by name below
//! white = { csv = "data/cbox-reflectance.csv", column = "white" }
//! lamp = { wavelengths = [400, 500, 600, 700], values = [0, 8, 15.6, 18.4] }
//! sun = "lamp"                  # another entry (in any order) or an illuminant
//!
//! [materials.white]
//! type = "diffuse"
//! reflectance = "white"         # a number, a name, or an inline spectrum table
//!
//! [[shapes]]
//! type = "obj"
//! file = "meshes/cbox_luminaire.obj"
//! translate = [0, -0.5, 0]
//! material = "white"
//! emission = { radiance = "lamp", scale = 1.0 }
//! ```
//!
//! The full format, with an example of every element, is in the README.

use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;

/// The whole scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    /// The camera.
    pub camera: CameraDesc,
    /// Render defaults.
    #[serde(default)]
    pub render: RenderDesc,
    /// Named spectra. An entry may name another entry (`sun = "lamp"`, resolved whatever
    /// the order; a cycle is an error) or a CIE illuminant.
    #[serde(default)]
    pub spectra: BTreeMap<String, SpectrumDesc>,
    /// Named materials.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialDesc>,
    /// Named homogeneous media.
    #[serde(default)]
    pub media: BTreeMap<String, MediumDesc>,
    /// Shapes, in order: the geometry id of a shape's first mesh follows this order.
    #[serde(default)]
    pub shapes: Vec<ShapeDesc>,
    /// Named regions of interest of the image (`[[region]]`), for `stokes converge`.
    #[serde(default, rename = "region")]
    pub regions: Vec<RegionDesc>,
}

/// A named region of interest: a rectangle of pixels of the camera's resolution (x to
/// the right, y down; `min` inclusive, `max` exclusive), scaled when rendering at
/// another resolution. `stokes converge` reports the error over each region.
///
/// ```toml
/// [[region]]
/// name = "patches"
/// min = [162, 301]
/// max = [350, 352]
/// ```
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionDesc {
    /// A name for reports: letters, digits, `-` and `_`.
    pub name: String,
    /// The first pixel column and row.
    pub min: [u32; 2],
    /// One past the last pixel column and row.
    pub max: [u32; 2],
}

/// A pinhole camera.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Eye position.
    pub position: [f32; 3],
    /// A point the camera looks at.
    pub look_at: [f32; 3],
    /// Up direction (default +y).
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees.
    pub fov: f32,
    /// Image size in pixels, width then height.
    pub resolution: [u32; 2],
    /// The medium the camera sits in (default: none).
    pub medium: Option<String>,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

/// Render defaults that the command line can override.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderDesc {
    /// Samples per pixel.
    #[serde(default = "default_spp")]
    pub spp: u32,
    /// Path segments from the camera (Mitsuba 3's convention); −1 is unbounded.
    #[serde(default = "default_depth")]
    pub max_depth: i32,
    /// Seed of every random stream.
    #[serde(default)]
    pub seed: u64,
}

fn default_spp() -> u32 {
    16
}
fn default_depth() -> i32 {
    -1
}

impl Default for RenderDesc {
    fn default() -> Self {
        RenderDesc {
            spp: default_spp(),
            max_depth: default_depth(),
            seed: 0,
        }
    }
}

/// A spectrum as written: a number (constant), a string (a name from `[spectra]` or a CIE
/// illuminant `D65`, `A`, `F2`, `F11`), or a table with exactly one kind of key.
#[derive(Debug, Clone)]
pub enum SpectrumDesc {
    /// `0.5`
    Constant(f64),
    /// `"white"` or `"D65"`
    Name(String),
    /// `{ ... }`
    Table(SpectrumTable),
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
    /// `{ wavelengths = [...], values = [...] }`, linear between, zero outside.
    pub wavelengths: Option<Vec<f32>>,
    /// With `wavelengths`.
    pub values: Option<Vec<f32>>,
    /// `{ narrow_band = 440, fwhm = 10 }`: a Gaussian band of unit integral (nm).
    pub narrow_band: Option<f32>,
    /// With `narrow_band`: full width at half maximum in nm.
    pub fwhm: Option<f32>,
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
                    .map(SpectrumDesc::Table)
            }
        }
        d.deserialize_any(V)
    }
}

/// A material; `type` selects the model.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialDesc {
    /// `diffuse`, `mirror` or `dielectric`.
    #[serde(rename = "type")]
    pub kind: String,
    /// `diffuse` (required) and `mirror` (default 1): spectral reflectance in [0, 1].
    pub reflectance: Option<SpectrumDesc>,
    /// `dielectric`: interior index of refraction.
    pub ior: Option<IorDesc>,
    /// `dielectric`: exterior index (default 1).
    pub ext_ior: Option<f32>,
    /// `fluorescent_diffuse`: a parametric dye.
    pub dye: Option<DyeDesc>,
    /// `fluorescent_diffuse`: a measured re-radiation matrix (CSV grid).
    pub matrix: Option<String>,
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

/// A shape; `type` selects which keys apply.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShapeDesc {
    /// `obj`, `quad`, `box` or `sphere`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Name of a material from `[materials]`.
    pub material: Option<String>,
    /// Makes the shape an area light.
    pub emission: Option<EmissionDesc>,
    /// `obj`: the file (relative to the scene file).
    pub file: Option<String>,
    /// `obj`: only the object (`o`/`g`) of this name.
    pub object: Option<String>,
    /// `quad`: a corner.
    pub origin: Option<[f32; 3]>,
    /// `quad`: first edge from `origin`.
    pub edge_u: Option<[f32; 3]>,
    /// `quad`: second edge from `origin`; the quad faces `edge_u × edge_v`.
    pub edge_v: Option<[f32; 3]>,
    /// `box`: minimum corner.
    pub min: Option<[f32; 3]>,
    /// `box`: maximum corner.
    pub max: Option<[f32; 3]>,
    /// `sphere`: centre.
    pub center: Option<[f32; 3]>,
    /// `sphere`: radius.
    pub radius: Option<f32>,
    /// `sphere`: rings of latitude (default 64).
    pub stacks: Option<u32>,
    /// `sphere`: segments of longitude (default 2·stacks).
    pub slices: Option<u32>,
    /// Any shape: uniform scale applied before `translate` (default 1).
    pub scale: Option<f32>,
    /// Any shape: translation.
    pub translate: Option<[f32; 3]>,
    /// Any shape: turn the front side around (for example a box seen from inside).
    #[serde(default)]
    pub flip: bool,
    /// Any closed shape facing outwards: the medium inside it. Without a `material` the
    /// boundary is index-matched (rays cross it unchanged).
    pub interior: Option<String>,
    /// The medium outside the shape (default: none).
    pub exterior: Option<String>,
}

/// A homogeneous participating medium: σ_a and σ_s (per scene unit), or albedo and σ_t;
/// a Henyey–Greenstein phase function; optionally a fluorescent dye.
///
/// ```toml
/// [media.dye]
/// sigma_a = 0.0
/// sigma_s = 0.0
/// g = 0.0
/// dye = { absorption = { narrow_band = 440, fwhm = 60, scale = 60 }, concentration = 0.05,
///         emission = { narrow_band = 520, fwhm = 40 }, quantum_yield = 0.9 }
/// ```
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
}

/// A fluorescent dye in a medium: its absorption coefficient is
/// `absorption × concentration` (per scene unit).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumDyeDesc {
    /// Absorption spectrum (per scene unit at concentration 1).
    pub absorption: SpectrumDesc,
    /// Multiplies `absorption` (default 1; positive, and concentration × absorption at
    /// most 1e30 per scene unit).
    pub concentration: Option<f32>,
    /// Shape of the emission spectrum (normalised by the renderer).
    pub emission: SpectrumDesc,
    /// Fraction of the absorbed light re-emitted, in [0, 1].
    pub quantum_yield: f32,
    /// Width of the re-radiation grid's cells in nm (default 2).
    pub cell_nm: Option<f32>,
}

/// Emission of an area light: radiance (W·sr⁻¹·m⁻²·nm⁻¹) × scale, from the front side or
/// both.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmissionDesc {
    /// Spectral radiance.
    pub radiance: SpectrumDesc,
    /// Multiplier (default 1); radiance × scale may be at most 1e30 and the light's power
    /// must be finite in 32-bit floats.
    pub scale: Option<f32>,
    /// Emit from both sides (default false: only the front).
    #[serde(default)]
    pub two_sided: bool,
}
