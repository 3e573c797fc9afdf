//! Log–log line charts (error against time or spp) as SVG and PNG, through `plotters`
//! without any system font library: the text is laid out with DejaVu Sans, embedded
//! from `assets/` (Bitstream Vera licence, `assets/DejaVuSans-LICENSE.txt`). Files are
//! written atomically ([`crate::output::write_atomically`]).
//!
//! A line has a [`Style`]: a colour, a [`Dash`] pattern and a [`Marker`] at its points,
//! so that a chart can give each a meaning (in `stokes converge`: the colour is the
//! spectral method, the dash the tracking, the marker the rays). The legend, to the right
//! of the plot, is a list of [`LegendSection`]s that explain those meanings, written by
//! the caller; the canvas grows downwards when the legend needs it.

use crate::error::Error;
use crate::output::write_atomically;
use crate::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// The embedded font: DejaVu Sans 2.37, from Debian's `fonts-dejavu-core`.
static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// Registers the embedded font as `sans-serif` (once). It fails only if the build
/// embedded a broken font: an [`Error::Other`], as no input is to blame.
pub(crate) fn register_font() -> Result<()> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let valid = *ONCE.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok()
    });
    match valid {
        true => Ok(()),
        false => Err(Error::Other(
            "the embedded font (assets/DejaVuSans.ttf) is not a valid font".into(),
        )),
    }
}

/// How a line is stroked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dash {
    /// A continuous line.
    Solid,
    /// Long dashes.
    Dashed,
    /// Dots.
    Dotted,
    /// Dash, dot.
    DashDot,
    /// Long dash, two dots.
    DashDotDot,
}

impl Dash {
    /// Every pattern, in the order lines take them.
    pub const ALL: [Dash; 5] = [
        Dash::Solid,
        Dash::Dashed,
        Dash::Dotted,
        Dash::DashDot,
        Dash::DashDotDot,
    ];

    /// The `i`-th pattern (cycling).
    pub fn nth(i: usize) -> Dash {
        Dash::ALL[i % Dash::ALL.len()]
    }

    /// Lengths in pixels, on and off alternately; empty for a solid line.
    fn pattern(self) -> &'static [f64] {
        match self {
            Dash::Solid => &[],
            Dash::Dashed => &[11.0, 6.0],
            Dash::Dotted => &[2.5, 4.5],
            Dash::DashDot => &[11.0, 4.0, 2.5, 4.0],
            Dash::DashDotDot => &[11.0, 4.0, 2.5, 4.0, 2.5, 4.0],
        }
    }
}

/// The shape drawn at a line's points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// A filled disc.
    Circle,
    /// A filled triangle, point up.
    Triangle,
    /// A filled square.
    Square,
    /// A filled diamond.
    Diamond,
    /// A filled triangle, point down.
    TriangleDown,
    /// A `+`.
    Plus,
    /// An `×`.
    Cross,
    /// A small dot (a point without a meaning of its own).
    Dot,
    /// A five-pointed star (the chart's [`Target`] uses a large one).
    Star,
}

impl Marker {
    /// The filled shapes, in the order lines take them.
    pub const SHAPES: [Marker; 5] = [
        Marker::Circle,
        Marker::Triangle,
        Marker::Square,
        Marker::Diamond,
        Marker::TriangleDown,
    ];

    /// The `i`-th filled shape (cycling).
    pub fn nth(i: usize) -> Marker {
        Marker::SHAPES[i % Marker::SHAPES.len()]
    }
}

/// An sRGB colour.
pub type Colour = (u8, u8, u8);

/// Distinguishable colours: Tableau 10 without its grey (kept for other renderers'
/// lines, [`neutral`]), then plotters' 99-colour palette.
pub fn colour(i: usize) -> Colour {
    const TAB9: [Colour; 9] = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (188, 189, 34),
        (23, 190, 207),
    ];
    match TAB9.get(i) {
        Some(&c) => c,
        None => {
            let c = Palette99::pick(i - TAB9.len()).to_rgba();
            (c.0, c.1, c.2)
        }
    }
}

/// Black and greys, for lines that stand apart from the coloured ones (cycling).
pub fn neutral(i: usize) -> Colour {
    const GREYS: [Colour; 3] = [(0, 0, 0), (105, 105, 105), (160, 160, 160)];
    GREYS[i % GREYS.len()]
}

/// How a line looks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Style {
    /// Its colour.
    pub colour: Colour,
    /// Its dash pattern.
    pub dash: Dash,
    /// The shape at its points.
    pub marker: Marker,
}

impl Default for Style {
    fn default() -> Style {
        Style {
            colour: colour(0),
            dash: Dash::Solid,
            marker: Marker::Circle,
        }
    }
}

/// One line: a name and its points.
#[derive(Debug, Clone)]
pub struct Series {
    /// The line's name (in the SVG; the legend is [`LogLogChart::legend`]).
    pub name: String,
    /// `(x, y)`; points with a non-positive or non-finite coordinate are left out.
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub style: Style,
}

/// A sample of a legend entry: a short line, a marker on it, or both.
#[derive(Debug, Clone)]
pub struct LegendEntry {
    /// The text beside the sample.
    pub label: String,
    /// The sample's colour.
    pub colour: Colour,
    /// The line's pattern, if a line is drawn.
    pub dash: Option<Dash>,
    /// The marker, if one is drawn.
    pub marker: Option<Marker>,
}

/// A titled group of legend entries (`colour: spectral method`, …).
#[derive(Debug, Clone)]
pub struct LegendSection {
    /// The heading.
    pub title: String,
    /// The entries; an entry without line or marker is a note.
    pub entries: Vec<LegendEntry>,
}

/// A point to single out: a large star at `(x, y)`, a dotted horizontal line at `y`
/// across the plot and a label above it.
#[derive(Debug, Clone)]
pub struct Target {
    /// Where the star goes (x).
    pub x: f64,
    /// Where the star and the line go (y).
    pub y: f64,
    /// The star's fill.
    pub colour: Colour,
    /// The text beside the line.
    pub label: String,
}

/// A dashed reference line of some slope through the centre of all points (in log–log
/// coordinates), with its legend text.
#[derive(Debug, Clone)]
pub struct Slope {
    /// d ln y / d ln x.
    pub slope: f64,
    /// Its legend entry.
    pub label: String,
}

/// A chart with logarithmic axes.
#[derive(Debug, Clone)]
pub struct LogLogChart {
    /// Title above the plot.
    pub title: String,
    /// A second, smaller line under the title (empty for none).
    pub subtitle: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// The lines.
    pub series: Vec<Series>,
    /// The legend, beside the plot (the reference slope adds its own entry).
    pub legend: Vec<LegendSection>,
    /// A reference line.
    pub reference_slope: Option<Slope>,
    /// A point to mark.
    pub target: Option<Target>,
}

/// The smallest image, in pixels; it grows downwards if the legend needs more room.
pub const SIZE: (u32, u32) = (1400, 800);

/// The width of the legend column.
const LEGEND_WIDTH: u32 = 400;
/// Legend rows.
const ROW: i32 = 22;
/// The space under a legend section.
const SECTION_GAP: i32 = 12;
/// The legend's first row.
const LEGEND_TOP: i32 = 76;

/// The image size for `c`: [`SIZE`], taller if the legend does not fit.
pub fn size(c: &LogLogChart) -> (u32, u32) {
    let rows: usize = c.legend.iter().map(|s| 1 + s.entries.len()).sum::<usize>()
        + usize::from(c.reference_slope.is_some()) * 2;
    let sections = c.legend.len() + usize::from(c.reference_slope.is_some());
    let needed = LEGEND_TOP as usize + rows * ROW as usize + sections * SECTION_GAP as usize + 20;
    (SIZE.0, SIZE.1.max(needed as u32))
}

/// A tick label with about three significant digits and no trailing zeros: `0.002`,
/// `0.25`, `1`, `10`, `1500`.
fn tick(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return format!("{v}");
    }
    let decimals = (2.0 - v.log10().floor()).clamp(0.0, 9.0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn valid(p: &(f64, f64)) -> bool {
    p.0.is_finite() && p.1.is_finite() && p.0 > 0.0 && p.1 > 0.0
}

/// A log range around `lo..hi` with some room on both sides.
fn padded(lo: f64, hi: f64) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0) {
        return (0.1, 10.0);
    }
    let (lo, hi) = if hi > lo * 1.0001 {
        (lo, hi)
    } else {
        (lo / 2.0, hi * 2.0)
    };
    let pad = (hi / lo).powf(0.04);
    (lo / pad, hi * pad)
}

/// The pieces of the polyline `path` that a dash `pattern` (lengths on and off
/// alternately, in the path's units) keeps; the whole path if the pattern is empty.
pub fn dashes(path: &[(f64, f64)], pattern: &[f64]) -> Vec<Vec<(f64, f64)>> {
    if pattern.is_empty() || pattern.iter().any(|l| l.is_nan() || *l <= 0.0) {
        return if path.len() > 1 {
            vec![path.to_vec()]
        } else {
            vec![]
        };
    }
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let (mut k, mut left) = (0usize, pattern[0]);
    let mut current: Vec<(f64, f64)> = path.first().map(|&p| vec![p]).unwrap_or_default();
    for w in path.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        let mut done = 0.0;
        while len - done >= left {
            done += left;
            let t = done / len;
            let p = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
            if k % 2 == 0 {
                current.push(p);
                out.push(std::mem::take(&mut current));
            } else {
                current = vec![p];
            }
            k = (k + 1) % pattern.len();
            left = pattern[k];
        }
        left -= len - done;
        if k % 2 == 0 {
            current.push(b);
        }
    }
    if k % 2 == 0 && current.len() > 1 {
        out.push(current);
    }
    out
}

fn rgb(c: Colour) -> RGBColor {
    RGBColor(c.0, c.1, c.2)
}

/// Strokes the polyline `pixels` (backend coordinates) with `dash`.
fn draw_line<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    pixels: &[(f64, f64)],
    colour: Colour,
    width: u32,
    dash: Dash,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let style = rgb(colour).stroke_width(width);
    for piece in dashes(pixels, dash.pattern()) {
        let pts: Vec<(i32, i32)> = piece
            .iter()
            .map(|p| (p.0.round() as i32, p.1.round() as i32))
            .collect();
        area.draw(&PathElement::new(pts, style))?;
    }
    Ok(())
}

/// Draws `marker` centred at `c` (backend coordinates), `r` pixels in radius.
fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    marker: Marker,
    c: (i32, i32),
    r: i32,
    colour: Colour,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let fill = rgb(colour).filled();
    let at = |pts: &[(f64, f64)]| -> Vec<(i32, i32)> {
        pts.iter()
            .map(|&(x, y)| {
                (
                    c.0 + (x * r as f64).round() as i32,
                    c.1 + (y * r as f64).round() as i32,
                )
            })
            .collect()
    };
    match marker {
        Marker::Circle => area.draw(&Circle::new(c, r, fill)),
        Marker::Dot => area.draw(&Circle::new(c, (r / 2).max(2), fill)),
        Marker::Triangle => area.draw(&Polygon::new(
            at(&[(0.0, -1.25), (1.15, 0.85), (-1.15, 0.85)]),
            fill,
        )),
        Marker::TriangleDown => area.draw(&Polygon::new(
            at(&[(0.0, 1.25), (1.15, -0.85), (-1.15, -0.85)]),
            fill,
        )),
        Marker::Square => area.draw(&Polygon::new(
            at(&[(-0.9, -0.9), (0.9, -0.9), (0.9, 0.9), (-0.9, 0.9)]),
            fill,
        )),
        Marker::Diamond => area.draw(&Polygon::new(
            at(&[(0.0, -1.3), (1.1, 0.0), (0.0, 1.3), (-1.1, 0.0)]),
            fill,
        )),
        Marker::Plus | Marker::Cross => {
            let s = rgb(colour).stroke_width(2);
            type Stroke = [(f64, f64); 2];
            let (a, b): (Stroke, Stroke) = if marker == Marker::Plus {
                ([(-1.3, 0.0), (1.3, 0.0)], [(0.0, -1.3), (0.0, 1.3)])
            } else {
                ([(-1.0, -1.0), (1.0, 1.0)], [(-1.0, 1.0), (1.0, -1.0)])
            };
            area.draw(&PathElement::new(at(&a), s))?;
            area.draw(&PathElement::new(at(&b), s))
        }
        Marker::Star => {
            let pts: Vec<(f64, f64)> = (0..10)
                .map(|k| {
                    let a = std::f64::consts::PI * (k as f64 / 5.0 - 0.5);
                    let rad = if k % 2 == 0 { 1.3 } else { 0.55 };
                    (rad * a.cos(), rad * a.sin())
                })
                .collect();
            area.draw(&Polygon::new(at(&pts), fill))?;
            let mut outline = at(&pts);
            outline.push(outline[0]);
            area.draw(&PathElement::new(outline, BLACK.stroke_width(1)))
        }
    }
}

/// Draws `c` on `root`. Drawing happens in memory, before the file is named: an error
/// is an [`Error::Other`].
fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, c: &LogLogChart) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| {
        Error::Other(format!("cannot draw the chart: {e}"))
    };
    root.fill(&WHITE).map_err(err)?;
    let (width, _) = root.dim_in_pixel();
    let (left, legend) = root.split_horizontally(width - LEGEND_WIDTH);
    let (head, plot) = left.split_vertically(if c.subtitle.is_empty() { 44 } else { 66 });

    // Title and subtitle.
    let title = ("sans-serif", 21).into_font().color(&BLACK);
    head.draw(&Text::new(c.title.clone(), (16, 12), title))
        .map_err(err)?;
    if !c.subtitle.is_empty() {
        let sub = ("sans-serif", 15).into_font().color(&RGBColor(60, 60, 60));
        head.draw(&Text::new(c.subtitle.clone(), (16, 40), sub))
            .map_err(err)?;
    }

    let series: Vec<Vec<(f64, f64)>> = c
        .series
        .iter()
        .map(|s| s.points.iter().copied().filter(valid).collect())
        .collect();
    let marks: Vec<(f64, f64)> = c.target.iter().map(|t| (t.x, t.y)).filter(valid).collect();
    let all = series.iter().flatten().chain(&marks);
    let (x_lo, x_hi) = all.clone().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (y_lo, y_hi) = all.fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let (x_lo, x_hi) = padded(x_lo, x_hi);
    let (y_lo, y_hi) = padded(y_lo, y_hi);

    let mut chart = ChartBuilder::on(&plot)
        .margin(14)
        .x_label_area_size(54)
        .y_label_area_size(88)
        .build_cartesian_2d((x_lo..x_hi).log_scale(), (y_lo..y_hi).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(&c.x_label)
        .y_desc(&c.y_label)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(215, 215, 215))
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()
        .map_err(err)?;
    let px = |p: &(f64, f64)| -> (f64, f64) {
        let (x, y) = chart.backend_coord(p);
        (x as f64, y as f64)
    };
    let (plot_x, plot_y) = chart.plotting_area().get_pixel_range();

    if let Some(slope) = &c.reference_slope {
        let points: Vec<(f64, f64)> = series.iter().flatten().copied().collect();
        if !points.is_empty() {
            let n = points.len() as f64;
            let x0 = (points.iter().map(|p| p.0.ln()).sum::<f64>() / n).exp();
            let y0 = (points.iter().map(|p| p.1.ln()).sum::<f64>() / n).exp();
            let steps = 64;
            let line: Vec<(f64, f64)> = (0..=steps)
                .map(|k| {
                    let x = x_lo * (x_hi / x_lo).powf(k as f64 / steps as f64);
                    (x, y0 * (x / x0).powf(slope.slope))
                })
                .filter(|p| p.1 >= y_lo && p.1 <= y_hi)
                .map(|p| px(&p))
                .collect();
            draw_line(&root, &line, (90, 90, 90), 1, Dash::Dashed).map_err(err)?;
        }
    }
    if let Some(t) = &c.target {
        if valid(&(t.x, t.y)) {
            let (_, y) = px(&(t.x, t.y));
            let line = [(plot_x.start as f64, y), (plot_x.end as f64, y)];
            draw_line(&root, &line, (0, 0, 0), 1, Dash::Dotted).map_err(err)?;
        }
    }
    for (pts, s) in series.iter().zip(&c.series) {
        let pixels: Vec<(f64, f64)> = pts.iter().map(px).collect();
        draw_line(&root, &pixels, s.style.colour, 2, s.style.dash).map_err(err)?;
    }
    for (pts, s) in series.iter().zip(&c.series) {
        for p in pts {
            let (x, y) = px(p);
            draw_marker(
                &root,
                s.style.marker,
                (x as i32, y as i32),
                4,
                s.style.colour,
            )
            .map_err(err)?;
        }
    }
    if let Some(t) = &c.target {
        if valid(&(t.x, t.y)) {
            let (x, y) = px(&(t.x, t.y));
            draw_marker(&root, Marker::Star, (x as i32, y as i32), 11, t.colour).map_err(err)?;
            let font = ("sans-serif", 15).into_font().color(&BLACK);
            let (w, h) = root.estimate_text_size(&t.label, &font).map_err(err)?;
            let lx = plot_x.start + 8;
            let above = y as i32 - h as i32 - 8;
            let ly = if above > plot_y.start + 2 {
                above
            } else {
                y as i32 + 6
            };
            root.draw(&Rectangle::new(
                [(lx - 3, ly - 2), (lx + w as i32 + 3, ly + h as i32 + 2)],
                WHITE.mix(0.85).filled(),
            ))
            .map_err(err)?;
            root.draw(&Text::new(t.label.clone(), (lx, ly), font))
                .map_err(err)?;
        }
    }

    // The legend, beside the plot.
    let text = ("sans-serif", 15).into_font().color(&BLACK);
    let heading = ("sans-serif", 15).into_font().color(&RGBColor(70, 70, 70));
    let mut sections = c.legend.clone();
    if let Some(s) = &c.reference_slope {
        sections.push(LegendSection {
            title: "reference".into(),
            entries: vec![LegendEntry {
                label: s.label.clone(),
                colour: (90, 90, 90),
                dash: Some(Dash::Dashed),
                marker: None,
            }],
        });
    }
    let mut y = LEGEND_TOP;
    let (x0, x1) = (10, 52);
    for section in &sections {
        legend
            .draw(&Text::new(
                section.title.clone(),
                (x0, y - 8),
                heading.clone(),
            ))
            .map_err(err)?;
        y += ROW;
        for e in &section.entries {
            let sample = e.dash.is_some() || e.marker.is_some();
            if let Some(d) = e.dash {
                let line = [(x0 as f64, y as f64), (x1 as f64, y as f64)];
                draw_line(&legend, &line, e.colour, 2, d).map_err(err)?;
            }
            if let Some(m) = e.marker {
                draw_marker(&legend, m, ((x0 + x1) / 2, y), 5, e.colour).map_err(err)?;
            }
            let tx = if sample { x1 + 10 } else { x0 + 8 };
            legend
                .draw(&Text::new(e.label.clone(), (tx, y - 9), text.clone()))
                .map_err(err)?;
            y += ROW;
        }
        y += SECTION_GAP;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// The chart as SVG text.
pub fn svg(chart: &LogLogChart) -> Result<String> {
    register_font()?;
    let mut svg = String::new();
    draw(
        SVGBackend::with_string(&mut svg, size(chart)).into_drawing_area(),
        chart,
    )?;
    Ok(svg)
}

/// Writes the chart as SVG.
pub fn write_svg(chart: &LogLogChart, path: &Path) -> Result<()> {
    let svg = svg(chart)?;
    write_atomically(path, |tmp| {
        std::fs::write(tmp, svg.as_bytes()).map_err(|e| format!("cannot write SVG: {e}").into())
    })
}

/// Writes the chart as an 8-bit RGB PNG.
pub fn write_png(chart: &LogLogChart, path: &Path) -> Result<()> {
    register_font()?;
    let (w, h) = size(chart);
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    draw(
        BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area(),
        chart,
    )?;
    write_rgb8_png(path, w, h, &buf)
}

/// Writes `rgb` (8-bit sRGB, row by row, 3 bytes a pixel) as a PNG, atomically; for
/// whatever was drawn into a bitmap buffer (charts, `stokes figure`'s strips).
pub(crate) fn write_rgb8_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> Result<()> {
    write_atomically(path, |tmp| {
        let file = std::fs::File::create(tmp).map_err(|e| format!("cannot create PNG: {e}"))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Best);
        enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut wr = enc
            .write_header()
            .map_err(|e| format!("cannot write PNG: {e}"))?;
        wr.write_image_data(rgb)
            .map_err(|e| format!("cannot write PNG: {e}"))?;
        wr.finish()
            .map_err(|e| format!("cannot write PNG: {e}").into())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels() {
        assert_eq!(tick(1.0), "1");
        assert_eq!(tick(10.0), "10");
        assert_eq!(tick(1500.0), "1500");
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(0.002), "0.002");
        assert_eq!(tick(0.0012345), "0.00123");
    }

    #[test]
    fn dashes_follow_the_pattern_across_corners() {
        let path = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)];
        assert_eq!(dashes(&path, &[]), vec![path.to_vec()]);
        let d = dashes(&path, &[4.0, 2.0]);
        // On 0–4, 6–10, then 12–16 (2–6 down the second segment), 18–20 (8–10).
        assert_eq!(d.len(), 4, "{d:?}");
        assert_eq!(d[0], vec![(0.0, 0.0), (4.0, 0.0)]);
        assert_eq!(d[1], vec![(6.0, 0.0), (10.0, 0.0)]);
        assert_eq!(d[2], vec![(10.0, 2.0), (10.0, 6.0)]);
        assert_eq!(d[3], vec![(10.0, 8.0), (10.0, 10.0)]);
        // A dash spanning the corner keeps it.
        let d = dashes(&path, &[12.0, 100.0]);
        assert_eq!(d, vec![vec![(0.0, 0.0), (10.0, 0.0), (10.0, 2.0)]]);
        assert!(dashes(&[(1.0, 1.0)], &[2.0, 2.0]).is_empty());
    }

    fn chart(series: Vec<Series>) -> LogLogChart {
        LogLogChart {
            title: "test".into(),
            subtitle: "every line: hwss".into(),
            x_label: "spp".into(),
            y_label: "RMSE".into(),
            series,
            legend: vec![LegendSection {
                title: "colour".into(),
                entries: vec![LegendEntry {
                    label: "flat, with a zero".into(),
                    colour: colour(1),
                    dash: Some(Dash::Dotted),
                    marker: Some(Marker::Diamond),
                }],
            }],
            reference_slope: Some(Slope {
                slope: -0.5,
                label: "slope −½".into(),
            }),
            target: Some(Target {
                x: 2.0,
                y: 0.3,
                colour: colour(0),
                label: "target".into(),
            }),
        }
    }

    #[test]
    fn writes_svg_and_png() {
        let dir = std::env::temp_dir().join(format!("stokes-chart-{}", std::process::id()));
        let chart = chart(vec![
            Series {
                name: "a".into(),
                points: (0..6)
                    .map(|k| ((1 << k) as f64, 1.0 / ((1 << k) as f64).sqrt()))
                    .collect(),
                style: Style::default(),
            },
            Series {
                name: "flat, with a zero".into(),
                points: vec![(1.0, 0.3), (2.0, 0.0), (4.0, 0.3)],
                style: Style {
                    colour: colour(1),
                    dash: Dash::Dotted,
                    marker: Marker::Diamond,
                },
            },
        ]);
        write_svg(&chart, &dir.join("c.svg")).unwrap();
        write_png(&chart, &dir.join("c.png")).unwrap();
        let svg = std::fs::read_to_string(dir.join("c.svg")).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("flat, with a zero"));
        assert!(svg.contains("every line: hwss") && svg.contains("slope −½"));
        let png = std::fs::read(dir.join("c.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        // An empty chart still draws.
        let empty = LogLogChart {
            series: vec![],
            target: None,
            ..chart
        };
        write_svg(&empty, &dir.join("e.svg")).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_long_legend_makes_the_canvas_taller() {
        let mut c = chart(vec![]);
        assert_eq!(size(&c), SIZE);
        let entry = c.legend[0].entries[0].clone();
        c.legend[0].entries = vec![entry; 60];
        let (w, h) = size(&c);
        assert_eq!(w, SIZE.0);
        assert!(h as i32 > LEGEND_TOP + 60 * ROW, "{h}");
    }
}
