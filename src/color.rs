//! Colour spaces the film and the tests need: CIE XYZ ↔ linear sRGB (Rec. 709 primaries,
//! D65 white, no white balancing), the sRGB transfer function, CIELAB and CIEDE2000.
//!
//! XYZ here is in the renderer's normalisation (a constant radiance spectrum of 1 has
//! Y = 1, see [`crate::spectrum::spectrum_to_xyz`]). Linear sRGB (1, 1, 1) is a D65
//! spectrum scaled to Y = 1; with no white balancing an equal-energy spectrum comes out
//! slightly pink, as it should.

use glam::{Vec2, Vec3};

/// Rows of XYZ → linear sRGB, derived exactly from the Rec. 709 primaries
/// R (0.64, 0.33), G (0.30, 0.60), B (0.15, 0.06) and the D65 white (0.3127, 0.3290)
/// (the test `matrix_follows_from_primaries` re-derives it).
const XYZ_TO_SRGB: [Vec3; 3] = [
    Vec3::new(3.240_97, -1.537_383_2, -0.498_610_76),
    Vec3::new(-0.969_243_6, 1.875_967_5, 0.041_555_06),
    Vec3::new(0.055_630_08, -0.203_976_96, 1.056_971_5),
];

/// Rows of linear sRGB → XYZ (the inverse of [`XYZ_TO_SRGB`]): its columns are the
/// primaries' XYZ, and its rows sum to the white (0.9505, 1, 1.0891).
const SRGB_TO_XYZ: [Vec3; 3] = [
    Vec3::new(0.412_390_8, 0.357_584_34, 0.180_480_8),
    Vec3::new(0.212_639, 0.715_168_7, 0.072_192_32),
    Vec3::new(0.019_330_82, 0.119_194_78, 0.950_532_15),
];

/// CIE XYZ → linear sRGB. Out-of-gamut colours give negative components (not clamped).
pub fn xyz_to_linear_srgb(xyz: Vec3) -> Vec3 {
    Vec3::new(
        XYZ_TO_SRGB[0].dot(xyz),
        XYZ_TO_SRGB[1].dot(xyz),
        XYZ_TO_SRGB[2].dot(xyz),
    )
}

/// Linear sRGB → CIE XYZ.
pub fn linear_srgb_to_xyz(rgb: Vec3) -> Vec3 {
    Vec3::new(
        SRGB_TO_XYZ[0].dot(rgb),
        SRGB_TO_XYZ[1].dot(rgb),
        SRGB_TO_XYZ[2].dot(rgb),
    )
}

/// The sRGB transfer function (IEC 61966-2-1) from linear to encoded, input clamped to
/// [0, 1] first (NaN becomes 0) so the result is a displayable value.
pub fn srgb_encode(linear: f32) -> f32 {
    let x = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`srgb_encode`] (encoded → linear), for inputs in [0, 1].
pub fn srgb_decode(encoded: f32) -> f32 {
    if encoded <= 0.040_45 {
        encoded / 12.92
    } else {
        ((encoded + 0.055) / 1.055).powf(2.4)
    }
}

/// Chromaticity (x, y) of an XYZ colour; (0, 0) for black.
pub fn xyz_to_xy(xyz: Vec3) -> Vec2 {
    let sum = xyz.x + xyz.y + xyz.z;
    if sum == 0.0 {
        Vec2::ZERO
    } else {
        Vec2::new(xyz.x / sum, xyz.y / sum)
    }
}

/// CIE 1976 L*a*b* of `xyz` relative to the reference white `white_xyz` (both in the same
/// units; L* = 100 for the white itself). Uses the CIE's exact ε = 216/24389, κ = 24389/27.
pub fn xyz_to_lab(xyz: Vec3, white_xyz: Vec3) -> Vec3 {
    const EPSILON: f64 = 216.0 / 24389.0;
    const KAPPA: f64 = 24389.0 / 27.0;
    let f = |t: f32, white: f32| {
        let r = f64::from(t) / f64::from(white);
        if r > EPSILON {
            r.cbrt()
        } else {
            (KAPPA * r + 16.0) / 116.0
        }
    };
    let (fx, fy, fz) = (
        f(xyz.x, white_xyz.x),
        f(xyz.y, white_xyz.y),
        f(xyz.z, white_xyz.z),
    );
    Vec3::new(
        (116.0 * fy - 16.0) as f32,
        (500.0 * (fx - fy)) as f32,
        (200.0 * (fy - fz)) as f32,
    )
}

/// CIEDE2000 colour difference ΔE₀₀ between two L*a*b* colours (k_L = k_C = k_H = 1),
/// following Sharma, Wu and Dalal (2005), computed in f64.
pub fn delta_e_2000(lab1: Vec3, lab2: Vec3) -> f32 {
    let (l1, a1, b1) = (f64::from(lab1.x), f64::from(lab1.y), f64::from(lab1.z));
    let (l2, a2, b2) = (f64::from(lab2.x), f64::from(lab2.y), f64::from(lab2.z));
    let pow7 = |x: f64| x.powi(7);
    let twenty_five_7 = pow7(25.0);

    // a' stretches the a axis near the neutral axis (G).
    let c_bar = 0.5 * (a1.hypot(b1) + a2.hypot(b2));
    let g = 0.5 * (1.0 - (pow7(c_bar) / (pow7(c_bar) + twenty_five_7)).sqrt());
    let (a1p, a2p) = ((1.0 + g) * a1, (1.0 + g) * a2);
    let (c1p, c2p) = (a1p.hypot(b1), a2p.hypot(b2));
    let hue = |a: f64, b: f64| {
        if a == 0.0 && b == 0.0 {
            0.0
        } else {
            b.atan2(a).to_degrees().rem_euclid(360.0)
        }
    };
    let h1p = hue(a1p, b1);
    let mut h2p = hue(a2p, b2);
    let chroma_product = c1p * c2p;
    // Exactly opposite hues (Sharma's pairs 10 and 14) sit on the boundary of the mean-hue
    // rule below, where the last bit of atan2 could pick the branch. The cross product
    // tells opposition exactly, so make the angles exactly 180° apart.
    if chroma_product != 0.0 && a1p * b2 - b1 * a2p == 0.0 && a1p * a2p + b1 * b2 < 0.0 {
        h2p = if h1p >= 180.0 {
            h1p - 180.0
        } else {
            h1p + 180.0
        };
    }

    let delta_l = l2 - l1;
    let delta_c = c2p - c1p;
    let delta_h_angle = if chroma_product == 0.0 {
        0.0
    } else {
        let d = h2p - h1p;
        if d > 180.0 {
            d - 360.0
        } else if d < -180.0 {
            d + 360.0
        } else {
            d
        }
    };
    let delta_h = 2.0 * chroma_product.sqrt() * (0.5 * delta_h_angle).to_radians().sin();

    let l_bar = 0.5 * (l1 + l2);
    let c_bar_p = 0.5 * (c1p + c2p);
    let h_bar_p = if chroma_product == 0.0 {
        h1p + h2p
    } else if (h1p - h2p).abs() <= 180.0 {
        0.5 * (h1p + h2p)
    } else if h1p + h2p < 360.0 {
        0.5 * (h1p + h2p + 360.0)
    } else {
        0.5 * (h1p + h2p - 360.0)
    };

    let cos_deg = |d: f64| d.to_radians().cos();
    let t = 1.0 - 0.17 * cos_deg(h_bar_p - 30.0)
        + 0.24 * cos_deg(2.0 * h_bar_p)
        + 0.32 * cos_deg(3.0 * h_bar_p + 6.0)
        - 0.20 * cos_deg(4.0 * h_bar_p - 63.0);
    let delta_theta = 30.0 * (-((h_bar_p - 275.0) / 25.0).powi(2)).exp();
    let r_c = 2.0 * (pow7(c_bar_p) / (pow7(c_bar_p) + twenty_five_7)).sqrt();
    let l_dev = (l_bar - 50.0).powi(2);
    let s_l = 1.0 + 0.015 * l_dev / (20.0 + l_dev).sqrt();
    let s_c = 1.0 + 0.045 * c_bar_p;
    let s_h = 1.0 + 0.015 * c_bar_p * t;
    let r_t = -(2.0 * delta_theta).to_radians().sin() * r_c;

    let (dl, dc, dh) = (delta_l / s_l, delta_c / s_c, delta_h / s_h);
    (dl * dl + dc * dc + dh * dh + r_t * dc * dh).sqrt() as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat3, Vec3};

    fn xyz_from_xy(x: f32, y: f32) -> Vec3 {
        Vec3::new(x / y, 1.0, (1.0 - x - y) / y)
    }

    fn rows(m: &[Vec3; 3]) -> Mat3 {
        Mat3::from_cols(m[0], m[1], m[2]).transpose()
    }

    #[test]
    fn matrix_follows_from_primaries() {
        let p = Mat3::from_cols(
            xyz_from_xy(0.64, 0.33),
            xyz_from_xy(0.30, 0.60),
            xyz_from_xy(0.15, 0.06),
        );
        let white = xyz_from_xy(0.3127, 0.3290);
        let s = p.inverse() * white;
        let rgb_to_xyz = p * Mat3::from_diagonal(s);
        let ours = rows(&SRGB_TO_XYZ);
        let inv = rows(&XYZ_TO_SRGB);
        for c in 0..3 {
            let d = (rgb_to_xyz.col(c) - ours.col(c)).abs().max_element();
            assert!(d < 1e-5, "column {c} differs by {d}");
        }
        let id = ours * inv;
        assert!(
            (id - Mat3::IDENTITY)
                .to_cols_array()
                .iter()
                .all(|v| v.abs() < 1e-6),
            "{id:?}"
        );
    }

    #[test]
    fn white_maps_to_equal_rgb() {
        let rgb = xyz_to_linear_srgb(xyz_from_xy(0.3127, 0.3290));
        assert!((rgb - Vec3::ONE).abs().max_element() < 1e-5, "{rgb}");
        let back = linear_srgb_to_xyz(Vec3::new(0.2, 0.5, 0.9));
        assert!((xyz_to_linear_srgb(back) - Vec3::new(0.2, 0.5, 0.9)).length() < 1e-5);
    }

    #[test]
    fn transfer_function_is_continuous_and_clamped() {
        assert_eq!(srgb_encode(-1.0), 0.0);
        assert_eq!(srgb_encode(f32::NAN), 0.0);
        assert!((srgb_encode(2.0) - 1.0).abs() < 1e-6);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        let knee = 0.003_130_8f32;
        assert!((12.92 * knee - (1.055 * knee.powf(1.0 / 2.4) - 0.055)).abs() < 1e-6);
        // 18 % grey encodes to ≈ 0.4613 (118/255).
        assert!((srgb_encode(0.18) - 0.461_356).abs() < 1e-4);
        for i in 0..=100 {
            let x = i as f32 / 100.0;
            assert!((srgb_decode(srgb_encode(x)) - x).abs() < 1e-5);
        }
    }

    #[test]
    fn lab_of_white_and_a_known_colour() {
        let white = Vec3::new(0.950_47, 1.0, 1.088_83);
        let lab = xyz_to_lab(white, white);
        assert!((lab - Vec3::new(100.0, 0.0, 0.0)).abs().max_element() < 1e-4);
        assert_eq!(xyz_to_lab(Vec3::ZERO, white), Vec3::ZERO);
        // sRGB red (1, 0, 0) under D65 is L*a*b* ≈ (53.24, 80.09, 67.20).
        let red = xyz_to_lab(linear_srgb_to_xyz(Vec3::X), white);
        assert!(
            (red - Vec3::new(53.24, 80.09, 67.20)).abs().max_element() < 0.02,
            "{red}"
        );
    }

    #[test]
    fn delta_e_is_symmetric_and_zero_on_equal() {
        let a = Vec3::new(50.0, 2.6772, -79.7751);
        let b = Vec3::new(50.0, 0.0, -82.7485);
        assert_eq!(delta_e_2000(a, a), 0.0);
        assert!((delta_e_2000(a, b) - delta_e_2000(b, a)).abs() < 1e-6);
        assert!((delta_e_2000(a, b) - 2.0425).abs() < 1e-4);
    }

    #[test]
    fn xy_of_black_is_zero() {
        assert_eq!(xyz_to_xy(Vec3::ZERO), Vec2::ZERO);
        let xy = xyz_to_xy(xyz_from_xy(0.3, 0.4) * 7.0);
        assert!((xy - Vec2::new(0.3, 0.4)).abs().max_element() < 1e-6);
    }
}
