//! A piecewise-constant density on the unit square over a grid of cells, sampled by
//! inversion: a row from the marginal distribution of rows, then a column from that
//! row's conditional distribution, each continuous within its cell (pbrt's
//! `PiecewiseConstant2D`, written out here). The environment map samples directions with
//! it, weighing each texel by its luminance × sin θ.

/// A density on [0, 1)² proportional to non-negative cell weights.
#[derive(Debug, Clone)]
pub struct Piecewise2d {
    width: usize,
    height: usize,
    /// Per row, the cumulative weights of its cells, normalised (last = 1); a row of zero
    /// weight is uniform.
    conditional: Vec<f64>,
    /// Cumulative row weights, normalised (last = 1).
    marginal: Vec<f64>,
    /// Each cell's density: weight × cells / total weight.
    density: Vec<f32>,
}

impl Piecewise2d {
    /// Bytes its tables take: two cumulative tables in f64 and the density in f32.
    pub fn memory(&self) -> usize {
        (self.conditional.len() + self.marginal.len()) * std::mem::size_of::<f64>()
            + self.density.len() * std::mem::size_of::<f32>()
    }

    /// The density of the `width` × `height` grid of `weights` (row by row, all finite and
    /// ≥ 0); `None` if their sum is zero or not finite.
    pub fn new(width: usize, height: usize, weights: &[f64]) -> Option<Piecewise2d> {
        assert_eq!(weights.len(), width * height);
        let total: f64 = weights.iter().sum();
        if !(total.is_finite() && total > 0.0) || width == 0 {
            return None;
        }
        let mut conditional = Vec::with_capacity(width * height);
        let mut rows = Vec::with_capacity(height);
        for row in weights.chunks(width) {
            let sum: f64 = row.iter().sum();
            let mut acc = 0.0;
            for (k, w) in row.iter().enumerate() {
                acc += if sum > 0.0 {
                    w / sum
                } else {
                    1.0 / width as f64
                };
                conditional.push(if k + 1 == width { 1.0 } else { acc });
            }
            rows.push(sum);
        }
        let mut acc = 0.0;
        let marginal = rows
            .iter()
            .enumerate()
            .map(|(k, s)| {
                acc += s / total;
                if k + 1 == height {
                    1.0
                } else {
                    acc
                }
            })
            .collect();
        let cells = (width * height) as f64;
        let density = weights.iter().map(|w| (w / total * cells) as f32).collect();
        Some(Piecewise2d {
            width,
            height,
            conditional,
            marginal,
            density,
        })
    }

    /// A point (x, y) in [0, 1)² from two uniforms, its cell (column, row) and its
    /// density.
    pub fn sample(&self, u: [f32; 2]) -> ([f32; 2], [usize; 2], f32) {
        let (row, fy) = invert(&self.marginal, f64::from(u[1]));
        let cdf = &self.conditional[row * self.width..(row + 1) * self.width];
        let (col, fx) = invert(cdf, f64::from(u[0]));
        let x = ((col as f64 + fx) / self.width as f64) as f32;
        let y = ((row as f64 + fy) / self.height as f64) as f32;
        let pdf = self.density[row * self.width + col];
        ([x.min(ONE_BELOW), y.min(ONE_BELOW)], [col, row], pdf)
    }

    /// The cell holding point (x, y) of the unit square.
    pub fn cell(&self, x: f32, y: f32) -> [usize; 2] {
        let col = ((x * self.width as f32) as usize).min(self.width - 1);
        let row = ((y * self.height as f32) as usize).min(self.height - 1);
        [col, row]
    }

    /// The density at point (x, y).
    pub fn pdf(&self, x: f32, y: f32) -> f32 {
        let [col, row] = self.cell(x, y);
        self.density[row * self.width + col]
    }
}

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// The cell of the normalised cumulative distribution `cdf` where uniform `u` falls, and
/// how far into it (0..1).
fn invert(cdf: &[f64], u: f64) -> (usize, f64) {
    let k = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
    let lo = if k == 0 { 0.0 } else { cdf[k - 1] };
    let width = cdf[k] - lo;
    let f = if width > 0.0 { (u - lo) / width } else { 0.0 };
    (k, f.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point that would round up to 1 in f32 stays inside [0, 1)² (the environment map
    /// turns x = 1 into the seam and y = 1 into the pole).
    #[test]
    fn samples_stay_below_one() {
        // All the weight in the last column: u just below 1 lands 2⁻²⁶ below x = 1.
        let d = Piecewise2d::new(4, 1, &[0.0, 0.0, 0.0, 1.0]).unwrap();
        let below_one = f32::from_bits(1.0f32.to_bits() - 1);
        let ([x, y], cell, _) = d.sample([below_one, below_one]);
        assert_eq!(cell, [3, 0]);
        assert_eq!((x, y), (below_one, below_one));
    }

    #[test]
    fn cells_are_chosen_in_proportion_to_their_weights() {
        let d = Piecewise2d::new(2, 2, &[1.0, 3.0, 0.0, 4.0]).unwrap();
        // Density = weight × 4 / 8.
        assert_eq!(d.pdf(0.25, 0.25), 0.5);
        assert_eq!(d.pdf(0.75, 0.25), 1.5);
        assert_eq!(d.pdf(0.25, 0.75), 0.0);
        assert_eq!(d.pdf(0.75, 0.75), 2.0);
        // u₁ < ½ picks the first row (weight 4 of 8), then u₀ < ¼ its first cell.
        let (p, cell, pdf) = d.sample([0.125, 0.25]);
        assert_eq!(cell, [0, 0]);
        assert_eq!(pdf, 0.5);
        assert!(
            (p[0] - 0.25).abs() < 1e-6 && (p[1] - 0.25).abs() < 1e-6,
            "{p:?}"
        );
        let (_, cell, _) = d.sample([0.5, 0.75]);
        assert_eq!(cell, [1, 1]);
        assert!(Piecewise2d::new(1, 1, &[0.0]).is_none());
    }
}
