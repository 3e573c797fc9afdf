//! Reading a measured re-radiation matrix from CSV text (format in the parent module docs).

use super::{Reradiation, MAX_CELLS};
use crate::error::{Detail, Error};
use crate::spectrum::{Spectrum, Tabulated, LAMBDA_MAX};
use crate::Result;

/// What the importer changed: entries set to 0. Each clamped entry is counted once; one
/// that is both negative and below the diagonal counts as anti-Stokes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImportReport {
    /// Negative entries on or above the diagonal (a negative diagonal entry makes D = 0
    /// at that cell centre).
    pub clamped_negative: usize,
    /// Non-zero entries below the diagonal (emission shorter than excitation).
    pub clamped_anti_stokes: usize,
}

impl ImportReport {
    /// Whether nothing was changed.
    pub fn is_clean(&self) -> bool {
        self.clamped_negative == 0 && self.clamped_anti_stokes == 0
    }
}

impl std::fmt::Display for ImportReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "set {} negative and {} anti-Stokes (emission shorter than excitation) entries to 0",
            self.clamped_negative, self.clamped_anti_stokes
        )
    }
}

/// Splits a line into fields: by commas when there is one, else by whitespace.
fn fields(line: &str) -> Vec<&str> {
    if line.contains(',') {
        line.split(',').map(str::trim).collect()
    } else {
        line.split_whitespace().collect()
    }
}

/// An error at line `line_no` of `source`.
fn at(source: &str, line_no: usize, detail: impl Into<Detail>) -> Error {
    Error::file(source, Some(line_no), detail)
}

fn number(field: &str, source: &str, line_no: usize, column: usize) -> Result<f32> {
    let v: f32 = field.parse().map_err(|_| {
        at(
            source,
            line_no,
            Detail::expected(format!("a number in column {column}"), format!("'{field}'")),
        )
    })?;
    if !v.is_finite() {
        return Err(at(
            source,
            line_no,
            Detail::expected(
                format!("a finite number in column {column}"),
                format!("'{field}'"),
            ),
        ));
    }
    Ok(v)
}

pub(super) fn parse(text: &str, source: &str) -> Result<(Reradiation, ImportReport)> {
    // The header: (line number, emission cell centres).
    let mut header: Option<(usize, Vec<f32>)> = None;
    let mut rows: Vec<Vec<f32>> = Vec::new();
    let mut last_line = 0;

    for (index, raw) in text.lines().enumerate() {
        let line_no = index + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let fields = fields(line);
        let Some((header_line, centres)) = &header else {
            if fields[0].parse::<f32>().is_ok() {
                return Err(at(
                    source,
                    line_no,
                    Detail::expected(
                        "a header line 'nm, <emission wavelengths>' (a label, then the \
                         emission cell centres in nm)",
                        "a number in column 1",
                    ),
                ));
            }
            if fields.len() < 3 {
                return Err(at(
                    source,
                    line_no,
                    Detail::expected(
                        "a header line 'nm, <emission wavelengths>' with at least 2 wavelengths",
                        format!("{} field(s)", fields.len()),
                    ),
                ));
            }
            let mut w = Vec::with_capacity(fields.len() - 1);
            for (c, field) in fields.iter().enumerate().skip(1) {
                w.push(number(field, source, line_no, c + 1)?);
            }
            check_grid(&w, source, line_no)?;
            header = Some((line_no, w));
            continue;
        };
        let n = centres.len();
        if fields.len() != n + 1 {
            return Err(at(
                source,
                line_no,
                Detail::expected(
                    format!(
                        "{} fields (an excitation wavelength, then one entry for each of the {n} \
                         emission wavelengths of the header on line {header_line})",
                        n + 1
                    ),
                    fields.len(),
                ),
            ));
        }
        let r = rows.len();
        if r == n {
            return Err(at(
                source,
                line_no,
                format!(
                    "one excitation row too many: the header on line {header_line} has {n} \
                     emission wavelengths and the excitation and emission grids must be the \
                     same"
                ),
            ));
        }
        let mut row = Vec::with_capacity(n + 1);
        for (c, field) in fields.iter().enumerate() {
            row.push(number(field, source, line_no, c + 1)?);
        }
        let h = (centres[n - 1] - centres[0]) / (n - 1) as f32;
        if (row[0] - centres[r]).abs() > 1e-3 * h {
            return Err(at(
                source,
                line_no,
                format!(
                    "excitation wavelength {} nm differs from the emission grid: row {} must \
                     be at {} nm (the excitation wavelengths must be the emission wavelengths \
                     of the header on line {header_line}, in order)",
                    row[0],
                    r + 1,
                    centres[r]
                ),
            ));
        }
        rows.push(row);
        last_line = line_no;
    }

    let Some((header_line, centres)) = header else {
        return Err(Error::file(
            source,
            None,
            "no data: expected a header line 'nm, <emission wavelengths>' and one row per \
             excitation wavelength",
        ));
    };
    let n = centres.len();
    if rows.len() < n {
        let line_no = if rows.is_empty() {
            header_line
        } else {
            last_line
        };
        return Err(at(
            source,
            line_no,
            format!(
                "the matrix ends after {} excitation row(s), but the header on line \
                 {header_line} has {n} emission wavelengths (the excitation and emission grids \
                 must be the same; the next row should be at {} nm)",
                rows.len(),
                centres[rows.len()]
            ),
        ));
    }

    let m: Vec<Vec<f32>> = rows.iter().map(|r| r[1..].to_vec()).collect();
    square(&centres, &m, source, false)
}

/// The re-radiation of a square matrix `m[i][o]` (excitation cell i, emission cell o) on
/// the evenly spaced cell centres `centres`: negatives and anti-Stokes entries set to 0
/// and counted, the diagonal as D, the rest as F = m/h. D is held constant out to the
/// outer cell edges, and with `hold_to_range` on to the end of the rendered range.
pub(super) fn square(
    centres: &[f32],
    m: &[Vec<f32>],
    source: &str,
    hold_to_range: bool,
) -> Result<(Reradiation, ImportReport)> {
    let n = centres.len();
    let h = (centres[n - 1] - centres[0]) / (n - 1) as f32;
    let mut report = ImportReport::default();
    let mut diag = Vec::with_capacity(n);
    let mut f = vec![0.0f32; n * n];
    for (i, row) in m.iter().enumerate() {
        for (o, &v) in row.iter().enumerate() {
            let v = if o < i && v != 0.0 {
                report.clamped_anti_stokes += 1;
                0.0
            } else if v < 0.0 {
                report.clamped_negative += 1;
                0.0
            } else {
                v
            };
            if o == i {
                diag.push(v);
            } else if o > i {
                f[i * n + o] = v / h;
            }
        }
    }

    // D through the cell centres, held constant out to the outer cell edges.
    let mut knots = Vec::with_capacity(n + 2);
    knots.push(centres[0] - 0.5 * h);
    knots.extend_from_slice(centres);
    knots.push(centres[n - 1] + 0.5 * h);
    let mut values = Vec::with_capacity(n + 2);
    values.push(diag[0]);
    values.extend_from_slice(&diag);
    values.push(diag[n - 1]);
    if hold_to_range && knots[n + 1] < LAMBDA_MAX {
        knots.push(LAMBDA_MAX);
        values.push(diag[n - 1]);
    }
    let d = Tabulated::new(knots, values)
        .map_err(|e| Error::file(source, None, format!("diagonal: {e}")))?;

    let mut r = Reradiation::diagonal_only(Spectrum::Tabulated(d));
    r.set_grid(centres[0] - 0.5 * h, h, n);
    r.set_matrix(f);
    Ok((r, report))
}

/// Checks that the cell centres are increasing and evenly spaced (to 0.1% of a step).
fn check_grid(w: &[f32], source: &str, line_no: usize) -> Result<()> {
    let n = w.len();
    if n > MAX_CELLS {
        return Err(at(
            source,
            line_no,
            format!("{n} emission wavelengths is more than the {MAX_CELLS} cells supported"),
        ));
    }
    let h = (f64::from(w[n - 1]) - f64::from(w[0])) / (n - 1) as f64;
    if h <= 0.0 {
        return Err(at(
            source,
            line_no,
            format!(
                "emission wavelengths must increase, found {} nm first and {} nm last",
                w[0],
                w[n - 1]
            ),
        ));
    }
    for (k, &x) in w.iter().enumerate() {
        let expected = f64::from(w[0]) + k as f64 * h;
        if (f64::from(x) - expected).abs() > 1e-3 * h {
            return Err(at(
                source,
                line_no,
                format!(
                    "emission wavelengths must be evenly spaced (one per cell): column {} has \
                     {x} nm where a uniform grid from {} to {} nm in steps of {} nm has {} nm",
                    k + 2,
                    w[0],
                    w[n - 1],
                    h as f32,
                    expected as f32
                ),
            ));
        }
    }
    Ok(())
}
