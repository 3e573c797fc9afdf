//! The command line's options: clap's derive structs and the parsers of their values.
//! What the options do is in the library; `main.rs` calls it.

use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use stokes::error::{Error, Key};
use stokes::integrator::render::RenderOptions;
use stokes::medium::tracking::Tracking;
use stokes::method::{Axis, Dispersion, Layout, Method, Rays, Shifting, Spectral, Wavelengths};
use stokes::scene::Scene;
use stokes::spectral_exr::{self, Bins};
use stokes::spectrum::{LAMBDA_MAX, LAMBDA_MIN};
use stokes::tools::{converge, figure};

#[derive(Parser)]
#[command(
    name = "stokes",
    version,
    about = "A spectral path tracer that renders fluorescence correctly and fast"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a scene to an OpenEXR image (linear sRGB).
    Render(RenderArgs),
    /// Print what a scene contains and which methods a render of it will use.
    Info {
        /// The scene file (TOML); without one, the material kinds a scene can use and the
        /// keys each needs.
        scene: Option<PathBuf>,
    },
    /// Merge renders of the same scene with disjoint sample ranges (e.g. the parts of a
    /// cluster job array): the spp-weighted mean.
    Merge(MergeArgs),
    /// Render a high-spp reference and its variance (<out>.variance.exr); --resume adds
    /// samples to an existing one.
    Reference(ReferenceArgs),
    /// Compare methods against a reference: error against time and spp at log-spaced
    /// checkpoints, as CSV, charts and a summary table.
    #[command(
        after_help = "Method names such as hwss-independent-fluo-aware-packet-drop, the default method list, the error measures and the outputs: see --help.",
        after_long_help = converge::HELP
    )]
    Converge(ConvergeArgs),
    /// Write a measured re-radiation matrix (a Labsphere BFC-450 file, a CSV matrix or a
    /// bispectral OpenEXR image) as the CSV a fluorescent_diffuse material's `matrix` key
    /// reads, with what the import changed (clipped range, entries set to 0) in its
    /// header, or (-o FILE.exr) as a one-pixel bispectral OpenEXR image in the spectral
    /// layout of Fichet et al. (T.<λ>nm diagonal, T.<λi>nm.<λo>nm re-radiation).
    ConvertBispectral {
        /// The measured matrix (.BFC, .csv or .exr).
        input: PathBuf,
        /// The file to write: .csv or .exr.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Lay renders (EXR) side by side as a labelled PNG strip, with their differences to
    /// a reference under them and a table of their errors (RMSE, relMSE) over the image
    /// and a scene's regions.
    #[command(after_long_help = figure::HELP)]
    Figure(FigureArgs),
    /// Submit a render split into parts to a batch scheduler (Slurm), with a merge job.
    Submit {
        #[command(subcommand)]
        what: SubmitCommand,
    },
    /// Benchmarks.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
}

#[derive(Subcommand)]
pub enum SubmitCommand {
    /// A Slurm job array, one task per part (samples [i·K, (i+1)·K) of part i, with
    /// --variance), and a merge job that runs after every task has ended, whatever became
    /// of it, merges the parts that exist into DIR/result.exr and reports the spp got
    /// against the spp asked for. Assumes a filesystem shared by this machine and every
    /// node: the scripts name the scene, DIR and this stokes binary by their absolute paths.
    #[command(after_help = SUBMIT_HELP)]
    Slurm(SubmitSlurmArgs),
}

const SUBMIT_HELP: &str =
    "Writes DIR/render.sbatch, DIR/merge.sbatch, DIR/logs/; parts go to DIR/parts/part-<i>.exr. \
With --time-limit, stokes gets --time (the limit less max(60 s, 10 %), at least half of it) \
so that its last pass ends in time; at Slurm's SIGTERM it finishes the pass in flight and \
writes what it has. --resume DIR submits only the sample ranges DIR/parts does not hold \
(e.g. of failed or timed-out tasks) and a new merge.";

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Embree ray throughput: single rays against 4-wide packets.
    Rays(BenchRaysArgs),
    /// Path-tracing throughput: packets of four paths against single rays, by depth and
    /// thread count, in one run.
    Render(BenchRenderArgs),
    /// A render's fraction of its Embree limit: its rays recorded and replayed through
    /// Embree alone, each kind the fastest way Embree offers.
    Limit(BenchLimitArgs),
}

/// A clap parser for the values of a method axis, with their descriptions in `--help`.
pub fn axis<A: Axis + Send + Sync>() -> impl clap::builder::TypedValueParser<Value = A> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    let values = A::VALUES
        .iter()
        .map(|v| PossibleValue::new(v.name()).help(v.about()));
    PossibleValuesParser::new(values)
        .map(|name| A::from_name(&name).expect("clap passes only the listed names"))
}

/// The options every rendering command shares: image size, seed, threads and the method.
#[derive(Args, Clone, Debug)]
pub struct MethodArgs {
    /// Resolution WxH (default: the scene's).
    #[arg(long, value_parser = parse_res)]
    pub res: Option<(u32, u32)>,
    /// Seed of the random streams (default: the scene's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads (0 = one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Wavelength sampling: four hero-driven wavelengths per path, or one.
    #[arg(long, value_parser = axis::<Spectral>(), default_value_t = Spectral::default())]
    pub spectral: Spectral,
    /// The hero wavelength's pdf: uniform over 360–830 nm, or by visible importance.
    #[arg(long, value_parser = axis::<Wavelengths>(), default_value_t = Wavelengths::default())]
    pub wavelengths: Wavelengths,
    /// How the four wavelengths move at a fluorescent vertex (HWSS).
    #[arg(long, value_parser = axis::<Shifting>(), default_value_t = Shifting::default())]
    pub shifting: Shifting,
    /// Distance sampling in media (default: classic where no medium fluoresces,
    /// fluo-aware where one does; `stokes info` says which).
    #[arg(long, value_parser = axis::<Tracking>())]
    pub tracking: Option<Tracking>,
    /// Path segments from the camera: 1 = emitters only, 2 = direct light, −1 = unbounded.
    #[arg(long, allow_negative_numbers = true)]
    pub max_depth: Option<i32>,
    /// Trace four paths per Embree packet, or one path at a time.
    #[arg(long, value_parser = axis::<Rays>(), default_value_t = Rays::default())]
    pub rays: Rays,
    /// At a dispersive refraction: drop the three secondary wavelengths, or split the
    /// path into four single-wavelength paths.
    #[arg(long, value_parser = axis::<Dispersion>(), default_value_t = Dispersion::default())]
    pub dispersion: Dispersion,
    /// Which pixel samples start together in a packet (packet modes; same image).
    #[arg(long, value_parser = axis::<Layout>(), default_value_t = Layout::default())]
    pub layout: Layout,
    /// Also write N spectral channels (bin-averaged spectral radiance, OpenEXR spectral
    /// layout: S0.<centre>nm) beside R, G, B.
    #[arg(long, value_name = "N")]
    pub spectral_bins: Option<u32>,
    /// The range the spectral bins cover, LO:HI in nm (default 360:830, the renderer's).
    #[arg(long, value_name = "LO:HI", value_parser = spectral_exr::parse_range, requires = "spectral_bins")]
    pub spectral_range: Option<(f32, f32)>,
}

impl MethodArgs {
    pub fn method(&self) -> Method {
        let (spectral, shifting, tracking) = (self.spectral, self.shifting, self.tracking);
        let (rays, dispersion) = (self.rays, self.dispersion);
        Method {
            spectral,
            wavelengths: self.wavelengths,
            shifting,
            tracking,
            rays,
            dispersion,
        }
    }

    /// The wavelength bins `--spectral-bins` and `--spectral-range` ask for.
    pub fn bins(&self) -> stokes::Result<Option<Bins>> {
        let Some(count) = self.spectral_bins else {
            return Ok(None);
        };
        let (lo, hi) = self.spectral_range.unwrap_or((LAMBDA_MIN, LAMBDA_MAX));
        let option = if self.spectral_range.is_some() && count > 0 {
            "--spectral-range"
        } else {
            "--spectral-bins"
        };
        Bins::new(count, lo, hi).map(Some).map_err(|e| {
            Error::option(option, stokes::error::Detail::Text(format!("expected {e}")))
        })
    }

    /// The render options these flags give for `scene` (loaded from `path`), with `spp`
    /// samples per pixel; sets the camera's resolution.
    pub fn options(
        &self,
        scene: &mut Scene,
        path: &Path,
        spp: u32,
    ) -> stokes::Result<RenderOptions> {
        let (w, h) = self
            .res
            .unwrap_or((scene.camera.width, scene.camera.height));
        if self.res.is_none() && (w > MAX_SIDE || h > MAX_SIDE) {
            return Err(Error::Value {
                file: path.to_path_buf(),
                error: Key::root("camera").field("resolution").error(format!(
                    "expected sizes in 1..={MAX_SIDE}, found [{w}, {h}] (--res overrides it)"
                )),
            });
        }
        scene.set_resolution(w, h);
        let opts = RenderOptions {
            spp,
            seed: self.seed.unwrap_or(scene.render.seed),
            max_depth: self.max_depth.unwrap_or(scene.render.max_depth),
            threads: self.threads,
            method: self.method(),
            layout: self.layout,
            bins: self.bins()?,
        };
        opts.validate()?;
        Ok(opts)
    }
}

#[derive(Args, Clone)]
pub struct RenderArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Output EXR (default: out/<scene name>.exr).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Samples per pixel (default: the scene's; with --time, a maximum).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Render whole passes while the next one is expected to end within this many
    /// seconds (scene loading not counted); --spp, if given, is then a maximum.
    #[arg(long, value_parser = parse_seconds, allow_negative_numbers = true)]
    pub time: Option<f64>,
    #[command(flatten)]
    pub passes: PassArgs,
    /// Draw sample indices [K, K + spp) instead of [0, spp): parts with disjoint ranges
    /// are independent and can be merged with `stokes merge`.
    #[arg(long, default_value_t = 0)]
    pub seed_offset: u32,
    #[command(flatten)]
    pub method: MethodArgs,
    /// Also write an sRGB PNG preview beside the EXR.
    #[arg(long)]
    pub png: bool,
    /// Also write the per-pixel variance of the mean as <output>.variance.exr.
    #[arg(long)]
    pub variance: bool,
    /// Write render statistics as JSON to this file.
    #[arg(long)]
    pub stats_json: Option<PathBuf>,
    /// Test hook: make every N-th sample NaN (they must be dropped and counted).
    #[arg(long, hide = true)]
    pub inject_nonfinite_every: Option<u64>,
}

#[derive(Args)]
pub struct MergeArgs {
    /// The renders to merge (EXR files written by `stokes render` or `stokes merge`).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// The merged EXR.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also merge the parts' <part>.variance.exr into <output>.variance.exr.
    #[arg(long)]
    pub variance: bool,
    /// The sample indices START..END the merge should hold: report the spp got against
    /// the spp asked for and the samples missing.
    #[arg(long, value_name = "START..END", value_parser = stokes::tools::merge::parse_expected)]
    pub expect: Option<(u64, u64)>,
    /// With --expect: the parts are K spp each (part i holds [i·K, (i+1)·K)); name the
    /// missing samples by part.
    #[arg(long, value_name = "K", requires = "expect")]
    pub part_spp: Option<u64>,
}

#[derive(Args)]
pub struct FigureArgs {
    /// The panels, left to right: LABEL=FILE.exr, split at the last `=` (quote a label
    /// with spaces: "mono max, 16 spp=a.exr").
    #[arg(required = true, value_name = "LABEL=FILE.exr")]
    pub panels: Vec<String>,
    /// The strip (PNG).
    #[arg(short, long, value_name = "STRIP.png")]
    pub output: PathBuf,
    /// The image to take differences and errors against; appended as the last panel
    /// unless it is one of them.
    #[arg(long, value_name = "REF.exr")]
    pub reference: Option<PathBuf>,
    /// The scene whose [[region]]s the error table covers besides the whole image.
    #[arg(long, value_name = "SCENE.toml")]
    pub scene: Option<PathBuf>,
    /// Draw a second row: each panel's luminance minus the reference's, blue below 0,
    /// white at 0, red above, with a colour bar.
    #[arg(long)]
    pub diff: bool,
    /// The difference drawn at full red or blue (default: the 99th percentile of
    /// |difference| over every panel).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub diff_scale: Option<f64>,
    /// Multiply the panels by 2^EV before tone mapping.
    #[arg(
        long,
        value_name = "EV",
        allow_negative_numbers = true,
        default_value_t = 0.0
    )]
    pub exposure: f64,
    /// Draw each image pixel as N×N pixels.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub zoom: u32,
    /// Text above the strip.
    #[arg(long)]
    pub title: Option<String>,
    /// Also write the error table (printed to stdout) to this markdown file.
    #[arg(long, value_name = "FILE.md")]
    pub table: Option<PathBuf>,
    /// Also write the error table as CSV (panel, file, spp, seconds, region, pixels,
    /// rmse, relmse).
    #[arg(long, value_name = "FILE.csv")]
    pub csv: Option<PathBuf>,
}

#[derive(Args)]
pub struct SubmitSlurmArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Parts (array tasks) to split the render into.
    #[arg(long, value_name = "N")]
    pub parts: u32,
    /// Samples per pixel of each part (the render has N·K).
    #[arg(long, value_name = "K")]
    pub spp_per_part: u32,
    /// Each task's time limit, HH:MM:SS or D-HH:MM:SS (sbatch --time).
    #[arg(long, value_name = "HH:MM:SS", value_parser = stokes::tools::submit::parse_time_limit)]
    pub time_limit: Option<u64>,
    /// The Slurm partition.
    #[arg(long)]
    pub partition: Option<String>,
    /// CPUs per task (stokes renders with as many threads; default: Slurm's, one).
    #[arg(long, value_name = "C")]
    pub cpus_per_task: Option<u32>,
    /// The render directory (default: out/slurm/<scene name>).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Submit only the sample ranges DIR/parts does not hold yet (of this scene file), and
    /// a new merge.
    #[arg(long, value_name = "DIR")]
    pub resume: Option<PathBuf>,
    /// Print the scripts and the sbatch commands; write and submit nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// More sbatch options (after --), given to both jobs: -- --account=A --mem=4G
    #[arg(last = true, value_name = "SBATCH OPTIONS")]
    pub sbatch_args: Vec<String>,
}

#[derive(Args, Clone)]
pub struct ReferenceArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Samples per pixel to render (with --resume: to add to the existing ones).
    #[arg(long)]
    pub spp: u32,
    /// The reference EXR; the variance of each pixel mean goes beside it, to
    /// <output>.variance.exr.
    #[arg(short, long)]
    pub output: PathBuf,
    /// If the output exists, add --spp samples to it (the sample indices after the ones
    /// it holds), once its header shows the same scene file, size and settings; without
    /// an existing output, start one. Without --resume an existing output is an error.
    #[arg(long)]
    pub resume: bool,
    #[command(flatten)]
    pub passes: PassArgs,
    #[command(flatten)]
    pub method: MethodArgs,
}

/// The size of a progressive render's passes (`render`, `reference`).
#[derive(Args, Clone)]
pub struct PassArgs {
    /// Samples per pixel per pass: passes are what --time budgets, what Ctrl-C lets
    /// finish and what progress counts. Larger passes keep a packet tracer's paths in
    /// flight longer on small images (fewer rounds that fill or drain them); the image
    /// does not change.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 1,
        allow_negative_numbers = true
    )]
    pub pass_spp: u32,
}

#[derive(Args, Clone)]
pub struct ConvergeArgs {
    /// The scene file (TOML).
    #[arg(required_unless_present = "redraw")]
    pub scene: Option<PathBuf>,
    /// The reference EXR (from `stokes reference`) of the same scene file, at the size of
    /// this run.
    #[arg(long, required_unless_present = "redraw")]
    pub reference: Option<PathBuf>,
    /// Methods to compare, comma-separated (names below; default: every combination the
    /// scene makes meaningful).
    #[arg(long)]
    pub methods: Option<String>,
    /// Seconds of rendering per method (error computation not counted).
    #[arg(long, value_parser = parse_seconds, allow_negative_numbers = true, default_value_t = 10.0)]
    pub budget: f64,
    /// At most this many samples per pixel per method.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Output directory (default: out/converge/<scene name>; with --redraw, DIR).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Another renderer's convergence, drawn as an extra line on both charts and listed
    /// in the summary as external: a CSV with the columns method, spp, seconds, region,
    /// rmse, relmse (found by name; others ignored), one line per distinct method.
    /// Repeatable.
    #[arg(long, value_name = "FILE.csv")]
    pub compare: Vec<PathBuf>,
    /// Render nothing: redraw the charts and print the summary from DIR/convergence.csv
    /// (written by an earlier run), with --compare's lines if given.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["scene", "reference", "methods", "spp"])]
    pub redraw: Option<PathBuf>,
    #[command(flatten)]
    pub method: MethodArgs,
}

#[derive(Args)]
pub struct BenchRaysArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Seconds of measurement per figure (split over the repetitions).
    #[arg(long, default_value_t = 1.0)]
    pub seconds: f64,
    /// Threads for the multi-threaded figures (0 = one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Repetitions per figure; the median is reported.
    #[arg(long, default_value_t = 5)]
    pub repetitions: usize,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct BenchRenderArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Ray modes to compare, comma-separated (single, packet, packet8, lockstep).
    #[arg(long, value_parser = axis::<Rays>(), value_delimiter = ',', default_value = "single,packet")]
    pub rays: Vec<Rays>,
    /// Packet layouts to compare, comma-separated (quad, pixel); single rays run once.
    #[arg(long, value_parser = axis::<Layout>(), value_delimiter = ',', default_value = "quad")]
    pub layouts: Vec<Layout>,
    /// Path depths, comma-separated; −1 is unbounded (1 = camera rays only).
    #[arg(
        long,
        value_delimiter = ',',
        allow_negative_numbers = true,
        default_value = "1,3,-1"
    )]
    pub max_depth: Vec<i32>,
    /// Thread counts, comma-separated (0 = one per core).
    #[arg(long, value_delimiter = ',', default_value = "1,0")]
    pub threads: Vec<usize>,
    /// Resolution WxH (default: the scene's).
    #[arg(long, value_parser = parse_res)]
    pub res: Option<(u32, u32)>,
    /// Wavelength sampling.
    #[arg(long, value_parser = axis::<Spectral>(), default_value_t = Spectral::default())]
    pub spectral: Spectral,
    /// The hero wavelength's pdf.
    #[arg(long, value_parser = axis::<Wavelengths>(), default_value_t = Wavelengths::default())]
    pub wavelengths: Wavelengths,
    /// Dispersive refraction: drop or split.
    #[arg(long, value_parser = axis::<Dispersion>(), default_value_t = Dispersion::default())]
    pub dispersion: Dispersion,
    /// Target seconds per figure (split over the repetitions).
    #[arg(long, default_value_t = 2.0)]
    pub seconds: f64,
    /// Runs per figure; the median is reported.
    #[arg(long, default_value_t = 3)]
    pub repetitions: usize,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct BenchLimitArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    #[command(flatten)]
    pub method: MethodArgs,
    /// Target seconds of the timed render (split over the repetitions).
    #[arg(long, default_value_t = 4.0)]
    pub seconds: f64,
    /// Timed runs of the render and of each replay.
    #[arg(long, default_value_t = 3)]
    pub repetitions: usize,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// A number of seconds > 0. Like [`parse_res`], a clap value parser: clap puts the
/// option and the value before the message (`invalid value '0' for '--time <TIME>': …`),
/// so the error is only the text.
pub fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(t) if t.is_finite() && t > 0.0 => Ok(t),
        _ => Err(format!(
            "expected a positive number of seconds, found {s:?}"
        )),
    }
}

/// The largest image side: 32768² pixels still index with 32 bits.
pub const MAX_SIDE: u32 = 32768;

pub fn parse_res(s: &str) -> Result<(u32, u32), String> {
    let bad = |what: &str| format!("expected {what} in {s:?}");
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WxH such as 512x512, found {s:?}"))?;
    let w: u32 = w.trim().parse().map_err(|_| bad("a width"))?;
    let h: u32 = h.trim().parse().map_err(|_| bad("a height"))?;
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!("expected sizes in 1..={MAX_SIDE}, found {s:?}"));
    }
    Ok((w, h))
}
