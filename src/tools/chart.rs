//! Log–log line charts (error against time or spp) as SVG and PNG, through `plotters`
//! without any system font library: the text is laid out with DejaVu Sans, embedded
//! from `assets/` (Bitstream Vera licence, `assets/DejaVuSans-LICENSE.txt`). Files are
//! written atomically ([`crate::output::write_atomically`]).

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
fn register_font() -> Result<()> {
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

/// One line: a name for the legend and its points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)`; points with a non-positive or non-finite coordinate are left out.
    pub points: Vec<(f64, f64)>,
}

/// A chart with logarithmic axes.
#[derive(Debug, Clone)]
pub struct LogLogChart {
    /// Title above the plot.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// The lines, one colour each.
    pub series: Vec<Series>,
    /// Draw a dashed line of slope −½ (error ∝ 1/√n) through the centre of all points
    /// (in log–log coordinates).
    pub reference_slope: bool,
}

/// Image size in pixels.
pub const SIZE: (u32, u32) = (1100, 640);

/// Distinguishable colours (Tableau 10), then plotters' 99-colour palette.
fn colour(i: usize) -> RGBColor {
    const TAB10: [(u8, u8, u8); 10] = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (188, 189, 34),
        (23, 190, 207),
    ];
    match TAB10.get(i) {
        Some(&(r, g, b)) => RGBColor(r, g, b),
        None => {
            let c = Palette99::pick(i - TAB10.len()).to_rgba();
            RGBColor(c.0, c.1, c.2)
        }
    }
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
    let (plot, legend) = root.split_horizontally(SIZE.0 - 330);

    let series: Vec<Vec<(f64, f64)>> = c
        .series
        .iter()
        .map(|s| s.points.iter().copied().filter(valid).collect())
        .collect();
    let all = series.iter().flatten();
    let (x_lo, x_hi) = all.clone().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (y_lo, y_hi) = all.fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let (x_lo, x_hi) = padded(x_lo, x_hi);
    let (y_lo, y_hi) = padded(y_lo, y_hi);

    let mut chart = ChartBuilder::on(&plot)
        .caption(&c.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d((x_lo..x_hi).log_scale(), (y_lo..y_hi).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(&c.x_label)
        .y_desc(&c.y_label)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()
        .map_err(err)?;

    if c.reference_slope {
        let points: Vec<(f64, f64)> = series.iter().flatten().copied().collect();
        if !points.is_empty() {
            let n = points.len() as f64;
            let x0 = (points.iter().map(|p| p.0.ln()).sum::<f64>() / n).exp();
            let y0 = (points.iter().map(|p| p.1.ln()).sum::<f64>() / n).exp();
            let steps = 32;
            let line: Vec<(f64, f64)> = (0..=steps)
                .map(|k| {
                    let x = x_lo * (x_hi / x_lo).powf(k as f64 / steps as f64);
                    (x, y0 * (x / x0).powf(-0.5))
                })
                .filter(|p| p.1 >= y_lo && p.1 <= y_hi)
                .collect();
            chart
                .draw_series(DashedLineSeries::new(
                    line,
                    8,
                    6,
                    BLACK.mix(0.7).stroke_width(1),
                ))
                .map_err(err)?;
        }
    }
    for (i, pts) in series.iter().enumerate() {
        let col = colour(i);
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), col.stroke_width(2)))
            .map_err(err)?;
        chart
            .draw_series(
                pts.iter()
                    .map(|&p| Circle::new(p, 3, col.filled()).into_dyn()),
            )
            .map_err(err)?;
    }

    // The legend, beside the plot.
    let text = ("sans-serif", 13).into_font().color(&BLACK);
    let mut y = 40;
    let row = 20;
    let mut entries: Vec<(String, ShapeStyle, bool)> = c
        .series
        .iter()
        .enumerate()
        .map(|(i, s)| (s.name.clone(), colour(i).stroke_width(2), false))
        .collect();
    if c.reference_slope {
        entries.push((
            "slope −½ (error ∝ 1/√n)".into(),
            BLACK.stroke_width(1),
            true,
        ));
    }
    for (name, style, dashed) in entries {
        let (x0, x1) = (8, 40);
        if dashed {
            for k in 0..3 {
                legend
                    .draw(&PathElement::new(
                        vec![(x0 + 12 * k, y), (x0 + 12 * k + 7, y)],
                        style,
                    ))
                    .map_err(err)?;
            }
        } else {
            legend
                .draw(&PathElement::new(vec![(x0, y), (x1, y)], style))
                .map_err(err)?;
        }
        legend
            .draw(&Text::new(name, (x1 + 8, y - 7), text.clone()))
            .map_err(err)?;
        y += row;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Writes the chart as SVG.
pub fn write_svg(chart: &LogLogChart, path: &Path) -> Result<()> {
    register_font()?;
    let mut svg = String::new();
    draw(
        SVGBackend::with_string(&mut svg, SIZE).into_drawing_area(),
        chart,
    )?;
    write_atomically(path, |tmp| {
        std::fs::write(tmp, svg.as_bytes()).map_err(|e| format!("cannot write SVG: {e}").into())
    })
}

/// Writes the chart as an 8-bit RGB PNG.
pub fn write_png(chart: &LogLogChart, path: &Path) -> Result<()> {
    register_font()?;
    let (w, h) = SIZE;
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    draw(
        BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area(),
        chart,
    )?;
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
        wr.write_image_data(&buf)
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
    fn writes_svg_and_png() {
        let dir = std::env::temp_dir().join(format!("stokes-chart-{}", std::process::id()));
        let chart = LogLogChart {
            title: "test".into(),
            x_label: "spp".into(),
            y_label: "RMSE".into(),
            series: vec![
                Series {
                    name: "a".into(),
                    points: (0..6)
                        .map(|k| ((1 << k) as f64, 1.0 / ((1 << k) as f64).sqrt()))
                        .collect(),
                },
                Series {
                    name: "flat, with a zero".into(),
                    points: vec![(1.0, 0.3), (2.0, 0.0), (4.0, 0.3)],
                },
            ],
            reference_slope: true,
        };
        write_svg(&chart, &dir.join("c.svg")).unwrap();
        write_png(&chart, &dir.join("c.png")).unwrap();
        let svg = std::fs::read_to_string(dir.join("c.svg")).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("flat, with a zero"));
        let png = std::fs::read(dir.join("c.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        // An empty chart still draws.
        let empty = LogLogChart {
            series: vec![],
            ..chart
        };
        write_svg(&empty, &dir.join("e.svg")).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
    }
}
