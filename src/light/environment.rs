//! The environment: radiance arriving from infinitely far in every direction, seen by
//! rays that leave the scene and sampled by next-event estimation. Either a constant
//! spectral sky (the same radiance L(λ) from every direction, sampled uniformly over the
//! sphere) or a lat-long image ([`EnvMap`], importance-sampled).

use super::envmap::EnvMap;
use glam::Vec3;
use std::f32::consts::PI;
use std::sync::Arc;

/// The environment light.
#[derive(Debug, Clone)]
pub struct Environment {
    /// A constant sky's radiance × scale; for a map, a constant of the map's mean
    /// luminance × scale, which only weighs the light's power.
    pub emitter: u32,
    /// The image, if the sky is not constant.
    pub map: Option<Arc<EnvMap>>,
}

/// 1 / 4π: the density of a uniform direction.
const INV_FOUR_PI: f32 = 0.25 / PI;

impl Environment {
    /// A direction from two uniforms, its solid-angle density and, for a map, its texel;
    /// `None` where the map's density is zero.
    pub fn sample(&self, u: [f32; 2]) -> Option<(Vec3, f32, Option<u32>)> {
        if let Some(map) = &self.map {
            return map.sample(u).map(|(d, pdf, k)| (d, pdf, Some(k)));
        }
        // Uniform on the sphere: z = 1 − 2u₀, φ = 2πu₁.
        let z = 1.0 - 2.0 * u[0];
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (s, c) = (2.0 * PI * u[1]).sin_cos();
        Some((Vec3::new(r * c, r * s, z), INV_FOUR_PI, None))
    }

    /// The solid-angle density with which [`Environment::sample`] gives unit direction
    /// `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match &self.map {
            Some(map) => map.pdf(dir),
            None => INV_FOUR_PI,
        }
    }

    /// Power ÷ π per unit of radiance, for choosing lights by power: a sky of radiance L
    /// sends 4π·πr²·L into a scene of bounding radius r.
    pub fn power_over_pi(&self, scene_radius: f32) -> f32 {
        4.0 * PI * scene_radius * scene_radius
    }
}
