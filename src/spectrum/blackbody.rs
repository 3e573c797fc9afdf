//! Planck's law.
//!
//! Spectral radiance of a black body in **W·sr⁻¹·m⁻²·nm⁻¹** (per nanometre, so it sits in
//! the same units as every other spectrum here, whose integrals run over λ in nm).

/// Planck constant (J·s), speed of light (m/s), Boltzmann constant (J/K): exact SI values.
const H: f64 = 6.626_070_15e-34;
const C: f64 = 299_792_458.0;
const K_B: f64 = 1.380_649e-23;
/// Wien's displacement constant b (m·K): the peak over wavelength is at b/T.
pub const WIEN_B: f64 = 2.897_771_955e-3;

/// B(λ, T) in W·sr⁻¹·m⁻²·nm⁻¹ for λ in nm and T in kelvin (0 for λ ≤ 0 or T ≤ 0).
pub fn planck(lambda_nm: f32, kelvin: f32) -> f32 {
    planck_f64(f64::from(lambda_nm), f64::from(kelvin)) as f32
}

fn planck_f64(lambda_nm: f64, kelvin: f64) -> f64 {
    if lambda_nm <= 0.0 || kelvin <= 0.0 {
        return 0.0;
    }
    let l = lambda_nm * 1e-9;
    // exp_m1 keeps the Rayleigh–Jeans end (small exponent) accurate.
    let x = H * C / (l * K_B * kelvin);
    let per_metre = 2.0 * H * C * C / (l.powi(5) * x.exp_m1());
    per_metre * 1e-9
}

/// The wavelength (nm) where B(λ, T) peaks: Wien's displacement law.
pub fn peak_wavelength(kelvin: f32) -> f32 {
    (WIEN_B / f64::from(kelvin) * 1e9) as f32
}

/// The largest value of B(λ, T) over all wavelengths.
pub fn peak_value(kelvin: f32) -> f32 {
    let t = f64::from(kelvin);
    planck_f64(WIEN_B / t * 1e9, t) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_a_hand_computed_value() {
        // B(500 nm, 5000 K): 2hc²/λ⁵ / (e^{hc/λkT} − 1) = 1.2107e13 W·sr⁻¹·m⁻³ (x = 5.7550).
        let b = planck(500.0, 5000.0);
        assert!((b / 1.2107e4 - 1.0).abs() < 1e-3, "{b}");
    }

    #[test]
    fn peak_value_is_the_maximum() {
        for &t in &[2700.0f32, 5000.0, 6500.0] {
            let p = peak_wavelength(t);
            let v = peak_value(t);
            assert!(planck(p - 1.0, t) < v && planck(p + 1.0, t) < v);
        }
    }

    #[test]
    fn nonpositive_inputs_give_zero() {
        assert_eq!(planck(0.0, 5000.0), 0.0);
        assert_eq!(planck(500.0, 0.0), 0.0);
    }
}
