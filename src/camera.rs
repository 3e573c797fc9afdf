//! A pinhole camera: position, look-at point, up vector, vertical field of view.
//!
//! Film coordinates are in pixels, x to the right and y down, (0, 0) the top-left corner.

use crate::accel::Ray;
use crate::error::{Key, KeyError};
use crate::simd::{Float, V3};
use glam::Vec3;

/// A pinhole camera.
#[derive(Debug, Clone)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// A camera; `fov_deg` is the vertical field of view. Errors name the `camera` key
    /// that is degenerate.
    pub fn new(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_deg: f32,
        width: u32,
        height: u32,
    ) -> Result<Camera, KeyError> {
        let key = Key::root("camera");
        let forward = (look_at - position).normalize_or_zero();
        if forward == Vec3::ZERO {
            return Err(key
                .field("look_at")
                .error("must differ from camera.position"));
        }
        let right = forward.cross(up).normalize_or_zero();
        if right == Vec3::ZERO {
            return Err(key
                .field("up")
                .error("must not be parallel to the viewing direction"));
        }
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(key.field("fov").expected("degrees in (0, 180)", fov_deg));
        }
        if width == 0 || height == 0 {
            return Err(key
                .field("resolution")
                .expected("positive sizes", format!("[{width}, {height}]")));
        }
        let tan_half = (fov_deg.to_radians() * 0.5).tan();
        let aspect = width as f32 / height as f32;
        let true_up = right.cross(forward);
        Ok(Camera {
            position,
            forward,
            right: right * tan_half * aspect,
            up: true_up * tan_half,
            width,
            height,
        })
    }

    /// The same camera at another resolution (same vertical field of view).
    pub fn with_resolution(&self, width: u32, height: u32) -> Camera {
        let aspect_old = self.width as f32 / self.height as f32;
        let aspect = width as f32 / height as f32;
        Camera {
            right: self.right * (aspect / aspect_old),
            width,
            height,
            ..self.clone()
        }
    }

    /// Pixels of the image.
    pub fn pixel_count(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    /// Film position (pixels) of a world point, or `None` if it is behind the camera.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let d = p - self.position;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = d.dot(self.right) / self.right.length_squared() / z;
        let sy = d.dot(self.up) / self.up.length_squared() / z;
        Some((
            (sx + 1.0) * 0.5 * self.width as f32,
            (1.0 - sy) * 0.5 * self.height as f32,
        ))
    }

    /// The primary ray through film position (x, y) in pixels; the direction is unit.
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        Ray::new(self.position, self.dirs(x, y).into())
    }

    /// The unit directions of the primary rays through film positions (x, y) of W paths.
    #[inline(always)]
    pub fn dirs<F: Float>(&self, x: F, y: F) -> V3<F> {
        let one = F::splat(1.0);
        let sx = F::splat(2.0) * x / F::splat(self.width as f32) - one;
        let sy = one - F::splat(2.0) * y / F::splat(self.height as f32);
        (V3::splat(self.forward) + V3::splat(self.right) * sx + V3::splat(self.up) * sy).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_right_is_right() {
        let c = Camera::new(
            Vec3::new(0.0, 0.0, -5.0),
            Vec3::ZERO,
            Vec3::Y,
            40.0,
            100,
            100,
        )
        .unwrap();
        let r = c.ray(50.0, 50.0);
        assert!((r.dir - Vec3::Z).length() < 1e-6);
        // Looking along +z with +y up, image right is −x (right-handed coordinates).
        assert!(c.ray(99.0, 50.0).dir.x < 0.0);
        assert!(c.ray(50.0, 0.0).dir.y > 0.0);
        // Top edge at half the field of view.
        let top = c.ray(50.0, 0.0).dir;
        assert!((top.y.atan2(top.z).to_degrees() - 20.0).abs() < 1e-3);
        // project() inverts ray().
        let r = c.ray(20.0, 70.0);
        let (x, y) = c.project(r.org + r.dir * 3.0).unwrap();
        assert!(
            (x - 20.0).abs() < 1e-3 && (y - 70.0).abs() < 1e-3,
            "{x} {y}"
        );
    }
}
