//! The CIE 1931 2° standard observer and the CIE standard illuminants.
//!
//! The tables are embedded (see `data/PROVENANCE.md`) and parsed once on first use.
//! Radiance becomes XYZ as XYZ = ∫ L(λ) x̄ȳz̄(λ) dλ / [`CIE_Y_INTEGRAL`], so a constant
//! spectrum of 1 has Y = 1; the colour-matching functions are linear between their 1 nm
//! samples and zero outside 360–830 nm.

use std::sync::OnceLock;

use glam::{Vec3, Vec4};

use super::curve::{parse_csv, Tabulated};
use super::{Spectrum, LAMBDA_MAX, LAMBDA_MIN};

/// ∫ ȳ(λ) dλ over 360–830 nm (nm units): the divisor that makes a constant 1 have Y = 1.
pub const CIE_Y_INTEGRAL: f32 = 106.856895;

/// The names [`illuminant`] knows (matching is case-insensitive; "FL2"/"FL11" also work).
pub const ILLUMINANT_NAMES: [&str; 4] = ["D65", "A", "F2", "F11"];

/// Number of 1 nm samples in the colour-matching table, 360..=830.
const CMF_SAMPLES: usize = 471;

const CMF_CSV: &str = include_str!("data/cie1931_2deg_xyz.csv");
const D65_CSV: &str = include_str!("data/cie_d65.csv");
const A_CSV: &str = include_str!("data/cie_a.csv");
const F2_CSV: &str = include_str!("data/cie_f2.csv");
const F11_CSV: &str = include_str!("data/cie_f11.csv");

/// x̄, ȳ, z̄ at 360, 361, …, 830 nm, padded to 4 lanes so a lookup is one aligned load.
struct CmfTable {
    xyz: Vec<Vec4>,
}

fn cmf_table() -> &'static CmfTable {
    static TABLE: OnceLock<CmfTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        let cols = parse_csv(CMF_CSV, "cie1931_2deg_xyz.csv").expect("embedded CMF table parses");
        assert_eq!(cols.len(), 3, "CMF table has x̄, ȳ, z̄ columns");
        let w = cols[0].1.wavelengths();
        assert_eq!(w.len(), CMF_SAMPLES);
        assert!(
            w.iter()
                .enumerate()
                .all(|(i, &l)| l == LAMBDA_MIN + i as f32),
            "CMF table must be sampled at every nm from 360 to 830"
        );
        let (x, y, z) = (cols[0].1.values(), cols[1].1.values(), cols[2].1.values());
        CmfTable {
            xyz: (0..CMF_SAMPLES)
                .map(|i| Vec4::new(x[i], y[i], z[i], 0.0))
                .collect(),
        }
    })
}

impl CmfTable {
    /// Linear interpolation between the 1 nm samples; zero outside [360, 830] (and for NaN).
    #[inline]
    fn lookup(&self, lambda: f32) -> Vec4 {
        let f = lambda - LAMBDA_MIN;
        if !(f >= 0.0 && f <= (CMF_SAMPLES - 1) as f32) {
            return Vec4::ZERO;
        }
        let i = (f as usize).min(CMF_SAMPLES - 2);
        let t = f - i as f32;
        self.xyz[i].lerp(self.xyz[i + 1], t)
    }
}

/// CIE 1931 2° colour-matching functions (x̄, ȳ, z̄) at `lambda` nm.
pub fn cie_xyz(lambda: f32) -> Vec3 {
    cmf_table().lookup(lambda).truncate()
}

/// Monte Carlo estimate of a path's XYZ from its four lanes.
///
/// `value` holds each lane's radiance estimate with the multiple-importance weights (for
/// HWSS the balance heuristic over the four lanes, 1/4 each when nothing was dropped)
/// **already applied**, so the lanes are summed, not averaged:
/// XYZ ≈ Σ_k value_k · x̄ȳz̄(λ_k) / (p(λ_k) · [`CIE_Y_INTEGRAL`]) with p = 1/(MAX − MIN).
/// Lanes a caller wants to ignore (monochromatic mode, dropped lanes) must carry 0.
#[inline]
pub fn xyz_estimate(lambda: Vec4, value: Vec4) -> Vec3 {
    let table = cmf_table();
    let l = lambda.to_array();
    let v = value.to_array();
    let mut sum = Vec4::ZERO;
    for k in 0..4 {
        if v[k] != 0.0 {
            sum += v[k] * table.lookup(l[k]);
        }
    }
    sum.truncate() * ((LAMBDA_MAX - LAMBDA_MIN) / CIE_Y_INTEGRAL)
}

/// A CIE illuminant by name: "D65", "A", "F2" (FL2) or "F11" (FL11), case-insensitive.
///
/// The values are the CIE's relative spectral power (D65 and A are 100 at 560 nm), as
/// tabulated (5 nm; D65 and A over 300–780 nm, F2 and F11 over 380–780 nm) and zero outside.
pub fn illuminant(name: &str) -> Option<Spectrum> {
    static TABLES: OnceLock<[Tabulated; 4]> = OnceLock::new();
    let tables = TABLES.get_or_init(|| {
        let parse = |csv: &str, name: &str| {
            let mut cols = parse_csv(csv, name).expect("embedded illuminant table parses");
            assert_eq!(cols.len(), 1, "{name} has one value column");
            cols.pop().unwrap().1
        };
        [
            parse(D65_CSV, "cie_d65.csv"),
            parse(A_CSV, "cie_a.csv"),
            parse(F2_CSV, "cie_f2.csv"),
            parse(F11_CSV, "cie_f11.csv"),
        ]
    });
    let index = match name.to_ascii_uppercase().as_str() {
        "D65" => 0,
        "A" => 1,
        "F2" | "FL2" => 2,
        "F11" | "FL11" => 3,
        _ => return None,
    };
    Some(Spectrum::Tabulated(tables[index].clone()))
}

/// Gauss–Legendre nodes (on [0, 1]) and weights for 3 points.
const GL3: [(f64, f64); 3] = [
    (0.112_701_665_379_258_3, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.887_298_334_620_741_7, 5.0 / 18.0),
];

/// ∫ f(λ) x̄ȳz̄(λ) dλ / [`CIE_Y_INTEGRAL`] over 360–830 nm, by 3-point Gauss–Legendre in
/// every 1 nm cell (accumulated in f64). The colour-matching functions are linear in a
/// cell, so this is exact for any f that is a polynomial of degree ≤ 4 within each
/// whole-nanometre cell (e.g. every table on a 1, 4 or 5 nm grid starting at a whole nm),
/// and far below Monte Carlo noise for smooth spectra.
fn integrate_xyz(f: impl Fn(f32) -> f32) -> Vec3 {
    let table = cmf_table();
    let mut sum = [0.0f64; 3];
    for cell in 0..CMF_SAMPLES - 1 {
        let (a, b) = (table.xyz[cell], table.xyz[cell + 1]);
        for &(node, weight) in &GL3 {
            let lambda = LAMBDA_MIN as f64 + cell as f64 + node;
            let cmf = a.lerp(b, node as f32);
            let l = f64::from(f(lambda as f32)) * weight;
            sum[0] += l * f64::from(cmf.x);
            sum[1] += l * f64::from(cmf.y);
            sum[2] += l * f64::from(cmf.z);
        }
    }
    let norm = f64::from(CIE_Y_INTEGRAL);
    Vec3::new(
        (sum[0] / norm) as f32,
        (sum[1] / norm) as f32,
        (sum[2] / norm) as f32,
    )
}

/// The exact (quadrature) XYZ of a radiance spectrum: ∫ L x̄ȳz̄ dλ / [`CIE_Y_INTEGRAL`], so
/// a constant 1 has Y = 1. The reference that Monte Carlo estimates converge to.
pub fn spectrum_to_xyz(s: &Spectrum) -> Vec3 {
    integrate_xyz(|l| s.eval(l))
}

/// XYZ of the radiance a reflectance `r` sends back under the illuminant `illum`:
/// ∫ r·E x̄ȳz̄ dλ / [`CIE_Y_INTEGRAL`]. This is **not** normalised to the illuminant's white
/// (colorimetry's usual k = 100/∫E ȳ): it is the same normalisation as rendered radiance,
/// so it compares directly with a render of that surface lit by that illuminant. Divide by
/// `spectrum_to_xyz(illum).y` to get the conventional relative colorimetry.
pub fn reflectance_to_xyz(r: &Spectrum, illum: &Spectrum) -> Vec3 {
    integrate_xyz(|l| r.eval(l) * illum.eval(l))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_known_samples() {
        // Rows of the 1 nm table: 555 nm has ȳ = 1, 360 nm the first row.
        assert_eq!(cie_xyz(555.0).y, 1.0);
        assert!((cie_xyz(360.0).x - 1.299e-4).abs() < 1e-9);
        assert!((cie_xyz(560.0).x - 0.5945).abs() < 1e-6);
        assert_eq!(cie_xyz(359.9), Vec3::ZERO);
        assert_eq!(cie_xyz(830.1), Vec3::ZERO);
        assert_eq!(cie_xyz(f32::NAN), Vec3::ZERO);
        assert!(cie_xyz(830.0).x > 0.0);
    }

    #[test]
    fn interpolates_between_nanometres() {
        let mid = cie_xyz(555.5);
        let expect = 0.5 * (cie_xyz(555.0) + cie_xyz(556.0));
        assert!((mid - expect).abs().max_element() < 1e-6);
    }

    #[test]
    fn estimate_sums_lanes() {
        let l = Vec4::new(450.0, 550.0, 650.0, 750.0);
        let one = xyz_estimate(l, Vec4::new(1.0, 0.0, 0.0, 0.0));
        let scale = (LAMBDA_MAX - LAMBDA_MIN) / CIE_Y_INTEGRAL;
        assert!((one - cie_xyz(450.0) * scale).abs().max_element() < 1e-5);
        let all = xyz_estimate(l, Vec4::ONE);
        let expect: Vec3 = l.to_array().map(cie_xyz).iter().sum::<Vec3>() * scale;
        assert!((all - expect).abs().max_element() < 1e-5);
    }

    #[test]
    fn illuminant_names_are_case_insensitive() {
        for name in ILLUMINANT_NAMES {
            assert!(illuminant(name).is_some(), "{name}");
            assert!(illuminant(&name.to_lowercase()).is_some(), "{name}");
        }
        assert!(illuminant("fl11").is_some());
        assert!(illuminant("D50").is_none());
        let d65 = illuminant("d65").unwrap();
        assert_eq!(d65.eval(560.0), 100.0);
        assert_eq!(d65.eval(299.0), 0.0);
        assert_eq!(illuminant("A").unwrap().eval(560.0), 100.0);
    }
}
