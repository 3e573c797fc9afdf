//! The scene file as written: TOML read with serde, unknown keys rejected. This module
//! holds the top level (camera, render defaults, regions) and the tables of the kinds.
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
//! Each kind parses its own part: spectra in [`crate::spectrum::desc`], materials in
//! [`crate::bsdf::desc`], media in [`crate::medium::desc`], shapes in
//! [`super::shapes`], emission in [`crate::light`]; the README has an example of every
//! element.

use super::shapes::ShapeDesc;
use crate::bsdf::MaterialDesc;
use crate::light::LightDesc;
use crate::medium::MediumDesc;
use crate::spectrum::SpectrumDesc;
use serde::Deserialize;
use std::collections::BTreeMap;

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
    /// Lights that are not shapes (`[[lights]]`): point, spot, directional, environment.
    #[serde(default)]
    pub lights: Vec<LightDesc>,
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
