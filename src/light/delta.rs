//! Lights that only next-event estimation can find: a point, a spot and a directional
//! light. Each is a delta distribution (in position or in direction), so a BSDF-sampled
//! ray never hits one and the light technique's MIS weight is 1 (up to the HWSS lanes').
//!
//! A point or spot light gives intensity I(λ) (W·sr⁻¹·nm⁻¹): the irradiance at distance r
//! is I·cos θ / r². A directional light gives the irradiance E(λ) (W·m⁻²·nm⁻¹) on a
//! surface facing it: E·cos θ on one at angle θ.

use glam::Vec3;

/// Where a delta light is and how it emits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DeltaKind {
    /// Intensity I in every direction from `position`.
    Point { position: Vec3 },
    /// Intensity I·falloff(cos θ) around the unit `axis` from `position`: 1 inside the
    /// cone of cosine `cos_inner`, 0 outside that of `cos_outer`, smoothstep between.
    Spot {
        position: Vec3,
        axis: Vec3,
        cos_outer: f32,
        cos_inner: f32,
    },
    /// Parallel light travelling along the unit `direction`.
    Directional { direction: Vec3 },
}

/// One delta light: its kind and the index of its spectrum × scale in
/// [`super::Lights::emitters`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeltaLight {
    /// Position, axis, cone.
    pub kind: DeltaKind,
    /// Its intensity or irradiance spectrum.
    pub emitter: u32,
}

/// The light seen from a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeltaSample {
    /// The unit direction from the shading point to the light.
    pub wi: Vec3,
    /// The squared distance (1 for a directional light): the delta's "solid-angle pdf" is
    /// the light's selection probability × this, so that spectrum / pdf is I/r² or E.
    pub dist2: f32,
    /// The light's position, or `None` for a directional light (infinitely far).
    pub position: Option<Vec3>,
    /// The spot's falloff towards the point (1 for the other kinds), in (0, 1].
    pub falloff: f32,
}

impl DeltaLight {
    /// The light as seen from `p`; `None` if it does not reach `p` (outside a spot's cone,
    /// or `p` at the light itself).
    pub fn towards(&self, p: Vec3) -> Option<DeltaSample> {
        let at = |position: Vec3| {
            let to = position - p;
            let dist2 = to.length_squared();
            (dist2 > 0.0 && dist2.is_finite()).then(|| (to / dist2.sqrt(), dist2))
        };
        match self.kind {
            DeltaKind::Point { position } => at(position).map(|(wi, dist2)| DeltaSample {
                wi,
                dist2,
                position: Some(position),
                falloff: 1.0,
            }),
            DeltaKind::Spot {
                position,
                axis,
                cos_outer,
                cos_inner,
            } => {
                let (wi, dist2) = at(position)?;
                let falloff = spot_falloff(axis.dot(-wi), cos_outer, cos_inner);
                (falloff > 0.0).then_some(DeltaSample {
                    wi,
                    dist2,
                    position: Some(position),
                    falloff,
                })
            }
            DeltaKind::Directional { direction } => Some(DeltaSample {
                wi: -direction,
                dist2: 1.0,
                position: None,
                falloff: 1.0,
            }),
        }
    }

    /// Power ÷ π per unit of the spectrum's value, for choosing lights by power (area
    /// lights weigh area × radiance, which is their power ÷ π): 4 for a point, the
    /// cone's 2(1 − cos θ) with the falloff band counted half for a spot, and the
    /// scene's cross-section r² for a directional light over a scene of bounding radius r.
    pub fn power_over_pi(&self, scene_radius: f32) -> f32 {
        match self.kind {
            DeltaKind::Point { .. } => 4.0,
            DeltaKind::Spot {
                cos_outer,
                cos_inner,
                ..
            } => 2.0 * (1.0 - 0.5 * (cos_outer + cos_inner)),
            DeltaKind::Directional { .. } => scene_radius * scene_radius,
        }
    }
}

/// A spot's falloff at the cosine `cos` from its axis: smoothstep from the outer cone
/// (0) to the inner one (1); a hard edge when they coincide.
pub fn spot_falloff(cos: f32, cos_outer: f32, cos_inner: f32) -> f32 {
    if cos_inner <= cos_outer {
        return if cos >= cos_outer { 1.0 } else { 0.0 };
    }
    let t = ((cos - cos_outer) / (cos_inner - cos_outer)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_falloff_is_one_inside_zero_outside_and_smooth_between() {
        let (o, i) = (0.8, 0.9);
        assert_eq!(spot_falloff(0.95, o, i), 1.0);
        assert_eq!(spot_falloff(0.9, o, i), 1.0);
        assert_eq!(spot_falloff(0.8, o, i), 0.0);
        assert_eq!(spot_falloff(0.5, o, i), 0.0);
        assert!((spot_falloff(0.85, o, i) - 0.5).abs() < 1e-6);
        assert!((spot_falloff(0.825, o, i) - 0.15625).abs() < 1e-5);
        assert_eq!(spot_falloff(0.81, 0.8, 0.8), 1.0);
        assert_eq!(spot_falloff(0.79, 0.8, 0.8), 0.0);
    }

    #[test]
    fn a_point_light_is_seen_along_the_line_at_its_squared_distance() {
        let l = DeltaLight {
            kind: DeltaKind::Point {
                position: Vec3::new(0.0, 2.0, 0.0),
            },
            emitter: 0,
        };
        let s = l.towards(Vec3::ZERO).unwrap();
        assert_eq!(s.wi, Vec3::Y);
        assert_eq!(s.dist2, 4.0);
        assert!(l.towards(Vec3::new(0.0, 2.0, 0.0)).is_none());
    }
}
