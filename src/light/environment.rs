//! The environment: radiance arriving from infinitely far in every direction, seen by
//! rays that leave the scene and sampled by next-event estimation. Today a constant
//! spectral sky (the same radiance L(λ) from every direction), sampled uniformly over
//! the sphere.

use glam::Vec3;
use std::f32::consts::PI;

/// A constant environment: radiance [`super::Lights::emitters`]`[emitter]` from every
/// direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Environment {
    /// Its radiance spectrum × scale.
    pub emitter: u32,
}

/// 1 / 4π: the density of a uniform direction.
const INV_FOUR_PI: f32 = 0.25 / PI;

impl Environment {
    /// A direction from two uniforms and its solid-angle density (uniform on the sphere:
    /// z = 1 − 2u₀, φ = 2πu₁).
    pub fn sample(&self, u: [f32; 2]) -> (Vec3, f32) {
        let z = 1.0 - 2.0 * u[0];
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (s, c) = (2.0 * PI * u[1]).sin_cos();
        (Vec3::new(r * c, r * s, z), INV_FOUR_PI)
    }

    /// The solid-angle density with which [`Environment::sample`] gives `dir`.
    pub fn pdf(&self, _dir: Vec3) -> f32 {
        INV_FOUR_PI
    }

    /// Power ÷ π per unit of radiance, for choosing lights by power: a sky of radiance L
    /// sends 4π·πr²·L into a scene of bounding radius r.
    pub fn power_over_pi(&self, scene_radius: f32) -> f32 {
        4.0 * PI * scene_radius * scene_radius
    }
}
