//! The medians, quantiles and paired ratios the `bench` subcommands report.

use serde::Serialize;

/// The `p`-quantile of `v` (0 ≤ p ≤ 1), linear between order statistics (NumPy's default,
/// Python's `statistics.quantiles(method="inclusive")`); NaN for no values.
pub fn quantile(v: &[f64], p: f64) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    sorted_quantile(&v, p)
}

/// The median of `v` (the mean of the middle two for an even count); NaN for no values.
pub fn median(v: &[f64]) -> f64 {
    quantile(v, 0.5)
}

/// [`quantile`] of values already in ascending order.
fn sorted_quantile(v: &[f64], p: f64) -> f64 {
    let Some(last) = v.len().checked_sub(1) else {
        return f64::NAN;
    };
    let x = p * last as f64;
    let (i, t) = (x.floor() as usize, x.fract());
    match v.get(i + 1) {
        Some(next) => v[i] + t * (next - v[i]),
        None => v[i],
    }
}

/// The median and quartiles of some ratios.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spread {
    pub median: f64,
    /// Lower quartile.
    pub q1: f64,
    /// Upper quartile.
    pub q3: f64,
}

/// The spread of the paired ratios `a[i] / b[i]` (runs of the same repetition).
pub fn paired(a: &[f64], b: &[f64]) -> Spread {
    let mut r: Vec<f64> = a.iter().zip(b).map(|(x, y)| x / y).collect();
    r.sort_by(f64::total_cmp);
    Spread {
        median: sorted_quantile(&r, 0.5),
        q1: sorted_quantile(&r, 0.25),
        q3: sorted_quantile(&r, 0.75),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Quantiles interpolate between order statistics as NumPy's default does, in any
    /// input order.
    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let v = [4.0, 1.0, 3.0, 2.0];
        assert_eq!(quantile(&v, 0.5), 2.5);
        assert_eq!(quantile(&v, 0.25), 1.75);
        assert_eq!(quantile(&v, 0.75), 3.25);
        assert_eq!(quantile(&v, 0.0), 1.0);
        assert_eq!(quantile(&v, 1.0), 4.0);
        assert_eq!(quantile(&[7.0], 0.25), 7.0);
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert!(median(&[]).is_nan());
    }

    /// A paired ratio divides each run by the run of its own repetition: where a load
    /// slows both runs of a repetition, the pairs keep their ratio while the ratio of the
    /// medians moves.
    #[test]
    fn paired_ratios_divide_out_what_a_repetition_shares() {
        let single = [1.0, 0.5, 1.0, 0.5, 0.5];
        let packet = [1.5, 0.75, 1.5, 0.75, 0.75];
        let p = paired(&packet, &single);
        assert_eq!((p.q1, p.median, p.q3), (1.5, 1.5, 1.5));
        // The ratio of the medians agrees here (0.75 / 0.5). When the load falls on
        // different repetitions in the two figures' runs, it no longer does, while the
        // pairs still read 1.5.
        let (single, packet) = ([1.0, 1.0, 1.0, 0.5, 0.5], [1.5, 0.75, 0.75, 0.75, 0.75]);
        assert_eq!(median(&packet) / median(&single), 0.75);
        assert_eq!(paired(&packet, &single).median, 1.5);
    }
}
