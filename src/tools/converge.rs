//! Convergence measurements (`stokes converge`): which methods to compare, progressive
//! renders of one sample per pixel per pass with the error against a reference recorded
//! at log-spaced checkpoints, log–log slope fits and the CSV.
//!
//! **Methods** are [`Resolved`] methods, named as [`crate::method`] names them
//! (`hwss-independent-fluo-aware-packet-drop`); a name given on the command line may
//! list the values in any order and leave axes out (`mono-packet`, `hwss-constant-max`):
//! those take the method flags' values, whose defaults are [`Method::default`]'s with the
//! scene's default tracking.
//!
//! **Errors.** At a checkpoint, with `x` the image and `r` the reference over the pixels
//! `P` of a region and the three channels: `rmse = √(mean (x − r)²)` and
//! `relmse = mean (x − r)² / (r² + 0.01)`. When the reference is spectral (rendered with
//! `--spectral-bins`), every method renders the same bins and the same two measures are
//! also taken over the pixels and the bins, in spectral radiance (`spectral_rmse`,
//! `spectral_relmse`); the charts and the summary stay in RGB.
//!
//! **CSV** (`convergence.csv`): one row per checkpoint and region, with the columns
//! [`CSV_HEADER`]; region `image` is the whole image.
//!
//! **Charts** ([`converge_chart`]): relMSE against seconds, with the summary's target
//! (a dotted line) and the first method to reach it (a star), and RMSE against spp; the
//! colour is the spectral method, the dash the tracking, the marker (time chart) the
//! rays; methods that differ only in their rays are one line against spp (they trace the
//! same samples). Names keep the axes that vary; the subtitle states the others.
//!
//! **Other renderers** (`--compare FILE.csv`, repeatable): a CSV in this format — the
//! columns `method`, `spp`, `seconds`, `region`, `rmse`, `relmse` found by their header
//! names, any others ignored and possibly empty — adds a black or grey line per distinct
//! `method` to both charts and a row marked external to the summary, over the region the
//! charts use (the file must have rows of it). A missing file or column, or a value that
//! is not a number, is a one-line error naming the file and the line.
//!
//! **Redrawing** (`--redraw DIR`): the charts and the summary again from
//! `DIR/convergence.csv`, without rendering ([`converge_chart::redraw`]).

use super::converge_chart::{self, Curve};
use super::merge::{plane_names, Part};
use crate::error::Error;
use crate::header::next_free_sample;
use crate::integrator::render::{render_pass, Film, RenderOptions};
use crate::medium::tracking::Tracking;
use crate::method::{Axis, Dispersion, Method, Rays, Resolved, Shifting, Spectral, Wavelengths};
use crate::output::{check_outputs, read_exr, variance_path, write_atomically, Plane};
use crate::scene::Scene;
use crate::spectral_exr::Bins;
use crate::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The long help of `stokes converge`: method names, the default list and the outputs.
pub const HELP: &str = "\
Methods: a method is one value on each of six axes, joined by `-` in this order:
  spectral     hwss | mono
  wavelengths  uniform | visible
  shifting     independent | constant
  tracking     classic | max | fluo-aware
  rays         packet | packet8 | lockstep | single
  dispersion   split | drop
for example hwss-visible-independent-fluo-aware-packet-drop (the name the outputs use).
In --methods a name may list the values in any order and leave axes out: those take the
method flags' values (--spectral, --wavelengths, --shifting, --tracking, --rays,
--dispersion), whose defaults are hwss, visible, independent, the scene's default
tracking, packet, split. Example:
  --methods hwss-packet,mono-packet,hwss-constant-max

Without --methods: every combination the scene makes meaningful. Spectral, wavelengths
and rays (single and packet) always vary; shifting only where something fluoresces, tracking only where there are
media, dispersion only where a dielectric is dispersive; mono takes one shifting and one
dispersion value (they act on the secondary wavelengths). A method flag given on the
command line fixes its axis (--spectral mono: only mono methods).

Each method renders passes of 1 spp on samples after the reference's, until --budget
seconds of rendering (or --spp). At spp 1, 2, 4, 8, ... and at the final spp it records
the seconds of rendering so far (error computation not counted) and the error against
the reference over the image and over each [[region]] of the scene:
  rmse   = sqrt(mean over pixels and channels of (x - r)^2)
  relmse = mean over pixels and channels of (x - r)^2 / (r^2 + 0.01)
A spectral reference (rendered with --spectral-bins) makes every method render its bins
too, and the same two are measured over pixels and bins in spectral radiance.

Outputs in --out DIR:
  convergence.csv   method,spectral,wavelengths,shifting,tracking,rays,dispersion,pass,spp,seconds,
                    region,rmse,relmse,spectral_rmse,spectral_relmse (one row per
                    checkpoint and region; region `image` is the whole image; the
                    spectral columns are empty against an RGB reference)
  error-vs-time.svg/.png: log-log relMSE against seconds over the first region (else
                    the image), one line per method, a dashed line of slope -1, the
                    target relMSE of the summary dotted and a star where the fastest
                    method reaches it
  error-vs-spp.svg/.png: log-log RMSE against spp, one line per group of methods that
                    differ only in rays (they trace the same samples), slope -1/2
                    In both: colour = spectral method (every axis but tracking and
                    rays), dash = tracking, marker = rays (time chart); names keep only
                    the axes that vary, the subtitle gives the values all share.
and on stdout a table: per method, the fitted log-log slope of RMSE against spp (over
checkpoints with spp >= 4; -0.5 for an unbiased method), the final errors and the
seconds to reach the worst final relMSE of the methods that converge (slope <= -0.4;
of all if none does), and the fastest to it.

Another renderer (--compare FILE.csv, repeatable): a CSV in the convergence.csv format;
the columns method, spp, seconds, region, rmse, relmse are found by their header names
(others are ignored and may be empty). Each distinct method becomes a black or grey
line on both charts and a summary row marked external; only its rows of the region the
charts use count (the file must have some). Example:
  stokes converge SCENE --reference REF.exr --compare mitsuba.csv --out DIR

Redrawing (--redraw DIR): no rendering; the charts are drawn again from
DIR/convergence.csv into DIR (or --out) and the summary printed, with --compare lines:
  stokes converge --redraw docs/results/cornell-box --compare mitsuba.csv --out /tmp/c";

/// The files `stokes converge` writes into its `--out` directory.
pub const FILES: [&str; 5] = [
    "convergence.csv",
    "error-vs-time.svg",
    "error-vs-time.png",
    "error-vs-spp.svg",
    "error-vs-spp.png",
];

/// The columns of `convergence.csv`.
pub const CSV_HEADER: &str =
    "method,spectral,wavelengths,shifting,tracking,rays,dispersion,pass,spp,seconds,region,rmse,relmse,spectral_rmse,spectral_relmse";

/// `base` rendering `method`.
pub fn options_for(method: &Resolved, base: &RenderOptions) -> RenderOptions {
    RenderOptions {
        method: method.with_tracking(Some(method.tracking)),
        ..base.clone()
    }
}

/// The values each axis takes in a comparison.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MethodSpace {
    /// Spectral sampling.
    pub spectral: Vec<Spectral>,
    /// The hero wavelength's pdf.
    pub wavelengths: Vec<Wavelengths>,
    /// Shifting (HWSS only: mono takes the first).
    pub shifting: Vec<Shifting>,
    /// Tracking.
    pub tracking: Vec<Tracking>,
    /// Rays.
    pub rays: Vec<Rays>,
    /// Dispersion (HWSS only: mono takes the first).
    pub dispersion: Vec<Dispersion>,
}

impl MethodSpace {
    /// The axes the scene makes meaningful: spectral sampling and rays always; shifting
    /// where something fluoresces; tracking where there are media; dispersion where a
    /// dielectric is dispersive. Fixed axes hold `defaults`' value.
    pub fn for_scene(scene: &Scene, defaults: &Resolved) -> MethodSpace {
        let fluorescent = scene.has_fluorescence() || scene.has_fluorescent_media();
        MethodSpace {
            spectral: vec![Spectral::Hwss, Spectral::Mono],
            wavelengths: Wavelengths::VALUES.to_vec(),
            shifting: if fluorescent {
                vec![Shifting::Independent, Shifting::Constant]
            } else {
                vec![defaults.shifting]
            },
            tracking: if scene.has_media() {
                vec![Tracking::Classic, Tracking::Max, Tracking::FluoAware]
            } else {
                vec![defaults.tracking]
            },
            rays: vec![Rays::Single, Rays::Packet],
            dispersion: if scene.has_dispersion() {
                vec![Dispersion::Drop, Dispersion::Split]
            } else {
                vec![defaults.dispersion]
            },
        }
    }

    /// Keeps only `value`'s value on its axis: the axis a method flag fixed.
    pub fn fix(&mut self, axis: &str, value: &Resolved) {
        match axis {
            "spectral" => self.spectral = vec![value.spectral],
            "wavelengths" => self.wavelengths = vec![value.wavelengths],
            "shifting" => self.shifting = vec![value.shifting],
            "tracking" => self.tracking = vec![value.tracking],
            "rays" => self.rays = vec![value.rays],
            "dispersion" => self.dispersion = vec![value.dispersion],
            _ => unreachable!("not an axis: {axis}"),
        }
    }

    /// Every combination, spectral outermost and rays innermost. Shifting and dispersion
    /// act on the secondary wavelengths, which mono does not have: mono takes only the
    /// first value of each.
    pub fn methods(&self) -> Vec<Resolved> {
        let mut out = Vec::new();
        for &spectral in &self.spectral {
            let mono = spectral == Spectral::Mono;
            let shifting = if mono {
                &self.shifting[..self.shifting.len().min(1)]
            } else {
                &self.shifting[..]
            };
            let dispersion = if mono {
                &self.dispersion[..self.dispersion.len().min(1)]
            } else {
                &self.dispersion[..]
            };
            for &wavelengths in &self.wavelengths {
                for &shifting in shifting {
                    for &tracking in &self.tracking {
                        for &dispersion in dispersion {
                            for &rays in &self.rays {
                                out.push(Method {
                                    spectral,
                                    wavelengths,
                                    shifting,
                                    tracking,
                                    rays,
                                    dispersion,
                                });
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

/// Names for legends and the summary: the values of the axes on which `methods` differ
/// (the full name where they all agree); [`converge_chart::common_values`] states the
/// others once.
pub fn short_names(methods: &[Resolved]) -> Vec<String> {
    let varies = converge_chart::varying_axes(methods);
    methods
        .iter()
        .map(|m| {
            let parts = m.parts();
            let kept: Vec<&str> = (0..parts.len())
                .filter(|&k| varies[k])
                .map(|k| parts[k])
                .collect();
            if kept.is_empty() {
                parts.join("-")
            } else {
                kept.join("-")
            }
        })
        .collect()
}

/// The error of an image against the reference over some pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    /// Root mean square error over pixels and channels.
    pub rmse: f64,
    /// Mean of (x − r)² / (r² + 0.01) over pixels and channels.
    pub relmse: f64,
    /// The same two over pixels and wavelength bins, if the reference is spectral.
    pub spectral: Option<(f64, f64)>,
}

/// The errors of `image` against `reference` over the pixels `pixels` (indices into
/// both) and the three channels. An empty set gives NaN.
pub fn errors(image: &[[f32; 3]], reference: &[[f32; 3]], pixels: &[usize]) -> Errors {
    let (rmse, relmse) = squared_errors(
        pixels
            .iter()
            .flat_map(|&i| (0..3).map(move |c| (image[i][c], reference[i][c]))),
    );
    Errors {
        rmse,
        relmse,
        spectral: None,
    }
}

/// The RMSE and relMSE of the bins `image` against the reference's `reference` over
/// `pixels` (planes in the same order).
pub fn spectral_errors(image: &[Plane], reference: &[Plane], pixels: &[usize]) -> (f64, f64) {
    squared_errors(
        image
            .iter()
            .zip(reference)
            .flat_map(|(x, r)| pixels.iter().map(move |&i| (x.data[i], r.data[i]))),
    )
}

/// √(mean (x − r)²) and mean (x − r)² / (r² + 0.01) over `(x, r)` pairs.
fn squared_errors(pairs: impl Iterator<Item = (f32, f32)>) -> (f64, f64) {
    let (mut se, mut rel, mut n) = (0.0f64, 0.0f64, 0usize);
    for (x, r) in pairs {
        let (x, r) = (x as f64, r as f64);
        let d = x - r;
        se += d * d;
        rel += d * d / (r * r + 0.01);
        n += 1;
    }
    ((se / n as f64).sqrt(), rel / n as f64)
}

/// The bins of a spectral reference's channels: every one must be an emissive channel
/// of ours, evenly spaced; `None` for an RGB reference, an error for channels the runs
/// could not reproduce.
pub fn reference_bins(reference: &Part) -> Result<Option<Bins>> {
    if reference.planes.is_empty() {
        return Ok(None);
    }
    let names: Vec<&str> = plane_names(&reference.planes);
    Bins::from_channel_names(&names).map(Some).ok_or_else(|| {
        Error::about_option(
            "--reference",
            &reference.path,
            format!(
                "has channels {} … {} beside R, G, B that are not the evenly spaced S0 bins stokes writes: give an RGB reference or one rendered with --spectral-bins",
                names[0],
                names[names.len() - 1]
            ),
        )
    })
}

/// A region of the image to measure: `image` (every pixel) or a scene's `[[region]]`.
#[derive(Debug, Clone)]
pub struct MeasuredRegion {
    /// Its name in the CSV.
    pub name: String,
    /// Row-major pixel indices.
    pub pixels: Vec<usize>,
}

/// `image` and then the scene's regions, at the resolution of `opts`.
pub fn measured_regions(scene: &Scene, width: u32, height: u32) -> Vec<MeasuredRegion> {
    let mut out = vec![MeasuredRegion {
        name: "image".into(),
        pixels: (0..width as usize * height as usize).collect(),
    }];
    out.extend(scene.regions.iter().map(|r| MeasuredRegion {
        name: r.name.clone(),
        pixels: r.pixels(width, height),
    }));
    out
}

/// Whether the error is recorded after `spp` samples: at 1, 2, 4, 8, … (the final spp
/// is recorded too, whatever it is).
pub fn is_checkpoint(spp: u32) -> bool {
    spp.is_power_of_two()
}

/// The state of a progressive render at a checkpoint.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    /// Passes rendered.
    pub pass: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Seconds spent in passes so far (error computation excluded).
    pub seconds: f64,
    /// The errors, one per measured region, in order.
    pub errors: Vec<Errors>,
}

/// How long one method renders.
#[derive(Debug, Clone, Copy)]
pub struct Budget {
    /// Seconds of rendering: a pass starts only if, at the mean pass time so far, it
    /// ends within them (the first pass always runs).
    pub seconds: f64,
    /// At most this many samples per pixel.
    pub max_spp: Option<u32>,
    /// The first sample index drawn (samples are `[first_sample, first_sample + spp)`).
    pub first_sample: u32,
}

/// One method's run: its checkpoints and the samples that came out NaN or infinite.
#[derive(Debug, Clone)]
pub struct Run {
    /// The method.
    pub method: Resolved,
    /// Checkpoints in order; the last is the final state.
    pub checkpoints: Vec<Checkpoint>,
    /// Non-finite samples dropped.
    pub nonfinite: u64,
}

/// Renders `method` progressively, one sample per pixel per pass, on `pool`, recording
/// the errors against `reference` at every checkpoint. `base` gives the size, seed,
/// depth and threads; the scene's camera must have its resolution.
pub fn run_method(
    scene: &Scene,
    base: &RenderOptions,
    method: &Resolved,
    reference: &Part,
    regions: &[MeasuredRegion],
    budget: &Budget,
    pool: &rayon::ThreadPool,
) -> Result<Run> {
    let mut opts = options_for(method, base);
    opts.bins = reference_bins(reference)?;
    opts.validate()?;
    let (width, height) = (scene.camera.width, scene.camera.height);
    if reference.pixels.len() as u64 != scene.camera.pixel_count() {
        return Err(Error::Other(format!(
            "the reference has {} pixels but the render {width}x{height} has {}",
            reference.pixels.len(),
            scene.camera.pixel_count()
        )));
    }
    if !(budget.seconds.is_finite() && budget.seconds > 0.0) {
        return Err(Error::Other(format!(
            "expected a positive time budget, found {}",
            budget.seconds
        )));
    }
    let max_spp = crate::integrator::render::sample_count(budget.first_sample, budget.max_spp)?;
    let mut film = Film::try_with_bins(width, height, opts.bins)?;
    let mut seconds = 0.0f64;
    let mut pass = 0u32;
    let mut nonfinite = 0u64;
    let mut checkpoints: Vec<Checkpoint> = Vec::new();
    let measure = |film: &Film, pass: u32, seconds: f64| {
        let image = film.mean();
        let bins = film.spectral_mean();
        let error = |r: &MeasuredRegion| Errors {
            spectral: (!bins.is_empty())
                .then(|| spectral_errors(&bins, &reference.planes, &r.pixels)),
            ..errors(&image, &reference.pixels, &r.pixels)
        };
        Checkpoint {
            pass,
            spp: film.spp,
            seconds,
            errors: regions.iter().map(error).collect(),
        }
    };
    while film.spp < max_spp && (pass == 0 || seconds + seconds / pass as f64 <= budget.seconds) {
        let first = budget.first_sample + film.spp;
        let start = Instant::now();
        let stats = pool.install(|| render_pass(scene, &opts, &mut film, first, 1, &|| {}));
        seconds += start.elapsed().as_secs_f64();
        pass += 1;
        nonfinite += stats.nonfinite;
        if is_checkpoint(film.spp) {
            checkpoints.push(measure(&film, pass, seconds));
        }
    }
    if checkpoints.last().map(|c| c.spp) != Some(film.spp) {
        checkpoints.push(measure(&film, pass, seconds));
    }
    Ok(Run {
        method: *method,
        checkpoints,
        nonfinite,
    })
}

/// A comparison: methods against a reference, each within a budget, with the CSV and
/// charts going into `out_dir`.
pub struct Job<'a> {
    /// The scene, at the reference's resolution.
    pub scene: &'a Scene,
    /// Seed, depth and threads (the method is each of `methods` in turn).
    pub base: &'a RenderOptions,
    /// The methods, in the order of the outputs.
    pub methods: Vec<Resolved>,
    /// The reference (checked with [`check_reference`]).
    pub reference: &'a Part,
    /// How long each method renders.
    pub budget: Budget,
    /// Where [`FILES`] go.
    pub out_dir: PathBuf,
}

/// What a comparison found.
pub struct Report {
    /// One run per method.
    pub runs: Vec<Run>,
    /// The regions measured (`image` first).
    pub regions: Vec<MeasuredRegion>,
    /// The index of the region the charts and the summary use.
    pub region: usize,
    /// The summary as `stokes converge` prints it: the reference, its own noise, the
    /// table.
    pub summary: String,
}

impl Job<'_> {
    /// The line announcing the comparison.
    pub fn describe(&self) -> String {
        let c = &self.scene.camera;
        format!(
            "{}: {}x{}, {} methods, {} s each{}, samples from {} on (after the reference's {} spp)",
            self.scene.name(),
            c.width,
            c.height,
            self.methods.len(),
            self.budget.seconds,
            self.budget
                .max_spp
                .map(|n| format!(" (at most {n} spp)"))
                .unwrap_or_default(),
            self.budget.first_sample,
            self.reference.spp()
        )
    }

    /// Checks that the outputs can be written and creates `out_dir`, so that nothing is
    /// rendered for results that could not be kept.
    pub fn prepare(&self) -> Result<()> {
        let dir = &self.out_dir;
        let files: Vec<PathBuf> = FILES.iter().map(|f| dir.join(f)).collect();
        let outputs: Vec<(&str, &Path)> = files.iter().map(|f| ("--out", f.as_path())).collect();
        check_outputs(&outputs)?;
        std::fs::create_dir_all(dir).map_err(|e| {
            Error::option(
                &format!("--out {}", dir.display()),
                format!("cannot create directory: {e}"),
            )
        })
    }

    /// Renders every method ([`compare`]) and writes the CSV and the charts (after
    /// [`Job::prepare`]).
    pub fn run(&self, on_run: &mut dyn FnMut(usize, &Run)) -> Result<Report> {
        self.run_with(&[], on_run)
    }

    /// [`Job::run`], with other renderers' `curves` (`--compare`, checked with
    /// [`converge_chart::check_compare`]) on the charts and in the summary.
    pub fn run_with(
        &self,
        curves: &[Curve],
        on_run: &mut dyn FnMut(usize, &Run),
    ) -> Result<Report> {
        self.prepare()?;
        let dir = &self.out_dir;
        let (scene, c) = (self.scene, &self.scene.camera);
        let regions = measured_regions(scene, c.width, c.height);
        let region = chart_region(&regions);
        let runs = compare(
            scene,
            self.base,
            &self.methods,
            self.reference,
            &regions,
            &self.budget,
            on_run,
        )?;
        let text = csv(&runs, &regions);
        write_atomically(&dir.join(FILES[0]), |tmp| {
            std::fs::write(tmp, text.as_bytes()).map_err(|e| format!("cannot write: {e}").into())
        })?;
        let title = format!("{} {}x{}", scene.name(), c.width, c.height);
        converge_chart::check_compare(curves, &regions[region].name)?;
        converge_chart::write_charts(&runs, curves, &regions, region, &title, dir)?;
        let summary = self.summary(&runs, curves, &regions, region);
        Ok(Report {
            runs,
            regions,
            region,
            summary,
        })
    }

    /// [`Report::summary`].
    fn summary(
        &self,
        runs: &[Run],
        curves: &[Curve],
        regions: &[MeasuredRegion],
        region: usize,
    ) -> String {
        let (c, r) = (&self.scene.camera, &self.reference);
        let mut out = format!(
            "{} {}x{} against {} ({} spp)\n",
            self.scene.name(),
            c.width,
            c.height,
            r.path.display(),
            r.spp()
        );
        let name = &regions[region].name;
        let var_path = variance_path(&r.path);
        if let Ok((w, h, var, _)) = read_exr(&var_path) {
            if (w, h) == (c.width, c.height) {
                let over = if region == 0 {
                    "the whole image".to_string()
                } else {
                    format!("region `{name}`")
                };
                let _ = writeln!(
                    out,
                    "the reference's own noise over {over}: RMSE ≈ {:.3e} (from {}); errors near it are the reference's",
                    reference_noise(&var, &regions[region].pixels),
                    var_path.display()
                );
            }
        }
        if let Some(bins) = r
            .planes
            .first()
            .and_then(|_| reference_bins(r).ok().flatten())
        {
            let _ = writeln!(
                out,
                "the reference is spectral ({bins}): errors in spectral radiance are in {} (spectral_rmse, spectral_relmse)",
                FILES[0]
            );
        }
        out.push('\n');
        out.push_str(&converge_chart::summary(runs, curves, regions, region));
        out
    }
}

/// Renders every method in turn on a pool of `base.threads` threads (after one untimed
/// pass of the first, so that it does not pay for cold caches and sleeping threads);
/// `on_run` hears of each finished run with its index.
pub fn compare(
    scene: &Scene,
    base: &RenderOptions,
    methods: &[Resolved],
    reference: &Part,
    regions: &[MeasuredRegion],
    budget: &Budget,
    on_run: &mut dyn FnMut(usize, &Run),
) -> Result<Vec<Run>> {
    let pool = crate::accel::thread_pool(base.threads)
        .map_err(|e| Error::Other(format!("cannot start threads: {e}")))?;
    if let Some(m) = methods.first() {
        let warm = Budget {
            max_spp: Some(1),
            ..*budget
        };
        run_method(scene, base, m, reference, regions, &warm, &pool)?;
    }
    let mut runs = Vec::with_capacity(methods.len());
    for (i, m) in methods.iter().enumerate() {
        let run = run_method(scene, base, m, reference, regions, budget, &pool)?;
        on_run(i, &run);
        runs.push(run);
    }
    Ok(runs)
}

/// The region the charts and the summary use: the scene's first `[[region]]`, else the
/// whole image.
pub fn chart_region(regions: &[MeasuredRegion]) -> usize {
    if regions.len() > 1 {
        1
    } else {
        0
    }
}

/// Checks that `reference` (the file `--reference`) is a reference of `scene` at its
/// resolution and `opts`' depth; returns a warning if its tracking is biased in the scene.
/// Errors are [`Error::About`] the reference file, after the option `--reference`.
pub fn check_reference(
    reference: &Part,
    scene: &Scene,
    opts: &RenderOptions,
) -> Result<Option<String>> {
    let r = reference.path.display();
    let (width, height) = (scene.camera.width, scene.camera.height);
    let h = &reference.header;
    let unlike = |rest: String| Err(Error::about_option("--reference", &reference.path, rest));
    if (reference.width, reference.height) != (width, height) {
        return unlike(format!(
            "is {}x{} but this run renders {width}x{height} (--res or the scene's camera.resolution): give a reference of the same size",
            reference.width, reference.height
        ));
    }
    if h.scene_hash != scene.hash {
        return unlike(format!(
            "is a reference of {}, not of {} ({})",
            h.scene_label(),
            scene.path.display(),
            scene.hash
        ));
    }
    if h.max_depth != opts.max_depth {
        return unlike(format!(
            "was rendered with max_depth = {} but this run uses {}: the images converge to different values (give --max-depth {})",
            h.max_depth, opts.max_depth, h.max_depth
        ));
    }
    Ok((h.method.tracking == Tracking::Classic && scene.has_fluorescent_media()).then(|| {
        format!("{r} was rendered with classic tracking, which is biased in fluorescent media: errors are measured against a biased reference")
    }))
}

/// The first sample index after the reference's samples of `seed`, so that no method
/// reuses them; an error if too few indices are left.
pub fn first_sample_after(reference: &Part, seed: u64) -> Result<u32> {
    let first = next_free_sample(&reference.header.ranges, seed);
    u32::try_from(first)
        .ok()
        .filter(|&s| s < u32::MAX / 2)
        .ok_or_else(|| {
            Error::about_option(
                "--reference",
                &reference.path,
                format!("holds samples up to {first} of seed {seed}: too many to draw new ones after them (give another --seed)"),
            )
        })
}

/// The RMSE a reference's own noise accounts for over `pixels`: the square root of the
/// mean variance of its pixel means (`variance`, its variance image).
pub fn reference_noise(variance: &[[f32; 3]], pixels: &[usize]) -> f64 {
    let sum: f64 = pixels
        .iter()
        .map(|&i| variance[i].iter().map(|&v| v as f64).sum::<f64>())
        .sum();
    (sum / (3 * pixels.len()) as f64).sqrt()
}

/// The CSV text of some runs (header included): one row per checkpoint and region.
pub fn csv(runs: &[Run], regions: &[MeasuredRegion]) -> String {
    let mut out = String::new();
    out.push_str(CSV_HEADER);
    out.push('\n');
    for run in runs {
        let m = &run.method;
        let [spectral, wavelengths, shifting, tracking, rays, dispersion] = m.parts();
        for c in &run.checkpoints {
            for (r, e) in regions.iter().zip(&c.errors) {
                let (s_rmse, s_relmse) = e
                    .spectral
                    .map(|(a, b)| (format!("{a:.6e}"), format!("{b:.6e}")))
                    .unwrap_or_default();
                let _ = writeln!(
                    out,
                    "{m},{spectral},{wavelengths},{shifting},{tracking},{rays},{dispersion},{},{},{:.6},{},{:.6e},{:.6e},{s_rmse},{s_relmse}",
                    c.pass,
                    c.spp,
                    c.seconds,
                    r.name,
                    e.rmse,
                    e.relmse
                );
            }
        }
    }
    out
}

/// The least-squares slope of `ln y` against `ln x` over the points with positive,
/// finite coordinates; `None` with fewer than two distinct `x`.
pub fn loglog_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    if logs.len() < 2 {
        return None;
    }
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The smallest spp of the checkpoints a slope is fitted over: earlier ones are
/// dominated by start-up effects (a single sample per pixel, the first passes' timing).
pub const SLOPE_MIN_SPP: u32 = 4;

/// The log–log slope of a run's RMSE in region `region` against spp, over the
/// checkpoints with at least [`SLOPE_MIN_SPP`] samples.
pub fn rmse_slope(run: &Run, region: usize) -> Option<f64> {
    let pts: Vec<(f64, f64)> = run
        .checkpoints
        .iter()
        .filter(|c| c.spp >= SLOPE_MIN_SPP)
        .map(|c| (c.spp as f64, c.errors[region].rmse))
        .collect();
    loglog_slope(&pts)
}

/// The time at which the error first falls to `target`, interpolated log–log between
/// the checkpoints around the crossing, from `(seconds, error)` points in order;
/// `None` if it never does.
pub fn time_to_reach(points: &[(f64, f64)], target: f64) -> Option<f64> {
    let i = points.iter().position(|&(_, e)| e <= target)?;
    if i == 0 {
        return Some(points[0].0);
    }
    let (t0, e0) = points[i - 1];
    let (t1, e1) = points[i];
    if !(t0 > 0.0 && t1 > 0.0 && e0 > 0.0 && e1 > 0.0 && target > 0.0) || e0 == e1 {
        return Some(t1);
    }
    let f = (target.ln() - e0.ln()) / (e1.ln() - e0.ln());
    Some((t0.ln() + f * (t1.ln() - t0.ln())).exp())
}

/// One line of the summary table.
#[derive(Debug, Clone)]
pub struct SummaryRow {
    /// The method's name.
    pub method: String,
    /// Samples per pixel reached.
    pub spp: u32,
    /// Seconds of rendering.
    pub seconds: f64,
    /// Fitted slope of RMSE against spp (log–log).
    pub slope: Option<f64>,
    /// Final RMSE.
    pub rmse: f64,
    /// Final relative MSE.
    pub relmse: f64,
    /// Seconds to reach the target relative MSE.
    pub time_to_target: Option<f64>,
    /// For another renderer's curve (`--compare`), the file it came from.
    pub external: Option<String>,
}

/// A fitted slope of ln RMSE on ln spp at or below this counts as converging (−0.5 for an
/// unbiased method; a biased one flattens towards 0 once its bias dominates).
pub const CONVERGING_SLOPE: f64 = -0.4;

/// The summary over one region: per method (named by [`short_names`]), slope, final
/// errors and the time to reach the target relative MSE — the worst final relative MSE
/// of the methods that converge (slope ≤ [`CONVERGING_SLOPE`]; of all if none does),
/// named in the returned `(target, its method)`, which each of them reaches.
pub fn summarize(runs: &[Run], region: usize) -> (f64, String, Vec<SummaryRow>) {
    let methods: Vec<Resolved> = runs.iter().map(|r| r.method).collect();
    let names = short_names(&methods);
    let finals: Vec<Errors> = runs
        .iter()
        .map(|r| {
            r.checkpoints.last().map_or(
                Errors {
                    rmse: f64::NAN,
                    relmse: f64::NAN,
                    spectral: None,
                },
                |c| c.errors[region],
            )
        })
        .collect();
    // A biased method's error stops falling (its slope flattens): only the methods that
    // converge set the target, so that every one of them reaches it and the biased ones'
    // plateau does not make the comparison trivial. If none converges, all count.
    let converging: Vec<bool> = runs
        .iter()
        .map(|r| rmse_slope(r, region).is_some_and(|k| k <= CONVERGING_SLOPE))
        .collect();
    let any = converging.iter().any(|&c| c);
    let (mut target, mut worst) = (f64::NAN, String::new());
    for ((name, e), &ok) in names.iter().zip(&finals).zip(&converging) {
        if (ok || !any) && e.relmse.is_finite() && (target.is_nan() || e.relmse > target) {
            target = e.relmse;
            worst = name.clone();
        }
    }
    let rows = runs
        .iter()
        .zip(&finals)
        .zip(names)
        .map(|((run, e), name)| {
            let pts: Vec<(f64, f64)> = run
                .checkpoints
                .iter()
                .map(|c| (c.seconds, c.errors[region].relmse))
                .collect();
            let last = run.checkpoints.last();
            SummaryRow {
                method: name,
                spp: last.map_or(0, |c| c.spp),
                seconds: last.map_or(0.0, |c| c.seconds),
                slope: rmse_slope(run, region),
                rmse: e.rmse,
                relmse: e.relmse,
                time_to_target: time_to_reach(&pts, target),
                external: None,
            }
        })
        .collect();
    (target, worst, rows)
}

/// The summary as a Markdown table, with a line naming the region and the target, one
/// stating the values every method shares (`common`, if any) and one naming the fastest
/// to the target. Rows of other renderers are marked `(external: FILE)`.
pub fn format_summary(
    region: &str,
    target: f64,
    worst: &str,
    common: &str,
    rows: &[SummaryRow],
) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Errors over {}; slope: least squares of ln RMSE on ln spp over checkpoints with spp ≥ {SLOPE_MIN_SPP} (−0.5 for an unbiased estimator); target: relMSE {target:.3e}, the worst final relMSE of the converging methods (slope ≤ −0.4), of {worst}.",
        if region == "image" {
            "the whole image".to_string()
        } else {
            format!("region `{region}`")
        }
    );
    if !common.is_empty() {
        let _ = writeln!(
            out,
            "Every method of stokes here has {common}; the names below give the other axes."
        );
    }
    if let Some(r) = converge_chart::fastest(rows).map(|i| &rows[i]) {
        let _ = writeln!(
            out,
            "Fastest to the target: {}{} in {:.3} s.",
            r.method,
            if r.external.is_some() {
                " (external)"
            } else {
                ""
            },
            r.time_to_target.unwrap_or(f64::NAN)
        );
    }
    out.push('\n');
    out.push_str(
        "| method | spp | seconds | slope | final RMSE | final relMSE | seconds to target |\n",
    );
    out.push_str("| --- | --- | --- | --- | --- | --- | --- |\n");
    for r in rows {
        let _ = writeln!(
            out,
            "| {}{} | {} | {:.2} | {} | {:.4e} | {:.4e} | {} |",
            r.method,
            r.external
                .as_ref()
                .map(|f| format!(" (external: {f})"))
                .unwrap_or_default(),
            r.spp,
            r.seconds,
            r.slope.map_or("—".into(), |s| format!("{s:.3}")),
            r.rmse,
            r.relmse,
            r.time_to_target.map_or("—".into(), |t| format!("{t:.3}"))
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn method_space_skips_what_mono_lacks() {
        let space = MethodSpace {
            spectral: vec![Spectral::Hwss, Spectral::Mono],
            wavelengths: Wavelengths::VALUES.to_vec(),
            shifting: vec![Shifting::Independent, Shifting::Constant],
            tracking: vec![Tracking::Classic, Tracking::Max, Tracking::FluoAware],
            rays: vec![Rays::Single, Rays::Packet],
            dispersion: vec![Dispersion::Drop],
        };
        let ms = space.methods();
        assert_eq!(ms.len(), 2 * (2 + 1) * 3 * 2);
        let names: std::collections::BTreeSet<String> = ms.iter().map(|m| m.to_string()).collect();
        assert_eq!(names.len(), ms.len());
        assert!(ms
            .iter()
            .all(|m| m.spectral == Spectral::Hwss || m.shifting == Shifting::Independent));
    }

    #[test]
    fn errors_and_slopes() {
        let r = vec![[1.0f32, 0.0, 0.5]; 4];
        let x = vec![[1.1f32, 0.1, 0.5]; 4];
        let e = errors(&x, &r, &[0, 1, 2, 3]);
        assert!((e.rmse - (0.02f64 / 3.0).sqrt()).abs() < 1e-6, "{e:?}");
        let want = (0.01 / 1.01 + 0.01 / 0.01) / 3.0;
        assert!((e.relmse - want).abs() < 1e-6, "{e:?}");
        assert!(errors(&x, &r, &[]).rmse.is_nan());

        let pts: Vec<(f64, f64)> = (0..8)
            .map(|k| {
                let n = (1u32 << k) as f64;
                (n, 3.0 / n.sqrt())
            })
            .collect();
        assert!((loglog_slope(&pts).unwrap() + 0.5).abs() < 1e-12);
        assert!(loglog_slope(&pts[..1]).is_none());
        assert!(loglog_slope(&[(2.0, 1.0), (2.0, 3.0)]).is_none());
    }

    #[test]
    fn time_to_reach_interpolates_log_log() {
        let pts = [(1.0, 1.0), (4.0, 0.25), (16.0, 0.0625)];
        assert_eq!(time_to_reach(&pts, 2.0), Some(1.0));
        assert!((time_to_reach(&pts, 0.5).unwrap() - 2.0).abs() < 1e-12);
        assert!((time_to_reach(&pts, 0.0625).unwrap() - 16.0).abs() < 1e-9);
        assert_eq!(time_to_reach(&pts, 0.01), None);
    }

    #[test]
    fn checkpoints_are_powers_of_two() {
        let cps: Vec<u32> = (1..=40).filter(|&n| is_checkpoint(n)).collect();
        assert_eq!(cps, [1, 2, 4, 8, 16, 32]);
    }
}
