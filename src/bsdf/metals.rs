//! Measured complex indices of refraction η + ik of a few metals, built into the binary
//! (`data/metals/*.csv`; their provenance is in `data/metals/README.md`), for
//! `conductor` materials that name one: `metal = "Au"`.

use crate::spectrum::{parse_csv, Spectrum};

/// The metals shipped: symbol, name and the CSV table (wavelength in nm, η, k).
pub const METALS: [(&str, &str, &str); 4] = [
    ("Au", "gold", include_str!("../../data/metals/au.csv")),
    ("Ag", "silver", include_str!("../../data/metals/ag.csv")),
    ("Cu", "copper", include_str!("../../data/metals/cu.csv")),
    ("Al", "aluminium", include_str!("../../data/metals/al.csv")),
];

/// η and k of the metal with chemical symbol `symbol` (case-sensitive, as in the table),
/// or `None` if none is shipped.
pub fn metal(symbol: &str) -> Option<(Spectrum, Spectrum)> {
    let (_, _, csv) = METALS.iter().find(|(s, _, _)| *s == symbol)?;
    let source = format!("data/metals/{}.csv", symbol.to_lowercase());
    // The tables are part of the build and checked by the tests below.
    let mut columns = parse_csv(csv, &source).ok()?;
    let k = columns.pop()?;
    let eta = columns.pop()?;
    Some((Spectrum::Tabulated(eta.1), Spectrum::Tabulated(k.1)))
}

/// The symbols of the shipped metals, for error messages and `stokes info`.
pub fn symbols() -> String {
    METALS.map(|(s, n, _)| format!("\"{s}\" ({n})")).join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_tables_parse_and_cover_the_range() {
        for (s, _, _) in METALS {
            let (eta, k) = metal(s).unwrap_or_else(|| panic!("{s} does not parse"));
            for l in [360.0, 550.0, 830.0] {
                let (e, k) = (eta.eval(l), k.eval(l));
                assert!(
                    e > 0.0 && e < 3.0 && k > 0.5 && k < 12.0,
                    "{s} at {l}: {e} + {k}i"
                );
            }
        }
        assert!(metal("Xx").is_none());
        // Gold: yellow, i.e. its normal-incidence reflectance rises from blue to red.
        let (eta, k) = metal("Au").unwrap();
        let r = |l: f32| {
            let (e, k) = (eta.eval(l), k.eval(l));
            ((e - 1.0).powi(2) + k * k) / ((e + 1.0).powi(2) + k * k)
        };
        assert!(
            r(450.0) < 0.45 && r(650.0) > 0.9,
            "{} {}",
            r(450.0),
            r(650.0)
        );
    }
}
