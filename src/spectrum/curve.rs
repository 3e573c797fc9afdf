//! Tabulated curves and the CSV files they come from.
//!
//! A tabulated spectrum is linear between its samples and **zero outside** its first and
//! last wavelength, as in Mitsuba 3 and pbrt-v4: a reflectance measured over 400–700 nm
//! reflects nothing at 380 nm rather than repeating its end value.
//!
//! CSV layout (what [`read_csv`] accepts):
//! ```text
//! # comments and blank lines are skipped; `#` also starts a comment mid-line
//! nm, white, red, green        <- optional header: wavelength column + value column names
//! 400, 0.343, 0.040, 0.092
//! 404, 0.445, 0.046, 0.097
//! ```
//! Fields are separated by commas (or, on a line with no comma, by whitespace). Without a
//! header the value columns are named `"1"`, `"2"`, ….

use super::{LAMBDA_MIN, NM_CELLS};
use crate::error::{Detail, Error};
use crate::simd::{Float, Lanes, Mask, F4, M4};
use crate::Result;
use glam::Vec4;
use std::path::Path;

/// A piecewise-linear curve over wavelength (nm), zero outside its samples.
#[derive(Clone, Debug, PartialEq)]
pub struct Tabulated {
    wavelengths: Vec<f32>,
    values: Vec<f32>,
    /// `(first wavelength, 1/step)` when the samples are evenly spaced, so that evaluation
    /// is a direct index instead of a binary search (all CIE and most measured tables).
    uniform: Option<(f32, f32)>,
    /// The curve at every integer nm of [MIN, MAX] when every sample
    /// lies on an integer nm (most measured tables): the same piecewise-linear function
    /// (each cell of 1 nm lies within one of its pieces), evaluated with one index and no
    /// division, the renderer's hot path. Cell k holds the values at both its ends, so a
    /// lane reads one pair.
    nm: Option<Box<[[f32; 2]]>>,
}

impl Tabulated {
    /// Checks the table: at least one sample, as many values as wavelengths, finite
    /// numbers, strictly increasing wavelengths.
    pub fn new(wavelengths: Vec<f32>, values: Vec<f32>) -> Result<Tabulated, Detail> {
        if wavelengths.len() != values.len() {
            return Err(Detail::Text(format!(
                "tabulated spectrum has {} wavelengths but {} values",
                wavelengths.len(),
                values.len()
            )));
        }
        if wavelengths.is_empty() {
            return Err("tabulated spectrum needs at least one sample, found none".into());
        }
        for (i, (&w, &v)) in wavelengths.iter().zip(&values).enumerate() {
            if !w.is_finite() {
                return Err(Detail::Text(format!(
                    "tabulated spectrum: wavelength at index {i} is not finite ({w})"
                )));
            }
            if !v.is_finite() {
                return Err(Detail::Text(format!(
                    "tabulated spectrum: value at index {i} ({w} nm) is not finite ({v})"
                )));
            }
        }
        for (i, pair) in wavelengths.windows(2).enumerate() {
            if pair[1] <= pair[0] {
                let what = if pair[1] == pair[0] {
                    "duplicates"
                } else {
                    "is smaller than"
                };
                return Err(Detail::Text(format!(
                    "tabulated spectrum: wavelengths must be strictly increasing, but index {} \
                     ({} nm) {what} index {i} ({} nm)",
                    i + 1,
                    pair[1],
                    pair[0]
                )));
            }
        }
        Ok(Tabulated::with_grids(wavelengths, values))
    }

    pub fn wavelengths(&self) -> &[f32] {
        &self.wavelengths
    }

    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// A checked table with its evaluation grids.
    fn with_grids(wavelengths: Vec<f32>, values: Vec<f32>) -> Tabulated {
        let uniform = uniform_grid(&wavelengths);
        let mut t = Tabulated {
            wavelengths,
            values,
            uniform,
            nm: None,
        };
        if t.wavelengths.iter().all(|w| w.fract() == 0.0) {
            let at = |k: usize| t.eval_samples(LAMBDA_MIN + k as f32);
            let table = (0..NM_CELLS).map(|k| [at(k), at(k + 1)]);
            t.nm = Some(table.collect());
        }
        t
    }

    /// The same curve with every value multiplied by `s`.
    pub fn scaled(&self, s: f32) -> Tabulated {
        let values = self.values.iter().map(|v| v * s).collect();
        Tabulated::with_grids(self.wavelengths.clone(), values)
    }

    /// Linear interpolation between samples, zero outside `[first, last]`.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        self.eval_w(lambda, true)
    }

    /// [`Tabulated::eval`] from the samples themselves.
    fn eval_samples(&self, lambda: f32) -> f32 {
        let w = &self.wavelengths;
        let n = w.len();
        // Written so that NaN also lands here and gives 0.
        if !(lambda >= w[0] && lambda <= w[n - 1]) {
            return 0.0;
        }
        if n == 1 {
            return self.values[0];
        }
        // The interval i with w[i] <= λ <= w[i+1], i in 0..n-1.
        let i = match self.uniform {
            Some((start, inv_step)) => (((lambda - start) * inv_step) as usize).min(n - 2),
            None => (w.partition_point(|&x| x <= lambda) - 1).min(n - 2),
        };
        // On a uniform grid the rounded index can be one cell off right at a knot; the
        // weight below then lies just outside [0, 1] and extends the neighbouring segment,
        // which meets this one at the knot, so the value is still right.
        let t = (lambda - w[i]) / (w[i + 1] - w[i]);
        let (v0, v1) = (self.values[i], self.values[i + 1]);
        v0 + t * (v1 - v0)
    }

    /// [`Tabulated::eval`] at four wavelengths in one SIMD evaluation: [`Self::eval_w`] at
    /// width 4 across the wavelengths instead of the paths, so the same bits as four
    /// `eval`s (every width runs the same arithmetic) for a quarter of the instructions.
    #[inline]
    pub fn eval4(&self, lambda: Vec4) -> Vec4 {
        let v = self.eval_w(F4::from_fn(|k| lambda[k]), M4::splat(true));
        Vec4::from_array(v.0.to_array())
    }

    /// [`Tabulated::eval`] for the W paths of `m` (0 elsewhere), all at once on the
    /// integer-nm table; path by path from the samples where there is none.
    #[inline(always)]
    pub fn eval_w<F: Float>(&self, lambda: F, m: F::Mask) -> F {
        let w = &self.wavelengths;
        let inside = m & lambda.ge(F::splat(w[0])) & lambda.le(F::splat(w[w.len() - 1]));
        let Some(nm) = self.nm.as_deref() else {
            return F::from_fn(|i| match inside.get(i) {
                true => self.eval_samples(lambda.get(i)),
                false => 0.0,
            });
        };
        // x is exact (λ and 360 are within a factor of two of x's scale), and so is t:
        // the same t as from the samples, since every cell is 1 nm wide.
        let x = lambda - F::splat(LAMBDA_MIN);
        let on_table = x.ge(F::splat(0.0)) & x.le(F::splat(NM_CELLS as f32));
        let cell = x
            .floor()
            .max(F::splat(0.0))
            .min(F::splat((NM_CELLS - 1) as f32));
        let k = cell.to_index();
        let ends: F::Arr<[f32; 2]> = Lanes::from_fn(|i| nm[k[i] as usize]);
        let (v0, v1) = (F::from_fn(|i| ends[i][0]), F::from_fn(|i| ends[i][1]));
        let t = x - cell;
        let v = (v0 + t * (v1 - v0)).masked(inside);
        let off = inside & !on_table;
        if off.none() {
            return v;
        }
        F::select(off, F::from_fn(|i| self.eval_samples(lambda.get(i))), v)
    }

    /// The largest value over `[lo, hi]`: the curve is piecewise linear, so the maximum sits
    /// on a sample or at an end of the interval.
    pub fn max_over(&self, lo: f32, hi: f32) -> f32 {
        let inner = self
            .wavelengths
            .iter()
            .zip(&self.values)
            .filter(|(&w, _)| w >= lo && w <= hi)
            .map(|(_, &v)| v);
        inner.fold(self.eval(lo).max(self.eval(hi)), f32::max)
    }

    /// The largest |value| over `[lo, hi]`.
    pub fn max_abs_over(&self, lo: f32, hi: f32) -> f32 {
        let inner = self
            .wavelengths
            .iter()
            .zip(&self.values)
            .filter(|(&w, _)| w >= lo && w <= hi)
            .map(|(_, &v)| v.abs());
        inner.fold(self.eval(lo).abs().max(self.eval(hi).abs()), f32::max)
    }
}

/// `(start, 1/step)` when every spacing equals the mean step to 1e-4 relative.
fn uniform_grid(w: &[f32]) -> Option<(f32, f32)> {
    let n = w.len();
    if n < 2 {
        return None;
    }
    let step = (f64::from(w[n - 1]) - f64::from(w[0])) / (n - 1) as f64;
    let even = w
        .windows(2)
        .all(|p| ((f64::from(p[1]) - f64::from(p[0])) - step).abs() <= 1e-4 * step);
    even.then(|| (w[0], (1.0 / step) as f32))
}

/// Reads every value column of a CSV file (see the module docs for the layout).
///
/// Errors name the file and line, e.g. `cbox.csv:17: expected a number in column 3, found 'abc'`.
pub fn read_csv(path: &Path) -> Result<Vec<(String, Tabulated)>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::file(path, None, format!("cannot read: {e}")))?;
    parse_csv(&text, &path.display().to_string())
}

/// One column of a CSV file: the column called `column`, or the only value column when
/// `column` is `None`.
pub fn csv_column(path: &Path, column: Option<&str>) -> Result<Tabulated> {
    let columns = read_csv(path)?;
    pick_column(columns, column, &path.display().to_string())
}

fn pick_column(
    columns: Vec<(String, Tabulated)>,
    column: Option<&str>,
    source: &str,
) -> Result<Tabulated> {
    let names = || {
        columns
            .iter()
            .map(|(n, _)| format!("'{n}'"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match column {
        None if columns.len() == 1 => Ok(columns.into_iter().next().unwrap().1),
        None => Err(Error::file(
            source,
            None,
            format!(
                "has {} value columns ({}); name the one to use",
                columns.len(),
                names()
            ),
        )),
        Some(name) => {
            let available = names();
            columns
                .into_iter()
                .find(|(n, _)| n == name)
                .map(|(_, t)| t)
                .ok_or_else(|| {
                    Error::file(
                        source,
                        None,
                        format!("no column named '{name}'; available: {available}"),
                    )
                })
        }
    }
}

/// Parses CSV text; `source` (usually the file name) is the file every error names.
pub fn parse_csv(text: &str, source: &str) -> Result<Vec<(String, Tabulated)>> {
    let at = |line: usize, detail: Detail| Error::file(source, Some(line), detail);
    let mut names: Option<Vec<String>> = None;
    let mut wavelengths: Vec<f32> = Vec::new();
    let mut columns: Vec<Vec<f32>> = Vec::new();
    let mut last_line = 0;
    let mut seen_first = false;

    for (index, raw) in text.lines().enumerate() {
        let line_no = index + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let fields: Vec<&str> = if line.contains(',') {
            line.split(',').map(str::trim).collect()
        } else {
            line.split_whitespace().collect()
        };
        if !seen_first {
            seen_first = true;
            if fields[0].parse::<f32>().is_err() {
                // A header row: the first field names the wavelength column.
                if fields.len() < 2 {
                    return Err(at(
                        line_no,
                        Detail::expected(
                            "a header with a wavelength column and at least one value column",
                            format!("'{line}'"),
                        ),
                    ));
                }
                names = Some(fields[1..].iter().map(|s| s.to_string()).collect());
                columns = vec![Vec::new(); fields.len() - 1];
                continue;
            }
            if fields.len() < 2 {
                return Err(at(
                    line_no,
                    Detail::expected("a wavelength and at least one value", format!("'{line}'")),
                ));
            }
            columns = vec![Vec::new(); fields.len() - 1];
        }
        let expected = columns.len() + 1;
        if fields.len() != expected {
            return Err(at(
                line_no,
                Detail::expected(
                    format!("{expected} columns (wavelength + {} values)", expected - 1),
                    fields.len(),
                ),
            ));
        }
        let mut numbers = Vec::with_capacity(expected);
        for (c, field) in fields.iter().enumerate() {
            let v: f32 = field.parse().map_err(|_| {
                at(
                    line_no,
                    Detail::expected(
                        format!("a number in column {}", c + 1),
                        format!("'{field}'"),
                    ),
                )
            })?;
            if !v.is_finite() {
                return Err(at(
                    line_no,
                    Detail::expected(
                        format!("a finite number in column {}", c + 1),
                        format!("'{field}'"),
                    ),
                ));
            }
            numbers.push(v);
        }
        if let Some(&prev) = wavelengths.last() {
            if numbers[0] <= prev {
                return Err(at(
                    line_no,
                    Detail::Text(format!(
                        "wavelengths must be strictly increasing, but {} nm follows {prev} nm \
                         on line {last_line}",
                        numbers[0]
                    )),
                ));
            }
        }
        wavelengths.push(numbers[0]);
        for (col, &v) in columns.iter_mut().zip(&numbers[1..]) {
            col.push(v);
        }
        last_line = line_no;
    }

    if wavelengths.is_empty() {
        return Err(Error::file(source, None, "no data rows"));
    }
    let names = names.unwrap_or_else(|| (1..=columns.len()).map(|i| i.to_string()).collect());
    names
        .into_iter()
        .zip(columns)
        .map(|(name, values)| {
            Tabulated::new(wavelengths.clone(), values)
                .map(|t| (name.clone(), t))
                .map_err(|e| Error::file(source, None, format!("column '{name}': {e}")))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(w: &[f32], v: &[f32]) -> Tabulated {
        Tabulated::new(w.to_vec(), v.to_vec()).unwrap()
    }

    #[test]
    fn interpolates_and_is_zero_outside() {
        let c = t(&[400.0, 500.0, 600.0], &[1.0, 3.0, 2.0]);
        assert_eq!(c.eval(400.0), 1.0);
        assert_eq!(c.eval(500.0), 3.0);
        assert_eq!(c.eval(600.0), 2.0);
        assert!((c.eval(450.0) - 2.0).abs() < 1e-6);
        assert!((c.eval(575.0) - 2.25).abs() < 1e-6);
        assert_eq!(c.eval(399.99), 0.0);
        assert_eq!(c.eval(600.01), 0.0);
        assert_eq!(c.eval(f32::NAN), 0.0);
    }

    #[test]
    fn uniform_and_irregular_grids_agree() {
        let w: Vec<f32> = (0..61).map(|i| 400.0 + 5.0 * i as f32).collect();
        let v: Vec<f32> = w.iter().map(|x| (x * 0.037).sin()).collect();
        let uniform = Tabulated::new(w.clone(), v.clone()).unwrap();
        assert!(uniform.uniform.is_some());
        let mut irregular = uniform.clone();
        irregular.uniform = None;
        let mut l = 395.0;
        while l < 705.0 {
            assert!(
                (uniform.eval(l) - irregular.eval(l)).abs() < 1e-5,
                "λ = {l}: {} vs {}",
                uniform.eval(l),
                irregular.eval(l)
            );
            l += 0.37;
        }
        for &x in &w {
            assert!((uniform.eval(x) - irregular.eval(x)).abs() < 1e-6);
        }
    }

    #[test]
    fn irregular_grid_is_detected() {
        let c = t(&[400.0, 410.0, 430.0], &[0.0, 1.0, 0.0]);
        assert!(c.uniform.is_none());
        assert!((c.eval(420.0) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn single_sample_is_a_point() {
        let c = t(&[500.0], &[2.0]);
        assert_eq!(c.eval(500.0), 2.0);
        assert_eq!(c.eval(500.5), 0.0);
    }

    #[test]
    fn rejects_bad_tables() {
        let e = Tabulated::new(vec![400.0, 500.0, 450.0], vec![0.0; 3])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("index 2") && e.contains("450") && e.contains("500"),
            "{e}"
        );
        let e = Tabulated::new(vec![400.0, 400.0], vec![0.0; 2])
            .unwrap_err()
            .to_string();
        assert!(e.contains("duplicates"), "{e}");
        let e = Tabulated::new(vec![400.0], vec![0.0; 2])
            .unwrap_err()
            .to_string();
        assert!(e.contains("1 wavelengths but 2 values"), "{e}");
        let e = Tabulated::new(vec![], vec![]).unwrap_err().to_string();
        assert!(e.contains("at least one sample"), "{e}");
        let e = Tabulated::new(vec![400.0, 500.0], vec![0.0, f32::NAN])
            .unwrap_err()
            .to_string();
        assert!(e.contains("index 1") && e.contains("not finite"), "{e}");
        let e = Tabulated::new(vec![f32::INFINITY], vec![0.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("wavelength at index 0"), "{e}");
    }

    #[test]
    fn max_over_finds_knots_and_ends() {
        let c = t(&[400.0, 500.0, 600.0], &[1.0, 3.0, 2.0]);
        assert_eq!(c.max_over(360.0, 830.0), 3.0);
        assert_eq!(c.max_over(550.0, 830.0), 2.5);
        let neg = t(&[400.0, 500.0], &[-4.0, 1.0]);
        assert_eq!(neg.max_abs_over(360.0, 830.0), 4.0);
    }

    #[test]
    fn parses_header_comments_and_blank_lines() {
        let text = "# measured\n\nnm, white, red\n400, 0.5, 0.1 # first\n\n410, 0.6, 0.2\n";
        let cols = parse_csv(text, "x.csv").unwrap();
        assert_eq!(cols.len(), 2);
        assert_eq!(cols[0].0, "white");
        assert_eq!(cols[1].0, "red");
        assert_eq!(cols[1].1.wavelengths(), &[400.0, 410.0]);
        assert_eq!(cols[1].1.values(), &[0.1, 0.2]);
    }

    #[test]
    fn headerless_columns_are_numbered() {
        let cols = parse_csv("400 1 2\n500 3 4\n", "y.txt").unwrap();
        let names: Vec<_> = cols.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["1", "2"]);
        assert_eq!(cols[1].1.values(), &[2.0, 4.0]);
    }

    #[test]
    fn csv_errors_name_file_line_and_column() {
        let e = parse_csv("nm,a,b\n400,1,2\n410,1,abc\n", "cbox.csv")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "cbox.csv:3: expected a number in column 3, found 'abc'");
        let e = parse_csv("400,1,2\n\n410,1\n", "f.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("f.csv:3: expected 3 columns"), "{e}");
        let e = parse_csv("400,1\n# c\n390,1\n", "g.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("g.csv:3:") && e.contains("line 1"), "{e}");
        let e = parse_csv("# only a comment\n", "h.csv")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "h.csv: no data rows");
        let e = parse_csv("400,nan\n", "i.csv").unwrap_err().to_string();
        assert!(
            e.starts_with("i.csv:1: expected a finite number in column 2"),
            "{e}"
        );
    }

    #[test]
    fn picks_columns_by_name() {
        let cols = || parse_csv("nm,a,b\n400,1,2\n", "p.csv").unwrap();
        assert_eq!(
            pick_column(cols(), Some("b"), "p.csv").unwrap().values(),
            &[2.0]
        );
        let e = pick_column(cols(), None, "p.csv").unwrap_err().to_string();
        assert!(e.contains("'a', 'b'"), "{e}");
        let e = pick_column(cols(), Some("c"), "p.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no column named 'c'") && e.contains("'a', 'b'"),
            "{e}"
        );
        let one = parse_csv("400,7\n", "q.csv").unwrap();
        assert_eq!(pick_column(one, None, "q.csv").unwrap().values(), &[7.0]);
    }
}
