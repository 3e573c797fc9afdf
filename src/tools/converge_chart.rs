//! What `stokes converge` draws and how it names the methods: the two charts, styled by
//! meaning; other renderers' curves read from CSV (`--compare`); runs read back from a
//! `convergence.csv` (`--redraw`).
//!
//! **Styles.** A method is split into the values of its axes ([`Resolved::parts`]); the
//! charts give each of three roles one visual channel:
//! - the *spectral method*, every axis but tracking and rays (among those that vary in
//!   the run): the colour;
//! - the tracking: the dash pattern (solid, dashed, dotted, …, in the axis' order);
//! - the rays: the marker (circle, triangle, square, …), on the time chart only.
//!
//! Methods that differ only in their rays trace the same samples with the same random
//! numbers, so on the error-against-spp chart they are one line ([`spp_groups`]); on the
//! time chart each keeps its own (their speeds differ). Names keep only the axes whose
//! value differs between the methods ([`crate::tools::converge::short_names`]); the
//! values every method shares are stated once, in the charts' subtitle and above the
//! summary ([`common_values`]).
//!
//! **Other renderers** (`--compare FILE.csv`): rows in the `convergence.csv` format, the
//! columns found by their header names — `method`, `spp`, `seconds`, `region`, `rmse`,
//! `relmse`; any other column is ignored and may be empty. Every distinct `method` is a
//! line in black or grey with a marker of its own on both charts, and a row of the
//! summary marked external. Only the rows of the region the charts use count.

use super::chart::{
    self, colour, neutral, Dash, LegendEntry, LegendSection, LogLogChart, Marker, Series, Slope,
    Style, Target,
};
use super::converge::{
    chart_region, format_summary, loglog_slope, short_names, summarize, time_to_reach, Checkpoint,
    Errors, MeasuredRegion, Run, SummaryRow, CSV_HEADER, FILES, SLOPE_MIN_SPP,
};
use crate::error::{Detail, Error};
use crate::medium::tracking::Tracking;
use crate::method::{Axis, Method, Rays, Resolved};
use crate::output::check_outputs;
use crate::Result;
use std::path::{Path, PathBuf};

/// A method's values in axis order, with the indices of its tracking and rays among them.
struct Roles {
    parts: Vec<&'static str>,
    tracking: Option<usize>,
    rays: Option<usize>,
}

fn roles(m: &Resolved) -> Roles {
    let parts: Vec<&'static str> = m.parts().to_vec();
    // Every value belongs to exactly one axis, so its name finds its place.
    let tracking = parts.iter().position(|p| *p == m.tracking.name());
    let rays = parts.iter().position(|p| *p == m.rays.name());
    Roles {
        parts,
        tracking,
        rays,
    }
}

/// For each axis (in [`Resolved::parts`] order), whether its value differs between
/// `methods`.
pub fn varying_axes(methods: &[Resolved]) -> Vec<bool> {
    let parts: Vec<Vec<&str>> = methods.iter().map(|m| m.parts().to_vec()).collect();
    let n = parts.first().map_or(0, Vec::len);
    (0..n)
        .map(|k| parts.iter().any(|p| p[k] != parts[0][k]))
        .collect()
}

/// The axes' names in [`Resolved::parts`] order, as the CSV's columns after `method`
/// give them, if they are `n`.
fn axis_names(n: usize) -> Option<Vec<&'static str>> {
    let cols: Vec<&'static str> = CSV_HEADER.split(',').collect();
    let end = cols.iter().position(|c| *c == "pass")?;
    let names = cols.get(1..end)?.to_vec();
    (names.len() == n).then_some(names)
}

/// The values every method shares, with their axes' names: `shifting independent,
/// dispersion split`; empty if every axis varies.
pub fn common_values(methods: &[Resolved]) -> String {
    let Some(first) = methods.first() else {
        return String::new();
    };
    let parts = first.parts().to_vec();
    let varies = varying_axes(methods);
    let names = axis_names(parts.len());
    let kept: Vec<String> = (0..parts.len())
        .filter(|&k| !varies[k])
        .map(|k| match &names {
            Some(n) => format!("{} {}", n[k], parts[k]),
            None => parts[k].to_string(),
        })
        .collect();
    kept.join(", ")
}

/// The values of `m` on the axes that vary, but for those in `skip`; all its values but
/// `skip`'s if none is left.
fn name_without(m: &Resolved, varies: &[bool], skip: &[Option<usize>]) -> String {
    let r = roles(m);
    let kept = |all: bool| -> Vec<&str> {
        (0..r.parts.len())
            .filter(|&k| (all || varies[k]) && !skip.contains(&Some(k)))
            .map(|k| r.parts[k])
            .collect()
    };
    let some = kept(false);
    if some.is_empty() {
        kept(true).join("-")
    } else {
        some.join("-")
    }
}

/// Groups of methods that differ only in their rays (indices into `methods`, each group
/// in order, groups in the order of their first method): they trace the same samples.
pub fn spp_groups(methods: &[Resolved]) -> Vec<Vec<usize>> {
    let key = |m: &Resolved| {
        let r = roles(m);
        let mut p = r.parts;
        if let Some(k) = r.rays {
            p.remove(k);
        }
        p
    };
    let mut groups: Vec<(Vec<&str>, Vec<usize>)> = Vec::new();
    for (i, m) in methods.iter().enumerate() {
        let k = key(m);
        match groups.iter_mut().find(|(g, _)| *g == k) {
            Some((_, members)) => members.push(i),
            None => groups.push((k, vec![i])),
        }
    }
    groups.into_iter().map(|(_, members)| members).collect()
}

/// How the charts draw a method: indices into the palettes of [`chart`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MethodStyle {
    /// The spectral method's colour ([`chart::colour`]).
    pub colour: usize,
    /// The tracking's dash ([`Dash::nth`]).
    pub dash: usize,
    /// The rays' marker ([`Marker::nth`]).
    pub marker: usize,
}

impl MethodStyle {
    /// The chart style.
    pub fn style(self) -> Style {
        Style {
            colour: colour(self.colour),
            dash: Dash::nth(self.dash),
            marker: Marker::nth(self.marker),
        }
    }
}

/// The values of an axis that occur in `methods`, in the axis' order.
fn present<A: Axis>(methods: &[Resolved], of: impl Fn(&Resolved) -> A) -> Vec<A> {
    A::VALUES
        .iter()
        .copied()
        .filter(|v| methods.iter().any(|m| of(m) == *v))
        .collect()
}

/// The spectral method of `m`: its values on every axis but tracking and rays.
fn spectral_key(m: &Resolved) -> Vec<&'static str> {
    let r = roles(m);
    (0..r.parts.len())
        .filter(|&k| Some(k) != r.tracking && Some(k) != r.rays)
        .map(|k| r.parts[k])
        .collect()
}

/// One style per method: a colour per spectral method (in the order they first occur),
/// a dash per tracking and a marker per rays value (in their axes' order among the values
/// that occur).
pub fn styles(methods: &[Resolved]) -> Vec<MethodStyle> {
    let trackings = present(methods, |m| m.tracking);
    let rays = present(methods, |m| m.rays);
    let mut spectral: Vec<Vec<&str>> = Vec::new();
    methods
        .iter()
        .map(|m| {
            let key = spectral_key(m);
            let colour = match spectral.iter().position(|k| *k == key) {
                Some(i) => i,
                None => {
                    spectral.push(key);
                    spectral.len() - 1
                }
            };
            MethodStyle {
                colour,
                dash: trackings.iter().position(|t| *t == m.tracking).unwrap_or(0),
                marker: rays.iter().position(|r| *r == m.rays).unwrap_or(0),
            }
        })
        .collect()
}

/// The legend's sections for `methods` with `styles`: the colours, and the dashes and
/// the markers where the tracking and the rays vary. `markers`: whether the lines carry
/// the rays' markers (the time chart) or one line stands for every rays value (spp).
fn legend(methods: &[Resolved], styles: &[MethodStyle], markers: bool) -> Vec<LegendSection> {
    let mut out = Vec::new();
    if methods.is_empty() {
        return out;
    }
    let varies = varying_axes(methods);
    let r = roles(&methods[0]);
    let mut colours: Vec<LegendEntry> = Vec::new();
    for (m, s) in methods.iter().zip(styles) {
        if colours.len() == s.colour {
            colours.push(LegendEntry {
                label: name_without(m, &varies, &[r.tracking, r.rays]),
                colour: colour(s.colour),
                dash: Some(Dash::Solid),
                marker: None,
            });
        }
    }
    out.push(LegendSection {
        title: "colour: spectral method".into(),
        entries: colours,
    });
    let grey = (60, 60, 60);
    let trackings = present(methods, |m| m.tracking);
    if trackings.len() > 1 {
        out.push(LegendSection {
            title: "line: tracking".into(),
            entries: trackings
                .iter()
                .enumerate()
                .map(|(i, t)| LegendEntry {
                    label: t.name().into(),
                    colour: grey,
                    dash: Some(Dash::nth(i)),
                    marker: None,
                })
                .collect(),
        });
    }
    let rays: Vec<Rays> = present(methods, |m| m.rays);
    if rays.len() > 1 {
        let names: Vec<&str> = rays.iter().map(|r| r.name()).collect();
        out.push(LegendSection {
            title: if markers {
                "marker: rays".into()
            } else {
                "rays".into()
            },
            entries: if markers {
                rays.iter()
                    .enumerate()
                    .map(|(i, r)| LegendEntry {
                        label: r.name().into(),
                        colour: grey,
                        dash: None,
                        marker: Some(Marker::nth(i)),
                    })
                    .collect()
            } else {
                vec![
                    LegendEntry {
                        label: format!("{} trace the same", names.join(", ")),
                        colour: grey,
                        dash: None,
                        marker: None,
                    },
                    LegendEntry {
                        label: "samples: one line for all".into(),
                        colour: grey,
                        dash: None,
                        marker: None,
                    },
                ]
            },
        });
    }
    out
}

/// The markers of other renderers' lines (cycling).
const EXTERNAL_MARKERS: [Marker; 2] = [Marker::Cross, Marker::Plus];

/// The style of the `i`-th other renderer's line.
fn external_style(i: usize) -> Style {
    Style {
        colour: neutral(i),
        dash: Dash::Solid,
        marker: EXTERNAL_MARKERS[i % EXTERNAL_MARKERS.len()],
    }
}

/// One checkpoint of another renderer.
#[derive(Debug, Clone, PartialEq)]
pub struct CurvePoint {
    /// The region measured.
    pub region: String,
    /// Samples per pixel.
    pub spp: f64,
    /// Seconds of rendering.
    pub seconds: f64,
    /// RMSE.
    pub rmse: f64,
    /// Relative MSE.
    pub relmse: f64,
}

/// Another renderer's convergence: one `method` of a `--compare` file.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Its name (the `method` column).
    pub name: String,
    /// The file it came from.
    pub file: PathBuf,
    /// Its checkpoints, in the file's order.
    pub points: Vec<CurvePoint>,
}

impl Curve {
    /// The checkpoints over `region`.
    fn over<'a>(&'a self, region: &'a str) -> impl Iterator<Item = &'a CurvePoint> + 'a {
        self.points.iter().filter(move |p| p.region == region)
    }
}

/// A CSV file read whole: its header and its rows with their line numbers.
struct Table {
    path: PathBuf,
    header: Vec<String>,
    rows: Vec<(usize, Vec<String>)>,
}

/// The fields of a CSV line (no quoted commas; a field in double quotes loses them).
fn fields(line: &str) -> Vec<String> {
    line.split(',')
        .map(|f| {
            let f = f.trim();
            match f.strip_prefix('"').and_then(|f| f.strip_suffix('"')) {
                Some(inner) => inner.replace("\"\"", "\""),
                None => f.to_string(),
            }
        })
        .collect()
}

impl Table {
    /// Reads `path`; `option` names the command-line option that gave it.
    fn read(path: &Path, option: &str) -> Result<Table> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::about_option(option, path, format!("cannot be read: {e}")))?;
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l))
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((_, head)) = lines.next() else {
            return Err(Error::file(
                path,
                None,
                Detail::expected("a CSV header line (method,spp,seconds,…)", "an empty file"),
            ));
        };
        let header = fields(head.trim_start_matches('\u{feff}'));
        let mut rows = Vec::new();
        for (n, line) in lines {
            let f = fields(line);
            if f.len() < header.len() {
                return Err(Error::file(
                    path,
                    Some(n),
                    Detail::expected(
                        format!("{} comma-separated fields as in the header", header.len()),
                        f.len(),
                    ),
                ));
            }
            rows.push((n, f));
        }
        Ok(Table {
            path: path.to_path_buf(),
            header,
            rows,
        })
    }

    /// The index of the column `name`.
    fn column(&self, name: &str) -> Result<usize> {
        self.header.iter().position(|h| h == name).ok_or_else(|| {
            Error::file(
                &self.path,
                Some(1),
                Detail::expected(
                    format!("a column `{name}` in the header"),
                    format!("the columns {}", self.header.join(",")),
                ),
            )
        })
    }

    /// The number in column `col` (named `name`) of the row at `line`.
    fn number(&self, line: usize, row: &[String], col: usize, name: &str) -> Result<f64> {
        let text = &row[col];
        text.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                Error::file(
                    &self.path,
                    Some(line),
                    Detail::expected(
                        format!("a finite number in column `{name}`"),
                        format!("{text:?}"),
                    ),
                )
            })
    }
}

/// Reads another renderer's curves from `path` (see the module documentation): one per
/// distinct `method`, in the order they first occur. Errors name the file and, for a
/// bad value, its line.
pub fn read_compare(path: &Path) -> Result<Vec<Curve>> {
    let t = Table::read(path, "--compare")?;
    let names = ["method", "spp", "seconds", "region", "rmse", "relmse"];
    let mut cols = [0usize; 6];
    for (c, name) in cols.iter_mut().zip(names) {
        *c = t.column(name)?;
    }
    let mut out: Vec<Curve> = Vec::new();
    for (n, row) in &t.rows {
        let method = row[cols[0]].clone();
        if method.is_empty() {
            return Err(Error::file(
                path,
                Some(*n),
                Detail::expected("a name in column `method`", "an empty field"),
            ));
        }
        let p = CurvePoint {
            region: row[cols[3]].clone(),
            spp: t.number(*n, row, cols[1], "spp")?,
            seconds: t.number(*n, row, cols[2], "seconds")?,
            rmse: t.number(*n, row, cols[4], "rmse")?,
            relmse: t.number(*n, row, cols[5], "relmse")?,
        };
        match out.iter_mut().find(|c| c.name == method) {
            Some(c) => c.points.push(p),
            None => out.push(Curve {
                name: method,
                file: path.to_path_buf(),
                points: vec![p],
            }),
        }
    }
    if out.is_empty() {
        return Err(Error::file(
            path,
            None,
            Detail::expected("rows after the header", "none"),
        ));
    }
    Ok(out)
}

/// Checks that every curve has checkpoints over `region` (the region the charts and the
/// summary use): a curve over another region would not be comparable.
pub fn check_compare(curves: &[Curve], region: &str) -> Result<()> {
    for c in curves {
        if c.over(region).next().is_none() {
            let mut has: Vec<&str> = c.points.iter().map(|p| p.region.as_str()).collect();
            has.dedup();
            return Err(Error::about_option(
                "--compare",
                &c.file,
                format!(
                    "has no rows of region `{region}` for method `{}` (the charts and the summary measure `{region}`; it has {})",
                    c.name,
                    has.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// The summary rows of other renderers' curves over `region`, against `target`.
pub fn compare_rows(curves: &[Curve], region: &str, target: f64) -> Vec<SummaryRow> {
    curves
        .iter()
        .map(|c| {
            let pts: Vec<&CurvePoint> = c.over(region).collect();
            let last = pts.last();
            let slope: Vec<(f64, f64)> = pts
                .iter()
                .filter(|p| p.spp >= SLOPE_MIN_SPP as f64)
                .map(|p| (p.spp, p.rmse))
                .collect();
            let to_target: Vec<(f64, f64)> = pts.iter().map(|p| (p.seconds, p.relmse)).collect();
            SummaryRow {
                method: c.name.clone(),
                spp: last.map_or(0, |p| p.spp.round() as u32),
                seconds: last.map_or(0.0, |p| p.seconds),
                slope: loglog_slope(&slope),
                rmse: last.map_or(f64::NAN, |p| p.rmse),
                relmse: last.map_or(f64::NAN, |p| p.relmse),
                time_to_target: time_to_reach(&to_target, target),
                external: Some(c.file.display().to_string()),
            }
        })
        .collect()
}

/// The row that reaches the target first, if any does.
pub fn fastest(rows: &[SummaryRow]) -> Option<usize> {
    let times = rows.iter().enumerate().filter_map(|(i, r)| {
        let t = r.time_to_target.filter(|t| t.is_finite())?;
        Some((i, t))
    });
    times.min_by(|a, b| a.1.total_cmp(&b.1)).map(|(i, _)| i)
}

/// The summary table over `regions[region]` of `runs` and `curves`, with the line naming
/// the region, the target and the values every method shares.
pub fn summary(
    runs: &[Run],
    curves: &[Curve],
    regions: &[MeasuredRegion],
    region: usize,
) -> String {
    let name = &regions[region].name;
    let (target, worst, mut rows) = summarize(runs, region);
    rows.extend(compare_rows(curves, name, target));
    let methods: Vec<Resolved> = runs.iter().map(|r| r.method).collect();
    format_summary(name, target, &worst, &common_values(&methods), &rows)
}

/// The union of the `(spp, error)` points of a group's runs, by spp (the same samples
/// give the same error; a run that went further adds its later checkpoints).
fn group_points(runs: &[&Run], region: usize) -> Vec<(f64, f64)> {
    let mut pts: Vec<(u32, f64)> = runs
        .iter()
        .flat_map(|r| r.checkpoints.iter().map(|c| (c.spp, c.errors[region].rmse)))
        .collect();
    pts.sort_by_key(|p| p.0);
    pts.dedup_by_key(|p| p.0);
    pts.into_iter().map(|(s, e)| (s as f64, e)).collect()
}

/// The two charts over `regions[region]`: relMSE against seconds, with every method and
/// the fastest to the summary's target marked, and RMSE against spp, one line per group
/// of methods that trace the same samples ([`spp_groups`]); `curves` add other
/// renderers' lines to both. `title` starts each chart's title.
pub fn charts(
    runs: &[Run],
    curves: &[Curve],
    regions: &[MeasuredRegion],
    region: usize,
    title: &str,
) -> [LogLogChart; 2] {
    let methods: Vec<Resolved> = runs.iter().map(|r| r.method).collect();
    let names = short_names(&methods);
    let styles = styles(&methods);
    let region_name = regions[region].name.as_str();
    let over = if region_name == "image" {
        "the whole image".to_string()
    } else {
        format!("region `{region_name}`")
    };
    let common = common_values(&methods);
    let subtitle = if common.is_empty() {
        String::new()
    } else {
        format!("every stokes method: {common}")
    };
    let mut external_legend = LegendSection {
        title: "other renderers (--compare)".into(),
        entries: Vec::new(),
    };
    let mut external_time = Vec::new();
    let mut external_spp = Vec::new();
    for (i, c) in curves.iter().enumerate() {
        let style = external_style(i);
        external_legend.entries.push(LegendEntry {
            label: c.name.clone(),
            colour: style.colour,
            dash: Some(style.dash),
            marker: Some(style.marker),
        });
        let pts: Vec<&CurvePoint> = c.over(region_name).collect();
        external_time.push(Series {
            name: c.name.clone(),
            points: pts.iter().map(|p| (p.seconds, p.relmse)).collect(),
            style,
        });
        external_spp.push(Series {
            name: c.name.clone(),
            points: pts.iter().map(|p| (p.spp, p.rmse)).collect(),
            style,
        });
    }

    // Against time: every method, the target and the fastest to it.
    let (target, _, mut rows) = summarize(runs, region);
    let ours = rows.len();
    rows.extend(compare_rows(curves, region_name, target));
    let mark = fastest(&rows).and_then(|i| {
        let row = &rows[i];
        let (name, fill) = if i < ours {
            (names[i].clone(), colour(styles[i].colour))
        } else {
            let k = i - ours;
            (format!("{} (external)", curves[k].name), neutral(k))
        };
        let t = row.time_to_target?;
        Some(Target {
            x: t,
            y: target,
            colour: fill,
            label: format!(
                "target relMSE {target:.3} (the worst final one that converges); fastest: {name} in {t:.3} s"
            ),
        })
    });
    let mut time_series: Vec<Series> = runs
        .iter()
        .zip(&names)
        .zip(&styles)
        .map(|((run, name), s)| Series {
            name: name.clone(),
            points: run
                .checkpoints
                .iter()
                .map(|c| (c.seconds, c.errors[region].relmse))
                .collect(),
            style: s.style(),
        })
        .collect();
    time_series.extend(external_time);
    let mut time_legend = legend(&methods, &styles, true);
    let mut spp_legend = legend(&methods, &styles, false);
    if !curves.is_empty() {
        time_legend.push(external_legend.clone());
        spp_legend.push(external_legend);
    }
    if let Some(t) = &mark {
        time_legend.push(LegendSection {
            title: "target".into(),
            entries: vec![LegendEntry {
                label: "first to reach it".into(),
                colour: t.colour,
                dash: None,
                marker: Some(Marker::Star),
            }],
        });
    }
    let time = LogLogChart {
        title: format!("{title}: relMSE over {over} against time"),
        subtitle: subtitle.clone(),
        x_label: "seconds of rendering".into(),
        y_label: "relMSE".into(),
        series: time_series,
        legend: time_legend,
        reference_slope: Some(Slope {
            slope: -1.0,
            label: "slope −1 (relMSE ∝ 1/t)".into(),
        }),
        target: mark,
    };

    // Against spp: one line per group of methods that trace the same samples.
    let varies = varying_axes(&methods);
    let mut spp_series: Vec<Series> = spp_groups(&methods)
        .into_iter()
        .map(|g| {
            let first = &methods[g[0]];
            let members: Vec<&Run> = g.iter().map(|&i| &runs[i]).collect();
            Series {
                name: name_without(first, &varies, &[roles(first).rays]),
                points: group_points(&members, region),
                style: Style {
                    marker: Marker::Dot,
                    ..styles[g[0]].style()
                },
            }
        })
        .collect();
    spp_series.extend(external_spp);
    let spp = LogLogChart {
        title: format!("{title}: RMSE over {over} against spp"),
        subtitle,
        x_label: "samples per pixel".into(),
        y_label: "RMSE (linear sRGB)".into(),
        series: spp_series,
        legend: spp_legend,
        reference_slope: Some(Slope {
            slope: -0.5,
            label: "slope −½ (RMSE ∝ 1/√n)".into(),
        }),
        target: None,
    };
    [time, spp]
}

/// Writes `error-vs-time` and `error-vs-spp` (SVG and PNG) into `dir` ([`charts`]).
pub fn write_charts(
    runs: &[Run],
    curves: &[Curve],
    regions: &[MeasuredRegion],
    region: usize,
    title: &str,
    dir: &Path,
) -> Result<()> {
    let [time, spp] = charts(runs, curves, regions, region, title);
    for (file, c) in [("error-vs-time", &time), ("error-vs-spp", &spp)] {
        chart::write_svg(c, &dir.join(format!("{file}.svg")))?;
        chart::write_png(c, &dir.join(format!("{file}.png")))?;
    }
    Ok(())
}

/// Reads the runs back from a `convergence.csv` that `stokes converge` wrote: the
/// methods (parsed from the `method` column), their checkpoints and the regions in the
/// order they first occur (`image` first).
pub fn read_runs(path: &Path) -> Result<(Vec<Run>, Vec<MeasuredRegion>)> {
    let t = Table::read(path, "--redraw")?;
    let names = [
        "method", "pass", "spp", "seconds", "region", "rmse", "relmse",
    ];
    let mut cols = [0usize; 7];
    for (c, name) in cols.iter_mut().zip(names) {
        *c = t.column(name)?;
    }
    let base: Resolved = Method::default().with_tracking(Tracking::Classic);
    let mut regions: Vec<MeasuredRegion> = Vec::new();
    let mut rows = Vec::new();
    for (n, row) in &t.rows {
        let method = Method::parse_with(&row[cols[0]], &base).map_err(|e| {
            Error::file(
                path,
                Some(*n),
                Detail::Text(format!("expected a method name in column `method`: {e}")),
            )
        })?;
        let whole = |col: usize, name: &str| -> Result<u32> {
            let v = t.number(*n, row, col, name)?;
            if v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f64 {
                Ok(v as u32)
            } else {
                Err(Error::file(
                    path,
                    Some(*n),
                    Detail::expected(format!("a whole number in column `{name}`"), v),
                ))
            }
        };
        let region = &row[cols[4]];
        let r = match regions.iter().position(|r| &r.name == region) {
            Some(r) => r,
            None => {
                regions.push(MeasuredRegion {
                    name: region.clone(),
                    pixels: Vec::new(),
                });
                regions.len() - 1
            }
        };
        let e = Errors {
            rmse: t.number(*n, row, cols[5], "rmse")?,
            relmse: t.number(*n, row, cols[6], "relmse")?,
            spectral: None,
        };
        let pass = whole(cols[1], "pass")?;
        let spp = whole(cols[2], "spp")?;
        rows.push((
            method,
            pass,
            spp,
            t.number(*n, row, cols[3], "seconds")?,
            r,
            e,
        ));
    }
    // `image` first, as a run measures it.
    if let Some(i) = regions.iter().position(|r| r.name == "image") {
        let image = regions.remove(i);
        regions.insert(0, image);
        for row in &mut rows {
            row.4 = match row.4 {
                r if r == i => 0,
                r if r < i => r + 1,
                r => r,
            };
        }
    }
    let nan = Errors {
        rmse: f64::NAN,
        relmse: f64::NAN,
        spectral: None,
    };
    let mut runs: Vec<Run> = Vec::new();
    for (method, pass, spp, seconds, r, e) in rows {
        let run = match runs.iter_mut().position(|run| run.method == method) {
            Some(i) => &mut runs[i],
            None => {
                runs.push(Run {
                    method,
                    checkpoints: Vec::new(),
                    nonfinite: 0,
                });
                runs.last_mut().expect("just pushed")
            }
        };
        let new = run
            .checkpoints
            .last()
            .is_none_or(|c| (c.pass, c.spp) != (pass, spp));
        if new {
            run.checkpoints.push(Checkpoint {
                pass,
                spp,
                seconds,
                errors: vec![nan; regions.len()],
            });
        }
        if let Some(c) = run.checkpoints.last_mut() {
            c.errors[r] = e;
        }
    }
    if runs.is_empty() {
        return Err(Error::file(
            path,
            None,
            Detail::expected("rows after the header", "none"),
        ));
    }
    Ok((runs, regions))
}

/// `stokes converge --redraw DIR`: reads `DIR/convergence.csv` ([`read_runs`]), writes
/// the charts ([`write_charts`], with `curves`) into `out` and returns the summary. The
/// title is the directory's name (the CSV does not name the scene).
pub fn redraw(dir: &Path, out: &Path, curves: &[Curve]) -> Result<String> {
    let csv = dir.join(FILES[0]);
    let (runs, regions) = read_runs(&csv)?;
    let region = chart_region(&regions);
    check_compare(curves, &regions[region].name)?;
    let files: Vec<PathBuf> = FILES[1..].iter().map(|f| out.join(f)).collect();
    let outputs: Vec<(&str, &Path)> = files.iter().map(|f| ("--out", f.as_path())).collect();
    check_outputs(&outputs)?;
    std::fs::create_dir_all(out).map_err(|e| {
        Error::option(
            &format!("--out {}", out.display()),
            format!("cannot create directory: {e}"),
        )
    })?;
    let canonical = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    let title = canonical.file_name().map_or_else(
        || dir.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    write_charts(&runs, curves, &regions, region, &title, out)?;
    Ok(format!(
        "{title}: redrawn from {}\n\n{}",
        csv.display(),
        summary(&runs, curves, &regions, region)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::{Dispersion, Shifting, Spectral};

    /// The 18 methods of the fluorescent volume scene.
    fn volume_methods() -> Vec<Resolved> {
        let mut out = Vec::new();
        for (spectral, shifting) in [
            (Spectral::Hwss, Shifting::Independent),
            (Spectral::Hwss, Shifting::Constant),
            (Spectral::Mono, Shifting::Independent),
        ] {
            for tracking in [Tracking::Classic, Tracking::Max, Tracking::FluoAware] {
                for rays in [Rays::Single, Rays::Packet] {
                    // Axes not named here keep the default method's values (split).
                    out.push(Method {
                        spectral,
                        shifting,
                        tracking,
                        rays,
                        ..Method::default().with_tracking(Tracking::Classic)
                    });
                }
            }
        }
        out
    }

    #[test]
    fn rays_only_differences_collapse_on_the_spp_chart() {
        let ms = volume_methods();
        let groups = spp_groups(&ms);
        assert_eq!(groups.len(), 9);
        for g in &groups {
            assert_eq!(g.len(), 2, "{g:?}");
            let (a, b) = (ms[g[0]], ms[g[1]]);
            assert_ne!(a.rays, b.rays);
            assert_eq!(a, Method { rays: a.rays, ..b });
        }
        // Any other difference keeps methods apart.
        let two = [
            ms[0],
            Method {
                tracking: Tracking::Max,
                ..ms[0]
            },
        ];
        assert_eq!(spp_groups(&two), [vec![0], vec![1]]);

        // On the charts: 18 lines against time, 9 against spp, whose points are the
        // union of the pair's checkpoints.
        let runs: Vec<Run> = ms
            .iter()
            .enumerate()
            .map(|(i, &m)| fake_run(m, 4 + (i % 2) as u32))
            .collect();
        let regions = [region("image")];
        let [time, spp] = charts(&runs, &[], &regions, 0, "t");
        assert_eq!(time.series.len(), 18);
        assert_eq!(spp.series.len(), 9);
        let xs: Vec<f64> = spp.series[0].points.iter().map(|p| p.0).collect();
        // single went to 32 spp, packet to 64: the line goes on to 64.
        assert_eq!(xs, [1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0]);
        assert_eq!(spp.series[0].name, "hwss-independent-classic");
        assert_eq!(time.series[0].name, "hwss-independent-classic-single");
    }

    #[test]
    fn styles_follow_the_axes_meaning() {
        let ms = volume_methods();
        let st = styles(&ms);
        for (a, sa) in ms.iter().zip(&st) {
            for (b, sb) in ms.iter().zip(&st) {
                let same_spectral = (a.spectral, a.shifting, a.dispersion)
                    == (b.spectral, b.shifting, b.dispersion);
                assert_eq!(sa.colour == sb.colour, same_spectral, "{a} {b}");
                assert_eq!(sa.dash == sb.dash, a.tracking == b.tracking, "{a} {b}");
                assert_eq!(sa.marker == sb.marker, a.rays == b.rays, "{a} {b}");
            }
        }
        // Colours in order of first occurrence; dashes and markers in the axes' order.
        assert_eq!(
            st[0],
            MethodStyle {
                colour: 0,
                dash: 0,
                marker: 1
            }
        );
        assert_eq!(
            st[17],
            MethodStyle {
                colour: 2,
                dash: 2,
                marker: 0
            }
        );
        assert_eq!(st[0].style().dash, Dash::Solid);
        assert_eq!(Style { ..st[2].style() }.dash, Dash::Dashed);
        // One spectral method: one colour; the legend names it in full.
        let one: Vec<Resolved> = ms
            .iter()
            .copied()
            .filter(|m| m.spectral == Spectral::Mono)
            .collect();
        assert!(styles(&one).iter().all(|s| s.colour == 0));
        let l = legend(&one, &styles(&one), true);
        assert_eq!(l[0].entries.len(), 1);
        let spectral: Vec<&str> = one[0]
            .parts()
            .into_iter()
            .filter(|p| !["classic", "single"].contains(p))
            .collect();
        assert_eq!(l[0].entries[0].label, spectral.join("-"));
        assert!(
            l[0].entries[0].label.starts_with("mono-") && l[0].entries[0].label.ends_with("-split")
        );
        let titles: Vec<&str> = l.iter().map(|s| s.title.as_str()).collect();
        assert_eq!(
            titles,
            ["colour: spectral method", "line: tracking", "marker: rays"]
        );
    }

    #[test]
    fn names_keep_the_axes_that_vary() {
        let ms = volume_methods();
        let names = short_names(&ms);
        assert_eq!(names[0], "hwss-independent-classic-single");
        assert_eq!(names[17], "mono-independent-fluo-aware-packet");
        // The common values, with their axes' names (whatever other axes the method has,
        // which share their value here too).
        let common = common_values(&ms);
        let items: Vec<&str> = common.split(", ").collect();
        assert!(items.contains(&"dispersion split"), "{common}");
        assert!(
            !common.contains("hwss") && !common.contains("classic"),
            "{common}"
        );
        let pair = [ms[0], ms[1]];
        assert_eq!(short_names(&pair), ["single", "packet"]);
        let common = common_values(&pair);
        let items: Vec<&str> = common.split(", ").collect();
        for want in [
            "spectral hwss",
            "shifting independent",
            "tracking classic",
            "dispersion split",
        ] {
            assert!(items.contains(&want), "{want} not in {common}");
        }
        assert!(
            !common.contains("single") && !common.contains("packet"),
            "{common}"
        );
        // Nothing varies: the full name.
        assert_eq!(short_names(&ms[..1]), [ms[0].to_string()]);
        // The spp chart's group names leave the rays out too.
        let varies = varying_axes(&pair);
        let all_but_rays: Vec<&str> = pair[0]
            .parts()
            .into_iter()
            .filter(|p| *p != "single")
            .collect();
        assert_eq!(
            name_without(&pair[0], &varies, &[roles(&pair[0]).rays]),
            all_but_rays.join("-")
        );
        assert!(all_but_rays.join("-").starts_with("hwss-"));
    }

    fn region(name: &str) -> MeasuredRegion {
        MeasuredRegion {
            name: name.into(),
            pixels: Vec::new(),
        }
    }

    /// A run with checkpoints at 1, 2, 4, … 2^(n+1) spp; relMSE 1/spp.
    fn fake_run(method: Resolved, n: u32) -> Run {
        Run {
            method,
            checkpoints: (0..=n + 1)
                .map(|k| {
                    let spp = 1u32 << k;
                    let e = Errors {
                        rmse: 1.0 / (spp as f64).sqrt(),
                        relmse: 1.0 / spp as f64,
                        spectral: None,
                    };
                    Checkpoint {
                        pass: spp,
                        spp,
                        seconds: spp as f64 * 0.01,
                        errors: vec![e, e],
                    }
                })
                .collect(),
            nonfinite: 0,
        }
    }

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("stokes-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn compare_files_are_read_by_column_name() {
        let dir = scratch("compare");
        let good = dir.join("good.csv");
        std::fs::write(
            &good,
            "region,method,variant,spp,seconds,rmse,relmse\r\n\
             image,mitsuba-llvm_ad_spectral,,1,0.5,0.4,1.5\r\n\
             image,mitsuba-llvm_ad_spectral,,2,1.0,0.3,0.75\r\n\
             \r\n\
             image,\"pbrt\",x,4,2,1e-1,2.5e-1\r\n",
        )
        .unwrap();
        let curves = read_compare(&good).unwrap();
        assert_eq!(curves.len(), 2);
        assert_eq!(curves[0].name, "mitsuba-llvm_ad_spectral");
        assert_eq!(curves[0].points.len(), 2);
        assert_eq!(
            curves[1].points[0],
            CurvePoint {
                region: "image".into(),
                spp: 4.0,
                seconds: 2.0,
                rmse: 0.1,
                relmse: 0.25
            }
        );
        assert!(check_compare(&curves, "image").is_ok());
        let e = check_compare(&curves, "dye-block").unwrap_err().to_string();
        assert!(
            e.starts_with("--compare ") && e.contains("dye-block"),
            "{e}"
        );
        let rows = compare_rows(&curves, "image", 1.0);
        // 1.5 at 0.5 s, 0.75 at 1 s: relMSE 1 at 0.75 s (log–log).
        assert!((rows[0].time_to_target.unwrap() - 0.75).abs() < 1e-9);
        assert!(rows.iter().all(|r| r.external.is_some()));

        let missing = dir.join("missing.csv");
        std::fs::write(&missing, "method,spp,seconds,region,rmse\nm,1,1,image,1\n").unwrap();
        let e = read_compare(&missing).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}:1: expected a column `relmse` in the header, found the columns method,spp,seconds,region,rmse",
                missing.display()
            )
        );
        let bad = dir.join("bad.csv");
        std::fs::write(
            &bad,
            "method,spp,seconds,region,rmse,relmse\nm,1,1,image,1,1\nm,2,fast,image,1,1\n",
        )
        .unwrap();
        let e = read_compare(&bad).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}:3: expected a finite number in column `seconds`, found \"fast\"",
                bad.display()
            )
        );
        let short = dir.join("short.csv");
        std::fs::write(&short, "method,spp,seconds,region,rmse,relmse\nm,1,1\n").unwrap();
        let e = read_compare(&short).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}:2: expected 6", short.display())),
            "{e}"
        );
        let none = dir.join("none.csv");
        let e = read_compare(&none).unwrap_err().to_string();
        assert!(
            e.starts_with("--compare ") && e.contains("none.csv cannot be read"),
            "{e}"
        );
        assert!(!e.contains('\n'));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn thirty_six_lines_and_a_compare_curve_draw() {
        let dir = scratch("charts36");
        // 18 methods × two wavelength samplings, stood in for by two dispersions.
        let ms: Vec<Resolved> = volume_methods()
            .into_iter()
            .flat_map(|m| {
                [
                    m,
                    Method {
                        dispersion: Dispersion::Drop,
                        ..m
                    },
                ]
            })
            .collect();
        assert_eq!(ms.len(), 36);
        let runs: Vec<Run> = ms
            .iter()
            .enumerate()
            .map(|(i, &m)| fake_run(m, 5 + (i % 3) as u32))
            .collect();
        let curve = Curve {
            name: "mitsuba-llvm_ad_spectral".into(),
            file: "m.csv".into(),
            points: (0..6)
                .map(|k| CurvePoint {
                    region: "dye".into(),
                    spp: (1 << k) as f64,
                    seconds: 0.004 * (1 << k) as f64,
                    rmse: 0.5 / ((1 << k) as f64).sqrt(),
                    relmse: 0.4 / (1 << k) as f64,
                })
                .collect(),
        };
        let regions = [region("image"), region("dye")];
        write_charts(
            &runs,
            std::slice::from_ref(&curve),
            &regions,
            1,
            "volume",
            &dir,
        )
        .unwrap();
        for f in [
            "error-vs-time.svg",
            "error-vs-time.png",
            "error-vs-spp.svg",
            "error-vs-spp.png",
        ] {
            let len = std::fs::metadata(dir.join(f)).map(|m| m.len()).unwrap_or(0);
            assert!(len > 1000, "{f}: {len} bytes");
        }
        let [time, spp] = charts(&runs, &[curve], &regions, 1, "volume");
        assert_eq!(time.series.len(), 37);
        assert_eq!(spp.series.len(), 19);
        assert_eq!(time.series[36].style.colour, neutral(0));
        // The external curve is the fastest to the target (relMSE 1/64, the worst final):
        // at 0.1024 s, where ours take 0.64 s.
        let t = time.target.as_ref().unwrap();
        assert!(
            t.label
                .contains("fastest: mitsuba-llvm_ad_spectral (external) in 0.102 s"),
            "{}",
            t.label
        );
        assert!((t.y - 1.0 / 64.0).abs() < 1e-12 && (t.x - 0.1024).abs() < 1e-9);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn runs_read_back_from_the_csv() {
        let dir = scratch("redraw");
        let runs: Vec<Run> = volume_methods()[..4]
            .iter()
            .map(|&m| fake_run(m, 2))
            .collect();
        let regions = [region("image"), region("dye")];
        let path = dir.join("convergence.csv");
        std::fs::write(&path, super::super::converge::csv(&runs, &regions)).unwrap();
        let (back, reg) = read_runs(&path).unwrap();
        let names: Vec<&str> = reg.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, ["image", "dye"]);
        assert_eq!(back.len(), 4);
        for (a, b) in runs.iter().zip(&back) {
            assert_eq!(a.method, b.method);
            assert_eq!(a.checkpoints.len(), b.checkpoints.len());
            for (x, y) in a.checkpoints.iter().zip(&b.checkpoints) {
                assert_eq!((x.pass, x.spp), (y.pass, y.spp));
                assert!((x.errors[1].relmse - y.errors[1].relmse).abs() < 1e-6);
            }
        }
        std::fs::write(
            &path,
            "method,pass,spp,seconds,region,rmse,relmse\nhwss-bogus,1,1,1,image,1,1\n",
        )
        .unwrap();
        let e = read_runs(&path).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}:2: expected a method name", path.display())),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
