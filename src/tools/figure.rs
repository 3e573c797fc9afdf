//! `stokes figure`: renders laid side by side as one labelled PNG strip, with their
//! differences to a reference and a table of their errors — a paper's comparison figure,
//! reproduced from EXRs by a script rather than assembled by hand.
//!
//! **Strip**, top to bottom: the title; row 1, every panel tone-mapped alike ([`tone_map`])
//! with its label under it; row 2 (`--diff`), each panel's difference to the reference
//! through a diverging colour map ([`diverging`]), with a colour bar at its right end;
//! notes (the exposure, the difference's scale). Text is DejaVu Sans, embedded
//! ([`super::chart`]), so a strip looks the same on every machine.
//!
//! **Difference**: the luminance Y = 0.2126 R + 0.7152 G + 0.0722 B (linear sRGB) of the
//! panel minus that of the reference, in the images' linear units (the exposure does not
//! apply), clamped to ±scale. The default scale is the 99th percentile of |difference|
//! over every difference panel: one firefly does not wash out the rest, and every panel
//! shares it, so their colours compare.
//!
//! **Errors** against the reference ([`converge::errors`]: RMSE, and relMSE = mean
//! (x − r)² / (r² + 0.01) over pixels and channels) over the whole image and over each
//! `[[region]]` of `--scene`, scaled to the images' size ([`converge::measured_regions`]).

use super::chart::{register_font, write_rgb8_png};
use super::converge::{self, Errors, MeasuredRegion};
use crate::color::srgb_encode;
use crate::error::{Detail, Error};
use crate::output::{check_outputs, write_atomically, Channels};
use crate::scene::Scene;
use crate::Result;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::{Path, PathBuf};

/// What `stokes figure --help` adds after the options.
pub const HELP: &str = "\
Panels are LABEL=FILE.exr, split at the last `=` (a label may hold `=` and spaces when
quoted; a file name may not hold `=`): \"mono max, 16 spp=out/mono.exr\". Every panel and
the reference must have the same size. A --reference that is not one of the panels is
appended as the last panel, labelled `reference` and its spp (from its stokes:spp header).

Row 1: each panel × 2^EXPOSURE, clamped to [0, 1], sRGB-encoded to 8 bits.
Row 2 (--diff): luminance Y (0.2126 R + 0.7152 G + 0.0722 B, linear) of panel − reference,
blue below 0, white at 0, red above, clamped at ±X (--diff-scale; default the 99th
percentile of |difference| over every difference panel), with a colour bar; the scale is
printed under the strip.

The error table (with --reference; printed to stdout as markdown, and written to --table
as markdown and --csv as CSV): RMSE and relMSE (mean (x − r)² / (r² + 0.01) over pixels
and channels) of each panel against the reference over `image` and every [[region]] of
--scene (regions are given at the scene camera's resolution and scale to the images').";

/// The largest side of a strip: beyond it a figure is a mistake (too many panels, too
/// large a zoom), and the bitmap would take gigabytes.
pub const MAX_SIDE: u32 = 16384;

/// One panel as the command line names it: `LABEL=FILE.exr`.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// The text under it.
    pub label: String,
    /// The EXR.
    pub file: PathBuf,
}

impl Panel {
    /// Parses `LABEL=FILE.exr`, split at the last `=`: labels are free text ("σ=0.5,
    /// 16 spp"), file names seldom hold `=`.
    pub fn parse(arg: &str) -> Result<Panel> {
        let bad = |expected: &str| {
            Error::option(
                &format!("panel {arg:?}"),
                Detail::expected(expected, format!("{arg:?}")),
            )
        };
        let (label, file) = arg
            .rsplit_once('=')
            .ok_or_else(|| bad("LABEL=FILE.exr (a label, `=`, an OpenEXR file)"))?;
        if label.trim().is_empty() {
            return Err(bad("a label before the `=` (LABEL=FILE.exr)"));
        }
        let file = PathBuf::from(file);
        if !has_extension(&file, "exr") {
            return Err(bad("a file name ending in .exr after the last `=`"));
        }
        Ok(Panel {
            label: label.to_string(),
            file,
        })
    }
}

/// Whether `path` ends in `.ext` (any case).
fn has_extension(path: &Path, ext: &str) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// What to draw and write: the options of `stokes figure`.
#[derive(Debug, Clone)]
pub struct Figure {
    /// The panels, left to right.
    pub panels: Vec<Panel>,
    /// The strip (PNG).
    pub output: PathBuf,
    /// The image the differences and errors are taken against.
    pub reference: Option<PathBuf>,
    /// The scene whose `[[region]]`s the error table covers.
    pub scene: Option<PathBuf>,
    /// Whether to draw the difference row.
    pub diff: bool,
    /// The difference mapped to full red or blue (default: [`robust_scale`]).
    pub diff_scale: Option<f64>,
    /// Exposure in EV (stops) of row 1.
    pub exposure: f64,
    /// Each image pixel drawn as zoom × zoom pixels (small renders stay readable).
    pub zoom: u32,
    /// The text above the strip.
    pub title: Option<String>,
    /// Where to write the error table as markdown.
    pub table: Option<PathBuf>,
    /// Where to write the error table as CSV.
    pub csv: Option<PathBuf>,
}

/// A rectangle of the strip, in pixels from its top left corner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    /// Left edge.
    pub x: u32,
    /// Top edge.
    pub y: u32,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
}

/// Where everything is on the strip: what a script (or a test) needs to find a panel.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The strip's width.
    pub width: u32,
    /// Its height.
    pub height: u32,
    /// Row 1's images, left to right (the appended reference last).
    pub panels: Vec<Rect>,
    /// Row 2's differences, one per panel: `None` for the reference's own column.
    pub diffs: Vec<Option<Rect>>,
    /// The colour bar (with `--diff`): +scale at the top, −scale at the bottom.
    pub colour_bar: Option<Rect>,
}

/// One panel's errors against the reference.
#[derive(Debug, Clone)]
pub struct PanelErrors {
    /// Its label.
    pub label: String,
    /// Its file.
    pub file: PathBuf,
    /// Its samples per pixel, if its header says.
    pub spp: Option<u64>,
    /// Its render time in seconds, if its header says.
    pub seconds: Option<f64>,
    /// One per region of [`ErrorTable::regions`].
    pub errors: Vec<Errors>,
}

/// The errors of every panel against the reference over every region.
#[derive(Debug, Clone)]
pub struct ErrorTable {
    /// The reference.
    pub reference: PathBuf,
    /// Its spp, if its header says.
    pub reference_spp: Option<u64>,
    /// The regions' names and pixel counts: `image` first.
    pub regions: Vec<(String, usize)>,
    /// One per panel given (not the appended reference).
    pub rows: Vec<PanelErrors>,
}

/// What [`Figure::make`] wrote and found.
#[derive(Debug, Clone)]
pub struct Made {
    /// Where everything is on the strip.
    pub layout: Layout,
    /// The difference at full colour (with `--diff`).
    pub diff_scale: Option<f64>,
    /// The errors (with a reference).
    pub table: Option<ErrorTable>,
    /// The table as markdown, as written to `--table`.
    pub markdown: Option<String>,
    /// What the user should know but that does not stop the figure.
    pub warnings: Vec<String>,
}

/// An image read for the figure.
struct Image {
    label: String,
    file: PathBuf,
    width: u32,
    height: u32,
    pixels: Vec<[f32; 3]>,
    spp: Option<u64>,
    seconds: Option<f64>,
}

/// Reads the RGB and the spp and time of an EXR; `what` says what it is for in errors.
fn read_image(label: &str, file: &Path, what: &str) -> Result<Image> {
    if !file.is_file() {
        return Err(Error::about(
            file,
            format!("does not exist: expected the OpenEXR image of {what}"),
        ));
    }
    let mut channels = Channels::read(file)?;
    let pixels = channels.take_rgb().ok_or_else(|| {
        Error::about(
            file,
            format!("has no R, G and B channels: expected an RGB OpenEXR image of {what}"),
        )
    })?;
    let attr = |key: &str| {
        channels
            .stokes_attributes()
            .into_iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v)
    };
    Ok(Image {
        label: label.to_string(),
        file: file.to_path_buf(),
        width: channels.width,
        height: channels.height,
        pixels,
        spp: attr("spp").and_then(|v| v.parse().ok()),
        seconds: attr("render_seconds")
            .and_then(|v| v.parse().ok())
            .filter(|s: &f64| s.is_finite()),
    })
}

/// Whether two existing files are the same file.
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// An 8-bit sRGB value of a linear one: × 2^exposure, clamped to [0, 1], encoded (as
/// `stokes render --png` does at exposure 0).
pub fn tone_map(linear: f32, exposure: f64) -> u8 {
    let scaled = (linear as f64 * exposure.exp2()) as f32;
    (srgb_encode(scaled) * 255.0 + 0.5) as u8
}

/// The luminance Y of linear sRGB (Rec. 709 weights).
pub fn luminance(rgb: [f32; 3]) -> f64 {
    0.2126 * rgb[0] as f64 + 0.7152 * rgb[1] as f64 + 0.0722 * rgb[2] as f64
}

/// The blue end of the diverging map (ColorBrewer RdBu's dark blue).
pub const BLUE: [u8; 3] = [33, 102, 172];
/// The red end (RdBu's dark red).
pub const RED: [u8; 3] = [178, 24, 43];

/// The colour of `t` in [−1, 1] (clamped): blue at −1, white at 0, red at 1, linear in
/// between. NaN is black: no colour of the scale.
pub fn diverging(t: f64) -> [u8; 3] {
    if t.is_nan() {
        return [0; 3];
    }
    let t = t.clamp(-1.0, 1.0);
    let end = if t < 0.0 { BLUE } else { RED };
    let a = t.abs();
    end.map(|c| (255.0 + (c as f64 - 255.0) * a).round() as u8)
}

/// The default scale of the differences: the 99th percentile of |difference| over all
/// of them (finite values only); if that is 0, the largest; if every difference is 0, 1
/// (the panels are then white whatever the scale).
pub fn robust_scale(diffs: &[Vec<f64>]) -> f64 {
    let mut all: Vec<f64> = diffs
        .iter()
        .flatten()
        .map(|d| d.abs())
        .filter(|d| d.is_finite())
        .collect();
    if all.is_empty() {
        return 1.0;
    }
    let k = ((all.len() - 1) as f64 * 0.99).round() as usize;
    let (_, p99, _) = all.select_nth_unstable_by(k, f64::total_cmp);
    let p99 = *p99;
    let max = all.iter().copied().fold(0.0, f64::max);
    [p99, max, 1.0]
        .into_iter()
        .find(|&s| s > 0.0)
        .unwrap_or(1.0)
}

/// A number for a tick or a note: three significant digits, `−` for minus.
pub fn format_value(v: f64) -> String {
    let a = v.abs();
    let text = if a == 0.0 {
        "0".to_string()
    } else if (1e-3..1e4).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{a:.decimals$}");
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        };
        s
    } else {
        format!("{a:.2e}")
    };
    if v < 0.0 {
        format!("−{text}")
    } else {
        text
    }
}

impl Figure {
    /// Checks the options against each other and that every output can be written,
    /// before anything is read: a figure that would fail at its last step fails here.
    pub fn check(&self) -> Result<()> {
        let needs_reference = |option: &str, what: &str| {
            Error::option(
                option,
                format!("expected --reference REF.exr as well ({what})"),
            )
        };
        if self.panels.is_empty() {
            return Err(Error::Other(
                "stokes figure needs at least one panel LABEL=FILE.exr".into(),
            ));
        }
        if self.reference.is_none() {
            if self.diff {
                return Err(needs_reference("--diff", "the image to subtract"));
            }
            for (option, given) in [
                ("--table", self.table.is_some()),
                ("--csv", self.csv.is_some()),
                ("--scene", self.scene.is_some()),
            ] {
                if given {
                    return Err(needs_reference(option, "the errors are against it"));
                }
            }
        }
        if let Some(s) = self.diff_scale {
            if !self.diff {
                return Err(Error::option(
                    "--diff-scale",
                    "expected --diff as well (the scale is the difference row's)",
                ));
            }
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::option(
                    "--diff-scale",
                    Detail::expected("a positive number", s),
                ));
            }
        }
        if !self.exposure.is_finite() || self.exposure.abs() > 64.0 {
            return Err(Error::option(
                "--exposure",
                Detail::expected("a number of stops in −64..64", self.exposure),
            ));
        }
        if !(1..=16).contains(&self.zoom) {
            return Err(Error::option(
                "--zoom",
                Detail::expected("a whole number in 1..=16", self.zoom),
            ));
        }
        let out = &self.output;
        check_outputs(&[("-o", out)])?;
        if !has_extension(out, "png") {
            return Err(Error::option(
                &format!("-o {}", out.display()),
                Detail::expected(
                    "a file name ending in .png",
                    format!("{:?}", out.file_name().unwrap_or_default()),
                ),
            ));
        }
        let mut outputs: Vec<(&str, &Path)> = vec![("-o", out)];
        outputs.extend(self.table.as_deref().map(|p| ("--table", p)));
        outputs.extend(self.csv.as_deref().map(|p| ("--csv", p)));
        check_outputs(&outputs)
    }

    /// Checks ([`Figure::check`]), reads the panels, the reference and the scene, draws
    /// the strip, computes the errors and writes every output. Nothing is written unless
    /// every input was read and every panel fits.
    pub fn make(&self) -> Result<Made> {
        self.check()?;
        let mut warnings = Vec::new();
        let mut images = Vec::new();
        for p in &self.panels {
            images.push(read_image(
                &p.label,
                &p.file,
                &format!("panel {:?}", p.label),
            )?);
        }
        let (width, height) = (images[0].width, images[0].height);
        let same_size = |img: &Image, option: Option<&str>| -> Result<()> {
            if (img.width, img.height) == (width, height) {
                return Ok(());
            }
            let rest = format!(
                "is {}x{} but {} is {width}x{height}: every panel and the reference must have the same size",
                img.width,
                img.height,
                images[0].file.display()
            );
            Err(match option {
                Some(o) => Error::about_option(o, &img.file, rest),
                None => Error::about(&img.file, rest),
            })
        };
        for img in &images[1..] {
            same_size(img, None)?;
        }
        // The reference: a panel's image, or read and appended.
        let mut reference_column = None;
        if let Some(path) = &self.reference {
            match images.iter().position(|img| same_file(&img.file, path)) {
                Some(i) => reference_column = Some(i),
                None => {
                    let mut r = read_image("reference", path, "--reference")?;
                    same_size(&r, Some("--reference"))?;
                    if let Some(spp) = r.spp {
                        r.label = format!("reference, {spp} spp");
                    }
                    reference_column = Some(images.len());
                    images.push(r);
                }
            }
        }
        let given = self.panels.len();
        let scene = match &self.scene {
            Some(path) => {
                let scene = Scene::load(path)?;
                for w in &scene.warnings {
                    warnings.push(format!("{}: {w}", path.display()));
                }
                let (cw, ch) = (scene.camera.width, scene.camera.height);
                if cw as u64 * height as u64 != ch as u64 * width as u64 {
                    warnings.push(format!(
                        "--scene {}: its camera is {cw}x{ch} but the images are {width}x{height}: its regions are stretched to another aspect ratio",
                        path.display()
                    ));
                }
                Some(scene)
            }
            None => None,
        };

        // Differences and errors.
        let diffs: Vec<Option<Vec<f64>>> = match reference_column {
            Some(r) if self.diff => images
                .iter()
                .enumerate()
                .map(|(i, img)| {
                    (i != r).then(|| {
                        img.pixels
                            .iter()
                            .zip(&images[r].pixels)
                            .map(|(&x, &y)| luminance(x) - luminance(y))
                            .collect()
                    })
                })
                .collect(),
            _ => Vec::new(),
        };
        let diff_scale = self.diff.then(|| {
            self.diff_scale.unwrap_or_else(|| {
                let all: Vec<Vec<f64>> = diffs.iter().flatten().cloned().collect();
                robust_scale(&all)
            })
        });
        let table = reference_column.map(|r| {
            let regions = match &scene {
                Some(s) => converge::measured_regions(s, width, height),
                None => vec![MeasuredRegion {
                    name: "image".into(),
                    pixels: (0..width as usize * height as usize).collect(),
                }],
            };
            let reference = &images[r];
            ErrorTable {
                reference: reference.file.clone(),
                reference_spp: reference.spp,
                regions: regions
                    .iter()
                    .map(|g| (g.name.clone(), g.pixels.len()))
                    .collect(),
                rows: images[..given]
                    .iter()
                    .map(|img| PanelErrors {
                        label: img.label.clone(),
                        file: img.file.clone(),
                        spp: img.spp,
                        seconds: img.seconds,
                        errors: regions
                            .iter()
                            .map(|g| converge::errors(&img.pixels, &reference.pixels, &g.pixels))
                            .collect(),
                    })
                    .collect(),
            }
        });

        // The strip.
        register_font()?;
        let reference_label = reference_column.map(|r| match r < given {
            true => images[r].label.clone(),
            false => "reference".to_string(),
        });
        let diff_labels: Vec<Option<String>> = match &reference_label {
            Some(rl) if self.diff => images
                .iter()
                .enumerate()
                .map(|(i, img)| {
                    (Some(i) != reference_column).then(|| format!("{} − {rl}", img.label))
                })
                .collect(),
            _ => Vec::new(),
        };
        let mut notes = Vec::new();
        if self.exposure != 0.0 {
            notes.push(format!("exposure {:+} EV", self.exposure));
        }
        if let Some(s) = diff_scale {
            let why = match self.diff_scale {
                Some(_) => "--diff-scale",
                None => "the 99th percentile of |difference|",
            };
            notes.push(format!(
                "difference: luminance Y of panel − {} (linear), colour scale ±{} ({why})",
                reference_label.as_deref().unwrap_or("reference"),
                format_value(s)
            ));
        }
        let texts = Texts {
            title: self.title.clone().filter(|t| !t.trim().is_empty()),
            labels: images.iter().map(|i| i.label.clone()).collect(),
            diff_labels,
            notes,
            ticks: diff_scale.map(|s| ticks(s, bar_height(height * self.zoom))),
        };
        let layout = layout(width * self.zoom, height * self.zoom, &texts)?;
        if layout.width > MAX_SIDE || layout.height > MAX_SIDE {
            return Err(Error::option(
                &format!("-o {}", self.output.display()),
                format!(
                    "the strip would be {}x{} pixels, more than {MAX_SIDE} on a side (fewer panels or a smaller --zoom)",
                    layout.width, layout.height
                ),
            ));
        }
        let buf = draw(&layout, &texts, &images, &diffs, diff_scale, self)?;
        let markdown = table.as_ref().map(ErrorTable::markdown);

        // Every output, once everything is computed.
        write_rgb8_png(&self.output, layout.width, layout.height, &buf)?;
        if let (Some(path), Some(text)) = (&self.table, &markdown) {
            write_text(path, text)?;
        }
        if let (Some(path), Some(t)) = (&self.csv, &table) {
            write_text(path, &t.csv())?;
        }
        Ok(Made {
            layout,
            diff_scale,
            table,
            markdown,
            warnings,
        })
    }
}

/// Writes `text` to `path` atomically.
fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomically(path, |tmp| {
        std::fs::write(tmp, text).map_err(|e| format!("cannot write: {e}").into())
    })
}

/// The text a strip holds, which decides its layout.
struct Texts {
    title: Option<String>,
    /// Row 1's labels.
    labels: Vec<String>,
    /// Row 2's labels (empty without `--diff`; `None` in the reference's column).
    diff_labels: Vec<Option<String>>,
    notes: Vec<String>,
    /// The colour bar's values and their labels, top to bottom.
    ticks: Option<Vec<(f64, String)>>,
}

const MARGIN: u32 = 16;
const GAP: u32 = 12;
const TITLE_SIZE: u32 = 22;
const LABEL_SIZE: u32 = 16;
const NOTE_SIZE: u32 = 14;
const TICK_SIZE: u32 = 13;
const BAR_WIDTH: u32 = 14;
/// The tick marks' length, right of the bar.
const TICK_LENGTH: u32 = 4;
/// Space for a line of text of `size` pixels.
const fn line(size: u32) -> u32 {
    size + size / 2
}

/// The colour bar's height: the panels', but at least enough for its tick labels.
fn bar_height(panel_height: u32) -> u32 {
    panel_height.max(100)
}

/// The colour bar's ticks for `scale`: ±scale and 0, and ±scale/2 on a tall bar.
fn ticks(scale: f64, bar_height: u32) -> Vec<(f64, String)> {
    let fractions: &[f64] = if bar_height >= 200 {
        &[1.0, 0.5, 0.0, -0.5, -1.0]
    } else {
        &[1.0, 0.0, -1.0]
    };
    fractions
        .iter()
        .map(|&f| {
            let v = f * scale;
            let text = format_value(v);
            (v, if v > 0.0 { format!("+{text}") } else { text })
        })
        .collect()
}

/// The width of `text` in the embedded font at `size` pixels.
fn text_width(text: &str, size: u32) -> Result<u32> {
    ("sans-serif", size)
        .into_font()
        .box_size(text)
        .map(|(w, _)| w)
        .map_err(|e| Error::Other(format!("cannot lay out the text {text:?}: {e}")))
}

/// Places panels of `pw`×`ph` pixels (zoomed) in columns as wide as the widest label.
fn layout(pw: u32, ph: u32, t: &Texts) -> Result<Layout> {
    let mut label_w = 0;
    for l in t.labels.iter().chain(t.diff_labels.iter().flatten()) {
        label_w = label_w.max(text_width(l, LABEL_SIZE)? + 4);
    }
    let column = pw.max(label_w);
    let n = t.labels.len() as u32;
    let strip_w = n * column + (n - 1) * GAP;
    // The colour bar right of the last difference panel: in the reference's column
    // when the reference is last, as it usually is.
    let last_diff = t.diff_labels.iter().rposition(Option::is_some);
    let bar_x = last_diff.map_or(MARGIN + strip_w, |i| {
        MARGIN + (i as u32 + 1) * (column + GAP)
    }) + GAP / 2;
    let bar_h = bar_height(ph);
    let mut content_w = strip_w;
    if let Some(ticks) = &t.ticks {
        let mut widest = 0;
        for (_, text) in ticks {
            widest = widest.max(text_width(text, TICK_SIZE)?);
        }
        content_w = content_w.max(bar_x + BAR_WIDTH + TICK_LENGTH + 3 + widest - MARGIN);
    }
    if let Some(title) = &t.title {
        content_w = content_w.max(text_width(title, TITLE_SIZE)?);
    }
    for note in &t.notes {
        content_w = content_w.max(text_width(note, NOTE_SIZE)?);
    }
    let mut y = MARGIN;
    if t.title.is_some() {
        y += line(TITLE_SIZE) + 4;
    }
    let x = |i: u32| MARGIN + i * (column + GAP) + (column - pw) / 2;
    let panels = (0..n)
        .map(|i| Rect {
            x: x(i),
            y,
            width: pw,
            height: ph,
        })
        .collect();
    y += ph + line(LABEL_SIZE);
    let (mut diffs, mut colour_bar) = (vec![None; n as usize], None);
    if t.ticks.is_some() {
        y += GAP;
        for (i, d) in diffs.iter_mut().enumerate() {
            if t.diff_labels[i].is_some() {
                *d = Some(Rect {
                    x: x(i as u32),
                    y,
                    width: pw,
                    height: ph,
                });
            }
        }
        colour_bar = Some(Rect {
            x: bar_x,
            y,
            width: BAR_WIDTH,
            height: bar_h,
        });
        y += ph.max(bar_h) + line(LABEL_SIZE);
    }
    if !t.notes.is_empty() {
        y += 8 + t.notes.len() as u32 * line(NOTE_SIZE);
    }
    Ok(Layout {
        width: content_w + 2 * MARGIN,
        height: y + MARGIN,
        panels,
        diffs,
        colour_bar,
    })
}

/// Draws the strip as 8-bit RGB: text through plotters, images pixel by pixel.
fn draw(
    layout: &Layout,
    t: &Texts,
    images: &[Image],
    diffs: &[Option<Vec<f64>>],
    scale: Option<f64>,
    fig: &Figure,
) -> Result<Vec<u8>> {
    let (w, h) = (layout.width, layout.height);
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let err = |e: DrawingAreaErrorKind<_>| Error::Other(format!("cannot draw the strip: {e}"));
        let centred = Pos::new(HPos::Center, VPos::Top);
        if let Some(title) = &t.title {
            let font = ("sans-serif", TITLE_SIZE)
                .into_font()
                .color(&BLACK)
                .pos(centred);
            root.draw(&Text::new(
                title.clone(),
                ((w / 2) as i32, MARGIN as i32),
                font,
            ))
            .map_err(err)?;
        }
        let label_font = ("sans-serif", LABEL_SIZE)
            .into_font()
            .color(&BLACK)
            .pos(centred);
        let under = |r: &Rect, height: u32| ((r.x + r.width / 2) as i32, (r.y + height + 4) as i32);
        for (r, label) in layout.panels.iter().zip(&t.labels) {
            root.draw(&Text::new(
                label.clone(),
                under(r, r.height),
                label_font.clone(),
            ))
            .map_err(err)?;
        }
        for (r, label) in layout.diffs.iter().zip(&t.diff_labels) {
            if let (Some(r), Some(label)) = (r, label) {
                root.draw(&Text::new(
                    label.clone(),
                    under(r, r.height),
                    label_font.clone(),
                ))
                .map_err(err)?;
            }
        }
        if let (Some(bar), Some(ticks), Some(s)) = (&layout.colour_bar, &t.ticks, scale) {
            let font = ("sans-serif", TICK_SIZE)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Center));
            for (v, text) in ticks {
                let y = bar_y(bar, *v / s);
                let x0 = (bar.x + bar.width) as i32;
                root.draw(&PathElement::new(
                    vec![(x0, y), (x0 + TICK_LENGTH as i32, y)],
                    BLACK,
                ))
                .map_err(err)?;
                let at = (x0 + TICK_LENGTH as i32 + 3, y);
                root.draw(&Text::new(text.clone(), at, font.clone()))
                    .map_err(err)?;
            }
        }
        let note_font = ("sans-serif", NOTE_SIZE)
            .into_font()
            .color(&RGBColor(60, 60, 60));
        let lines = t.notes.len() as u32;
        for (i, note) in t.notes.iter().enumerate() {
            let y = h - MARGIN - (lines - i as u32) * line(NOTE_SIZE);
            root.draw(&Text::new(
                note.clone(),
                (MARGIN as i32, y as i32),
                note_font.clone(),
            ))
            .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    let mut put = |x: u32, y: u32, c: [u8; 3]| {
        let i = (y as usize * w as usize + x as usize) * 3;
        buf[i..i + 3].copy_from_slice(&c);
    };
    let z = fig.zoom;
    let iw = images[0].width as usize;
    for (r, img) in layout.panels.iter().zip(images) {
        for (py, px) in (0..r.height).flat_map(|y| (0..r.width).map(move |x| (y, x))) {
            let p = img.pixels[(py / z) as usize * iw + (px / z) as usize];
            put(r.x + px, r.y + py, p.map(|v| tone_map(v, fig.exposure)));
        }
    }
    if let Some(s) = scale {
        for (r, d) in layout.diffs.iter().zip(diffs) {
            if let (Some(r), Some(d)) = (r, d) {
                for (py, px) in (0..r.height).flat_map(|y| (0..r.width).map(move |x| (y, x))) {
                    let v = d[(py / z) as usize * iw + (px / z) as usize];
                    put(r.x + px, r.y + py, diverging(v / s));
                }
            }
        }
    }
    if let Some(bar) = &layout.colour_bar {
        for y in 0..bar.height {
            let t = 1.0 - 2.0 * (y as f64 + 0.5) / bar.height as f64;
            for x in 0..bar.width {
                put(bar.x + x, bar.y + y, diverging(t));
            }
        }
    }
    Ok(buf)
}

/// The row of the colour bar at `t` in [−1, 1] (+1 at the top).
fn bar_y(bar: &Rect, t: f64) -> i32 {
    let f = (1.0 - t) / 2.0;
    (bar.y as f64 + f * (bar.height - 1) as f64).round() as i32
}

impl ErrorTable {
    /// The table as markdown: a sentence naming the reference, then one row per panel
    /// with RMSE and relMSE per region.
    pub fn markdown(&self) -> String {
        let esc = |s: &str| s.replace('|', "\\|");
        let spp = self
            .reference_spp
            .map(|n| format!(" ({n} spp)"))
            .unwrap_or_default();
        let over: Vec<String> = self
            .regions
            .iter()
            .map(|(name, n)| format!("{name} ({n} px)"))
            .collect();
        let mut s = format!(
            "Errors against {}{spp} over {}; relMSE is mean (x − r)² / (r² + 0.01) over pixels and channels.\n\n",
            self.reference.display(),
            over.join(", ")
        );
        s += "| panel | spp | seconds |";
        let mut rule = String::from("|---|--:|--:|");
        for (name, _) in &self.regions {
            s += &format!(" {} RMSE | {} relMSE |", esc(name), esc(name));
            rule += "--:|--:|";
        }
        s += "\n";
        s += &rule;
        s += "\n";
        for row in &self.rows {
            s += &format!(
                "| {} | {} | {} |",
                esc(&row.label),
                row.spp.map_or("–".into(), |n| n.to_string()),
                row.seconds.map_or("–".into(), |t| format!("{t:.2}")),
            );
            for e in &row.errors {
                s += &format!(" {:.3e} | {:.3e} |", e.rmse, e.relmse);
            }
            s += "\n";
        }
        s
    }

    /// The table as CSV, one line per panel and region, numbers in full precision:
    /// `panel,file,spp,seconds,region,pixels,rmse,relmse`.
    pub fn csv(&self) -> String {
        let mut s = String::from(CSV_HEADER);
        s.push('\n');
        for row in &self.rows {
            for ((name, n), e) in self.regions.iter().zip(&row.errors) {
                s += &format!(
                    "{},{},{},{},{},{n},{},{}\n",
                    csv_field(&row.label),
                    csv_field(&row.file.display().to_string()),
                    row.spp.map(|n| n.to_string()).unwrap_or_default(),
                    row.seconds.map(|t| t.to_string()).unwrap_or_default(),
                    csv_field(name),
                    e.rmse,
                    e.relmse
                );
            }
        }
        s
    }
}

/// The CSV's header line.
pub const CSV_HEADER: &str = "panel,file,spp,seconds,region,pixels,rmse,relmse";

/// A CSV field, quoted when it holds a comma, a quote or a line break (RFC 4180).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panels_split_at_the_last_equals_sign() {
        let p = Panel::parse("σ=0.5, 16 spp=out/a.exr").unwrap();
        assert_eq!(p.label, "σ=0.5, 16 spp");
        assert_eq!(p.file, PathBuf::from("out/a.exr"));
        for (bad, fragment) in [
            ("a.exr", "LABEL=FILE.exr"),
            ("=a.exr", "a label"),
            ("A=a.png", "ending in .exr"),
        ] {
            let e = Panel::parse(bad).unwrap_err().to_string();
            assert!(e.contains(fragment), "{bad}: {e}");
        }
    }

    #[test]
    fn diverging_map_and_scale() {
        assert_eq!(diverging(0.0), [255, 255, 255]);
        assert_eq!(diverging(1.0), RED);
        assert_eq!(diverging(-3.0), BLUE);
        assert_eq!(diverging(f64::NAN), [0, 0, 0]);
        let half = diverging(0.5);
        assert!(half[0] > half[2] && half[2] < 255);
        // 1 % of outliers do not set the scale.
        let mut d: Vec<f64> = (0..1000).map(|i| (i % 10) as f64 * 0.01).collect();
        d[0] = 100.0;
        assert!((robust_scale(&[d]) - 0.09).abs() < 1e-12);
        assert_eq!(robust_scale(&[vec![0.0; 4]]), 1.0);
        assert_eq!(luminance([0.0, 1.0, 0.0]), 0.7152);
        assert!((luminance([1.0; 3]) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn values_keep_three_significant_digits() {
        assert_eq!(format_value(0.0), "0");
        assert_eq!(format_value(0.012345), "0.0123");
        assert_eq!(format_value(-2.5), "−2.5");
        assert_eq!(format_value(150.0), "150");
        assert_eq!(format_value(1.5e-5), "1.50e-5");
    }
}
