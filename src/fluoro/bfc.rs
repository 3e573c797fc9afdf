//! Reading measured bispectral matrices in the Labsphere BFC-450 text format, as the RIT
//! bispectral database distributes them.
//!
//! ```text
//! VEC_01  5167                              <- line 1: the format's tag
//! BFC-450 Matrix File                       <- line 2
//! ;name.BFC                                 <- `;` comments: file, sample, operator, ...
//! 380  780  10  49  300  10                 <- emission start, end, step (nm); number of
//!                                              excitation columns, their start and step
//! r:c:  300  310  ...  780                  <- the excitation wavelengths
//! 380  m(300→380)  m(310→380) ...           <- one row per emission wavelength: the
//! ...                                          re-radiated fraction from each excitation
//! EOD                                       <- optional end mark
//! ```
//!
//! Fields are separated by tabs or spaces. Entry (emission λo, excitation λi) is the
//! fraction of spectral radiance at λi re-emitted at λo (λo = λi: the ordinary
//! reflectance), the same quantity as the CSV format's m[i][o] (module docs of
//! [`super`]). The importer puts the matrix on the square grid of the excitation
//! wavelengths inside the renderer's range (10 nm cells centred at 360 … 780 nm for the
//! database's files), and reports what that changes ([`BfcReport`]): excitation columns
//! below 360 nm dropped (the renderer does not trace them), emission rows below 360 nm
//! dropped, emission that was not measured on the grid (no re-emission there, the
//! diagonal held at the nearest measured row's), the diagonal held at its last value
//! from the last cell's edge up to 830 nm, and, as for CSV, negative noise and
//! anti-Stokes entries set to 0. Excitation that ends before the emission does is an
//! error: the reflectance (the diagonal) there was never measured.

use super::import::{self, ImportReport};
use super::{Reradiation, MAX_CELLS};
use crate::error::{Detail, Error};
use crate::spectrum::{LAMBDA_MAX, LAMBDA_MIN};
use crate::Result;
use std::fmt;

/// What importing a BFC file changed or left out.
#[derive(Debug, Clone, PartialEq)]
pub struct BfcReport {
    /// The sample's name (the second `;` comment), if the file has one.
    pub sample: Option<String>,
    /// Negative and anti-Stokes entries set to 0.
    pub clamped: ImportReport,
    /// Excitation columns dropped below the renderer's range: (first, last) nm and count.
    pub excitation_dropped: Option<(f32, f32, usize)>,
    /// Emission not measured on the grid: (first, last) nm of the rows added as zeros.
    pub emission_unmeasured: Option<(f32, f32)>,
    /// Emission rows dropped below the renderer's range: (first, last) nm and count.
    pub emission_dropped: Option<(f32, f32, usize)>,
    /// The last measured wavelength, where it ends inside the rendered range: the
    /// reflectance is held at its value up to 830 nm.
    pub held_above: Option<f32>,
}

impl fmt::Display for BfcReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if let Some((a, b, n)) = self.excitation_dropped {
            parts.push(format!(
                "dropped {n} excitation column(s) {a}–{b} nm (below the rendered range)"
            ));
        }
        if let Some((a, b, n)) = self.emission_dropped {
            parts.push(format!(
                "dropped {n} emission row(s) {a}–{b} nm (below the rendered range)"
            ));
        }
        if let Some(l) = self.held_above {
            parts.push(format!(
                "no data above {l} nm (reflectance held at its {l} nm value up to {LAMBDA_MAX} nm)"
            ));
        }
        if let Some((a, b)) = self.emission_unmeasured {
            parts.push(format!(
                "no emission measured at {a}–{b} nm (taken as none; reflectance held at the first measured row)"
            ));
        }
        if !self.clamped.is_clean() {
            parts.push(self.clamped.to_string());
        }
        if parts.is_empty() {
            parts.push("imported as measured".into());
        }
        f.write_str(&parts.join("; "))
    }
}

/// Whether `text` is a BFC file (its first line is the format's tag).
pub fn is_bfc(text: &str) -> bool {
    text.trim_start().starts_with("VEC_01")
}

fn at(source: &str, line_no: usize, detail: impl Into<Detail>) -> Error {
    Error::file(source, Some(line_no), detail)
}

fn number(field: &str, source: &str, line_no: usize, what: &str) -> Result<f32> {
    match field.parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(at(
            source,
            line_no,
            Detail::expected(what.to_string(), format!("'{field}'")),
        )),
    }
}

/// The sampling line: emission start, end, step; excitation count, start, step.
struct Sampling {
    emission: Vec<f32>,
    excitation: Vec<f32>,
}

fn sampling(fields: &[&str], source: &str, line_no: usize) -> Result<Sampling> {
    if fields.len() != 6 {
        return Err(at(
            source,
            line_no,
            Detail::expected(
                "the sampling line: emission start, end and step (nm), then the number of \
                 excitation columns, their start and step (6 numbers)",
                format!("{} field(s)", fields.len()),
            ),
        ));
    }
    let v: Vec<f32> = fields
        .iter()
        .map(|f| number(f, source, line_no, "a number on the sampling line"))
        .collect::<Result<_>>()?;
    let (e0, e1, de, nx, x0, dx) = (v[0], v[1], v[2], v[3], v[4], v[5]);
    let ne = (e1 - e0) / de;
    let whole = |x: f32| x > 0.0 && (x - x.round()).abs() < 1e-3;
    if !(de > 0.0 && dx > 0.0 && whole(ne + 1.0) && whole(nx) && x0 > 0.0) {
        return Err(at(
            source,
            line_no,
            Detail::expected(
                "positive steps, an emission range that is a whole number of steps and a \
                 whole number of excitation columns",
                fields.join(" "),
            ),
        ));
    }
    let ne = ne.round() as usize + 1;
    let nx = nx.round() as usize;
    if !(2..=MAX_CELLS).contains(&ne) || !(2..=MAX_CELLS).contains(&nx) {
        return Err(at(
            source,
            line_no,
            Detail::expected(
                format!("2 to {MAX_CELLS} emission and excitation wavelengths"),
                format!("{ne} emission and {nx} excitation"),
            ),
        ));
    }
    Ok(Sampling {
        emission: (0..ne).map(|k| e0 + k as f32 * de).collect(),
        excitation: (0..nx).map(|k| x0 + k as f32 * dx).collect(),
    })
}

/// Parses a BFC file's text; `source` names it in errors.
pub fn parse(text: &str, source: &str) -> Result<(Reradiation, BfcReport)> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty());
    let mut next = |what: &str| {
        lines.next().ok_or_else(|| {
            Error::file(
                source,
                None,
                format!("the file ends before {what} (a truncated BFC file?)"),
            )
        })
    };
    let (n1, tag) = next("its first line")?;
    if !tag.starts_with("VEC_01") {
        return Err(at(
            source,
            n1,
            Detail::expected("'VEC_01' (a BFC-450 matrix file)", format!("'{tag}'")),
        ));
    }
    let (n2, title) = next("the line 'BFC-450 Matrix File'")?;
    if !title.starts_with("BFC-450") {
        return Err(at(
            source,
            n2,
            Detail::expected("'BFC-450 Matrix File'", format!("'{title}'")),
        ));
    }
    let mut comments = Vec::new();
    let (ns, sampling_line) = loop {
        let (n, l) = next("the sampling line")?;
        match l.strip_prefix(';') {
            Some(c) => comments.push(c.trim().to_string()),
            None => break (n, l),
        }
    };
    let fields: Vec<&str> = sampling_line.split_whitespace().collect();
    let grid = sampling(&fields, source, ns)?;

    let (nh, header) = next("the 'r:c:' line of excitation wavelengths")?;
    let fields: Vec<&str> = header.split_whitespace().collect();
    if fields.first() != Some(&"r:c:") || fields.len() != grid.excitation.len() + 1 {
        return Err(at(
            source,
            nh,
            Detail::expected(
                format!(
                    "'r:c:' and the {} excitation wavelengths of the sampling line {ns}",
                    grid.excitation.len()
                ),
                format!(
                    "'{}' and {} field(s)",
                    fields.first().unwrap_or(&""),
                    fields.len().saturating_sub(1)
                ),
            ),
        ));
    }
    for (k, f) in fields[1..].iter().enumerate() {
        let x = number(f, source, nh, "an excitation wavelength")?;
        if (x - grid.excitation[k]).abs() > 1e-3 {
            return Err(at(
                source,
                nh,
                format!(
                    "excitation wavelength {} is {x} nm; the sampling line {ns} puts it at {} nm",
                    k + 1,
                    grid.excitation[k]
                ),
            ));
        }
    }

    // rows[o][x]: emission row o, excitation column x.
    let mut rows: Vec<Vec<f32>> = Vec::with_capacity(grid.emission.len());
    for (o, &lo) in grid.emission.iter().enumerate() {
        let (n, l) = next(&format!(
            "the emission row at {lo} nm (row {} of {})",
            o + 1,
            grid.emission.len()
        ))?;
        if l == "EOD" {
            return Err(at(
                source,
                n,
                format!(
                    "the data end (EOD) before the emission row at {lo} nm (row {} of {}: a \
                     truncated BFC file?)",
                    o + 1,
                    grid.emission.len()
                ),
            ));
        }
        let fields: Vec<&str> = l.split_whitespace().collect();
        if fields.len() != grid.excitation.len() + 1 {
            return Err(at(
                source,
                n,
                Detail::expected(
                    format!(
                        "{} fields (the emission wavelength, then one value per excitation \
                         column)",
                        grid.excitation.len() + 1
                    ),
                    fields.len(),
                ),
            ));
        }
        let w = number(fields[0], source, n, "an emission wavelength in column 1")?;
        if (w - lo).abs() > 1e-3 {
            return Err(at(
                source,
                n,
                format!(
                    "emission row {} is at {w} nm; the sampling line {ns} puts it at {lo} nm",
                    o + 1
                ),
            ));
        }
        let row = fields[1..]
            .iter()
            .enumerate()
            .map(|(c, f)| number(f, source, n, &format!("a number in column {}", c + 2)))
            .collect::<Result<Vec<f32>>>()?;
        rows.push(row);
    }
    // The database's files end with an `EOD` line.
    let mut rest = lines.skip_while(|&(_, l)| l == "EOD");
    if let Some((n, l)) = rest.next() {
        return Err(at(
            source,
            n,
            format!(
                "data after the {} emission rows of the sampling line {ns}: '{}'",
                grid.emission.len(),
                l.chars().take(40).collect::<String>()
            ),
        ));
    }
    square_grid(&grid, &rows, comments.get(1).cloned(), source)
}

/// Puts the measured rows on the square grid of the excitation wavelengths in range.
fn square_grid(
    grid: &Sampling,
    rows: &[Vec<f32>],
    sample: Option<String>,
    source: &str,
) -> Result<(Reradiation, BfcReport)> {
    let err = |msg: String| Error::file(source, None, msg);
    let (x, e) = (&grid.excitation, &grid.emission);
    let (dx, de) = (x[1] - x[0], e[1] - e[0]);
    if (dx - de).abs() > 1e-3 {
        return Err(err(format!(
            "excitation step {dx} nm and emission step {de} nm differ: only a common grid is supported"
        )));
    }
    // Cells that reach into the rendered range (centre + h/2 > 360 nm).
    let in_range = |w: &f32| w + 0.5 * dx > LAMBDA_MIN;
    let first = x.iter().position(in_range).unwrap_or(x.len());
    let first_row = e.iter().position(in_range).unwrap_or(e.len());
    let centres: Vec<f32> = x[first..].to_vec();
    if centres.len() < 2 || first_row == e.len() {
        return Err(err(format!(
            "no data in the rendered range: excitation {}–{} nm, emission {}–{} nm",
            x[0],
            x[x.len() - 1],
            e[0],
            e[e.len() - 1]
        )));
    }
    // Every emission row in range sits on a cell of the excitation grid.
    let cell_of = |w: f32| {
        let k = (w - centres[0]) / dx;
        ((k - k.round()).abs() < 1e-3 && k > -0.5).then_some(k.round() as usize)
    };
    let mut row_at = vec![None; centres.len()];
    for (r, &w) in e.iter().enumerate().skip(first_row) {
        match cell_of(w) {
            Some(o) if o < centres.len() => row_at[o] = Some(r),
            Some(_) => {
                return Err(err(format!(
                    "the excitation wavelengths end at {} nm, before the emission row at {w} nm \
                     (its reflectance, the diagonal, was not measured)",
                    x[x.len() - 1]
                )))
            }
            None => {
                return Err(err(format!(
                    "emission wavelength {w} nm is not on the excitation grid ({} nm + k·{dx} nm)",
                    centres[0]
                )))
            }
        }
    }
    let n = centres.len();
    let mut m = vec![vec![0.0f32; n]; n];
    for (o, r) in row_at.iter().enumerate() {
        if let Some(r) = *r {
            for (i, mi) in m.iter_mut().enumerate() {
                mi[o] = rows[r][first + i];
            }
        }
    }
    // Unmeasured emission: no re-emission there, D held at the nearest measured row's.
    let measured: Vec<usize> = (0..n).filter(|&o| row_at[o].is_some()).collect();
    let unmeasured: Vec<f32> = (0..n)
        .filter(|&o| row_at[o].is_none())
        .map(|o| centres[o])
        .collect();
    for o in (0..n).filter(|&o| row_at[o].is_none()) {
        let near = *measured
            .iter()
            .min_by_key(|&&k| k.abs_diff(o))
            .expect("at least one measured row");
        m[o][o] = m[near][near];
    }
    let (rr, clamped) = import::square(&centres, &m, source, true)?;
    let top = centres[n - 1];
    let report = BfcReport {
        sample,
        clamped,
        excitation_dropped: (first > 0).then(|| (x[0], x[first - 1], first)),
        emission_unmeasured: (!unmeasured.is_empty())
            .then(|| (unmeasured[0], unmeasured[unmeasured.len() - 1])),
        emission_dropped: (first_row > 0).then(|| (e[0], e[first_row - 1], first_row)),
        held_above: (top + 0.5 * dx < LAMBDA_MAX).then_some(top),
    };
    Ok((rr, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small BFC file made up here: emission 380–400, excitation 350–400, 10 nm.
    fn tiny(extra: &str) -> String {
        format!(
            "VEC_01\t123\nBFC-450 Matrix File\n;tiny.BFC\n;Made-up sample\n;nobody\n\
             380\t400\t10\t6\t350\t10\n\
             r:c:\t350\t360\t370\t380\t390\t400\n\
             380\t0.01\t0.02\t0.03\t0.5\t-0.001\t0.0\n\
             390\t0.02\t0.03\t0.04\t0.05\t0.6\t0.002\n\
             400\t0.03\t0.04\t-0.05\t0.06\t0.07\t0.7\n{extra}EOD\r\n"
        )
    }

    #[test]
    fn tiny_file_imports_onto_the_rendered_grid() {
        let (rr, report) = parse(&tiny(""), "tiny.BFC").unwrap();
        assert_eq!(report.sample.as_deref(), Some("Made-up sample"));
        assert_eq!(report.excitation_dropped, Some((350.0, 350.0, 1)));
        assert_eq!(report.emission_unmeasured, Some((360.0, 370.0)));
        assert_eq!(report.emission_dropped, None);
        assert_eq!(report.held_above, Some(400.0));
        assert!((rr.d(829.0) - 0.7).abs() < 1e-6, "D held up to 830 nm");
        assert_eq!(report.clamped.clamped_negative, 1);
        assert_eq!(report.clamped.clamped_anti_stokes, 2);
        // The grid: cells centred at 360 … 400 (10 nm), F = m/h.
        assert_eq!(rr.cells(), 5);
        assert!((rr.d(390.0) - 0.6).abs() < 1e-6);
        assert!(
            (rr.d(362.0) - 0.5).abs() < 1e-6,
            "D held below the first row"
        );
        assert_eq!(rr.f(372.0, 398.0), 0.0, "a negative entry clamped");
        assert!((rr.f(372.0, 392.0) - 0.04 / 10.0).abs() < 1e-7);
        assert!((rr.f(361.0, 382.0) - 0.02 / 10.0).abs() < 1e-7);
        assert_eq!(rr.f(382.0, 392.0), 0.05 / 10.0);
        assert_eq!(
            rr.f(362.0, 368.0),
            0.0,
            "no emission measured at 360–370 nm"
        );
        assert!(report
            .to_string()
            .contains("dropped 1 excitation column(s) 350–350 nm"));
    }

    /// Emission rows below the range are dropped and reported; excitation that ends before
    /// the emission does, or a grid that does not line up, is an error.
    #[test]
    fn other_layouts_are_dropped_or_named() {
        let low = tiny("")
            .replace("380\t400\t10\t6\t350", "350\t370\t10\t6\t350")
            .replace("\n380\t0.01", "\n350\t0.01")
            .replace("\n390\t0.02", "\n360\t0.02")
            .replace("\n400\t0.03", "\n370\t0.03");
        let (_, report) = parse(&low, "low.BFC").unwrap();
        assert_eq!(report.emission_dropped, Some((350.0, 350.0, 1)));
        let short = tiny("").replace("380\t400\t10\t6\t350", "380\t410\t10\t6\t350") + "";
        let short = short.replace("EOD", "410\t0\t0\t0\t0\t0\t0\nEOD");
        let e = parse(&short, "short.BFC").unwrap_err().to_string();
        assert!(
            e.contains("end at 400 nm, before the emission row at 410 nm"),
            "{e}"
        );
        let huge = tiny("").replace("380\t400\t10\t6\t350", "380\t400\t10\t1e12\t350");
        let e = parse(&huge, "huge.BFC").unwrap_err().to_string();
        assert!(
            e.contains("huge.BFC:6") && e.contains("excitation wavelengths"),
            "{e}"
        );
        let none = tiny("").replace("380\t400\t10\t6\t350", "380\t400\t10\t0.0005\t350");
        assert!(parse(&none, "none.BFC").is_err());
    }

    #[test]
    fn malformed_files_name_the_line() {
        let cases: [(String, &str); 7] = [
            (tiny("").replace("VEC_01", "VEC_02"), "bad.BFC:1:"),
            (
                tiny("").replace("380\t400\t10\t6", "380\t400\t10\t7"),
                "bad.BFC:7:",
            ),
            (tiny("").replace("\t0.6\t", "\tabc\t"), "bad.BFC:9:"),
            (
                tiny("").replace("400\t0.03\t0.04\t-0.05\t0.06\t0.07\t0.7\n", ""),
                "truncated",
            ),
            (tiny("410\t1\t2\t3\t4\t5\t6\n"), "bad.BFC:11:"),
            (tiny("") + "0.5\n", "bad.BFC:12:"),
            (tiny("").replace("390\t0.02", "395\t0.02"), "bad.BFC:9:"),
        ];
        for (text, want) in cases {
            let e = parse(&text, "bad.BFC").unwrap_err().to_string();
            assert!(e.contains(want), "{want}: {e}");
            assert_eq!(e.lines().count(), 1, "{e}");
        }
    }
}
