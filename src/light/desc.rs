//! `[[lights]]`: the lights that are not shapes, as a scene file writes them.
//!
//! ```toml
//! [[lights]]
//! type = "point"
//! position = [0, 1.9, 0]
//! intensity = "D65"            # W·sr⁻¹·nm⁻¹, any spectrum
//! scale = 0.5                  # any light (default 1)
//!
//! [[lights]]
//! type = "spot"
//! position = [0, 1.9, 0]
//! look_at = [0, 0, 0]          # the cone's axis points here
//! angle = 30                   # the cone's half-angle in degrees, in (0, 180]
//! falloff = 5                  # the soft edge inside it in degrees (default 5, ≤ angle)
//! intensity = { narrow_band = 365, fwhm = 12 }
//!
//! [[lights]]
//! type = "directional"
//! direction = [0, -1, 0]       # the way the light travels
//! irradiance = "D65"           # W·m⁻²·nm⁻¹ on a surface facing it
//!
//! [[lights]]
//! type = "environment"         # at most one: light from every direction, far away
//! radiance = "D65"             # W·sr⁻¹·m⁻²·nm⁻¹, the same from every direction
//! # or: map = "sky.exr"        # a lat-long RGB OpenEXR (2:1, +y up), upsampled as
//! #                            # an illuminant: RGB (1, 1, 1) is D65 of luminance 1
//! ```

use super::{DeltaKind, Emitter, EnvMap, Lights};
use crate::error::{Key, KeyError};
use crate::scene::context::reject_keys;
use crate::scene::shapes::finite_vec;
use crate::scene::Context;
use crate::spectrum::{self, SpectrumDesc};
use glam::Vec3;
use serde::Deserialize;

/// One `[[lights]]` entry; which keys it takes depends on its `type`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightDesc {
    /// `point`, `spot`, `directional` or `environment`.
    #[serde(rename = "type")]
    pub kind: String,
    /// `point`, `spot`: where the light is.
    pub position: Option<[f32; 3]>,
    /// `spot`: a point on the cone's axis.
    pub look_at: Option<[f32; 3]>,
    /// `spot`: the cone's half-angle in degrees.
    pub angle: Option<f32>,
    /// `spot`: the width of the soft edge in degrees, inside the cone (default 5, or the
    /// whole cone if it is narrower).
    pub falloff: Option<f32>,
    /// `directional`: the direction the light travels in.
    pub direction: Option<[f32; 3]>,
    /// `point`, `spot`: the radiant intensity, W·sr⁻¹·nm⁻¹.
    pub intensity: Option<SpectrumDesc>,
    /// `directional`: the irradiance on a surface facing the light, W·m⁻²·nm⁻¹.
    pub irradiance: Option<SpectrumDesc>,
    /// `environment`: the radiance from every direction, W·sr⁻¹·m⁻²·nm⁻¹.
    pub radiance: Option<SpectrumDesc>,
    /// `environment`: a lat-long RGB OpenEXR image instead of `radiance` (relative to the
    /// scene file).
    pub map: Option<String>,
    /// Multiplies the spectrum (default 1).
    pub scale: Option<f32>,
}

/// The values of `type`.
const KINDS: [&str; 4] = ["point", "spot", "directional", "environment"];

/// The default width of a spot's soft edge (degrees).
const DEFAULT_FALLOFF: f32 = 5.0;

impl LightDesc {
    /// Adds the light at `key` to `lights`, in a scene whose bounding sphere has radius
    /// `scene_radius`. Errors name the key: an unknown type, a key of another type, a
    /// missing or non-finite position or direction, a cone outside (0°, 180°], a second
    /// environment, a spectrum that is not a finite non-negative emission, or a power that
    /// is not finite in 32-bit floats.
    pub fn add_to(
        &self,
        lights: &mut Lights,
        key: &Key,
        ctx: &mut Context,
        scene_radius: f32,
    ) -> Result<(), KeyError> {
        let kind = self.kind.as_str();
        if !KINDS.contains(&kind) {
            return Err(key
                .field("type")
                .expected(format!("one of {}", KINDS.join(", ")), format!("{kind:?}")));
        }
        self.reject_foreign(key)?;
        if kind == "environment" {
            return self.environment(lights, key, ctx, scene_radius);
        }
        let need = |k: &str, v: Option<[f32; 3]>| -> Result<Vec3, KeyError> {
            let v = v.ok_or_else(|| key.error(format!("missing key `{k}` for a {kind} light")))?;
            finite_vec(&key.field(k), v)
        };
        let (field, spectrum, units) = match kind {
            "directional" => ("irradiance", &self.irradiance, ("irradiance", "W·m⁻²·nm⁻¹")),
            _ => (
                "intensity",
                &self.intensity,
                ("radiant intensity", "W·sr⁻¹·nm⁻¹"),
            ),
        };
        let spectrum = spectrum
            .as_ref()
            .ok_or_else(|| key.error(format!("missing key `{field}` for a {kind} light")))?;
        let emitter = Emitter::checked(spectrum, self.scale, key, field, units, ctx)?;
        let kind = match kind {
            "point" => DeltaKind::Point {
                position: need("position", self.position)?,
            },
            "spot" => {
                let (position, look_at) = (
                    need("position", self.position)?,
                    need("look_at", self.look_at)?,
                );
                self.spot(key, position, look_at)?
            }
            _ => {
                let d = need("direction", self.direction)?;
                let direction = d.try_normalize().ok_or_else(|| {
                    key.field("direction")
                        .expected("a non-zero direction", format!("{d:?}"))
                })?;
                DeltaKind::Directional { direction }
            }
        };
        let light = super::DeltaLight { kind, emitter: 0 };
        check_power(key, field, &emitter, light.power_over_pi(scene_radius))?;
        lights.add_delta(kind, emitter);
        Ok(())
    }

    /// Sets the environment: a constant `radiance` or a `map`, one of them.
    fn environment(
        &self,
        lights: &mut Lights,
        key: &Key,
        ctx: &mut Context,
        scene_radius: f32,
    ) -> Result<(), KeyError> {
        if lights.environment.is_some() {
            return Err(key
                .field("type")
                .error("a second environment light (a scene has at most one)"));
        }
        let per_unit = 4.0 * std::f32::consts::PI * scene_radius.powi(2);
        let units = ("spectral radiance", "W·sr⁻¹·m⁻²·nm⁻¹");
        match (&self.radiance, &self.map) {
            (Some(_), Some(_)) => Err(key.error(
                "expected one of `radiance` (a constant sky) and `map` (an image), found both",
            )),
            (None, None) => Err(key.error(
                "missing key `radiance` (a constant sky) or `map` (an image) for an environment light",
            )),
            (Some(radiance), None) => {
                let emitter = Emitter::checked(radiance, self.scale, key, "radiance", units, ctx)?;
                check_power(key, "radiance", &emitter, per_unit)?;
                lights.set_environment(emitter, None);
                Ok(())
            }
            (None, Some(file)) => {
                let scale = self.scale.unwrap_or(1.0);
                if !(scale.is_finite() && scale >= 0.0) {
                    return Err(key.field("scale").expected("a non-negative number", scale));
                }
                let map = EnvMap::load(&ctx.resolve(file), scale)
                    .map_err(|e| key.field("map").error(e))?;
                let mean = SpectrumDesc::Constant(f64::from(map.mean_luminance));
                let emitter = Emitter::checked(&mean, None, key, "map", units, ctx)?;
                check_power(key, "map", &emitter, per_unit)?;
                lights.set_environment(emitter, Some(map));
                Ok(())
            }
        }
    }
    /// A spot at `position` aimed at `look_at`, with its cone checked.
    fn spot(&self, key: &Key, position: Vec3, look_at: Vec3) -> Result<DeltaKind, KeyError> {
        let axis = (look_at - position).try_normalize().ok_or_else(|| {
            key.field("look_at")
                .expected("a point other than `position`", format!("{look_at:?}"))
        })?;
        let angle = self
            .angle
            .ok_or_else(|| key.error("missing key `angle` for a spot light"))?;
        if !(angle > 0.0 && angle <= 180.0) {
            return Err(key
                .field("angle")
                .expected("a half-angle in (0, 180] degrees", angle));
        }
        let falloff = self.falloff.unwrap_or(DEFAULT_FALLOFF.min(angle));
        if !(falloff >= 0.0 && falloff <= angle) {
            return Err(key.field("falloff").expected(
                format!("a width in [0, {angle}] degrees (at most the cone's `angle`)"),
                falloff,
            ));
        }
        Ok(DeltaKind::Spot {
            position,
            axis,
            cos_outer: angle.to_radians().cos(),
            cos_inner: (angle - falloff).to_radians().cos(),
        })
    }

    /// An error for the first key given that this light's type does not take.
    fn reject_foreign(&self, key: &Key) -> Result<(), KeyError> {
        let kind = self.kind.as_str();
        let keys: [(&str, bool, &[&str]); 9] = [
            ("position", self.position.is_some(), &["point", "spot"]),
            ("look_at", self.look_at.is_some(), &["spot"]),
            ("angle", self.angle.is_some(), &["spot"]),
            ("falloff", self.falloff.is_some(), &["spot"]),
            ("direction", self.direction.is_some(), &["directional"]),
            ("intensity", self.intensity.is_some(), &["point", "spot"]),
            ("irradiance", self.irradiance.is_some(), &["directional"]),
            ("radiance", self.radiance.is_some(), &["environment"]),
            ("map", self.map.is_some(), &["environment"]),
        ];
        let foreign: Vec<(&str, bool)> = keys
            .iter()
            .filter(|(_, _, of)| !of.contains(&kind))
            .map(|&(k, present, _)| (k, present))
            .collect();
        reject_keys(key, kind, "light", &foreign)
    }
}

/// Checks that a light whose power ÷ π per unit spectrum is `per_unit` has a power that
/// is finite in 32-bit floats (the selection table holds it).
fn check_power(key: &Key, field: &str, emitter: &Emitter, per_unit: f32) -> Result<(), KeyError> {
    let power = std::f64::consts::PI
        * f64::from(per_unit)
        * f64::from(emitter.mean_radiance())
        * f64::from(spectrum::LAMBDA_RANGE);
    if power.is_finite() && power <= f64::from(f32::MAX) {
        return Ok(());
    }
    Err(key.field(field).expected(
        format!(
            "a light whose power over {}–{} nm is finite in 32-bit floats",
            spectrum::LAMBDA_MIN,
            spectrum::LAMBDA_MAX
        ),
        format!("{power:.3e}"),
    ))
}
