//! The `stokes` command line: thin over the library.

use clap::{Args, Parser, Subcommand};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;
use stokes::integrator::render::{
    render_progressive, PassDone, Progressive, RenderOptions, Stopped,
};
use stokes::integrator::{Dispersion, Rays, Shifting, Spectral};
use stokes::medium::tracking::Tracking;
use stokes::scene::Scene;

#[derive(Parser)]
#[command(
    name = "stokes",
    version,
    about = "A spectral path tracer that renders fluorescence correctly and fast"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to an OpenEXR image (linear sRGB).
    Render(RenderArgs),
    /// Print what a scene contains and which methods a render of it will use.
    Info {
        /// The scene file (TOML).
        scene: PathBuf,
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
        after_long_help = CONVERGE_HELP
    )]
    Converge(ConvergeArgs),
    /// Benchmarks.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Embree ray throughput: single rays against 4-wide packets.
    Rays(BenchRaysArgs),
    /// Path-tracing throughput: packets of four paths against single rays, by depth and
    /// thread count, in one run.
    Render(BenchRenderArgs),
}

#[derive(Args)]
struct BenchRenderArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// Ray modes to compare, comma-separated (single, packet, lockstep).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "single,packet"
    )]
    rays: Vec<Rays>,
    /// Path depths, comma-separated; −1 is unbounded (1 = camera rays only).
    #[arg(
        long,
        value_delimiter = ',',
        allow_negative_numbers = true,
        default_value = "1,3,-1"
    )]
    max_depth: Vec<i32>,
    /// Thread counts, comma-separated (0 = one per core).
    #[arg(long, value_delimiter = ',', default_value = "1,0")]
    threads: Vec<usize>,
    /// Resolution WxH (default: the scene's).
    #[arg(long, value_parser = parse_res)]
    res: Option<(u32, u32)>,
    /// Wavelength sampling.
    #[arg(long, value_enum, default_value_t = Spectral::Hwss)]
    spectral: Spectral,
    /// Dispersive refraction: drop or split.
    #[arg(long, value_enum, default_value_t = Dispersion::default())]
    dispersion: Dispersion,
    /// Target seconds per figure (split over the repetitions).
    #[arg(long, default_value_t = 2.0)]
    seconds: f64,
    /// Runs per figure; the median is reported.
    #[arg(long, default_value_t = 3)]
    repetitions: usize,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct BenchRaysArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// Seconds of measurement per figure (split over the repetitions).
    #[arg(long, default_value_t = 1.0)]
    seconds: f64,
    /// Threads for the multi-threaded figures (0 = one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Repetitions per figure; the median is reported.
    #[arg(long, default_value_t = 5)]
    repetitions: usize,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct MergeArgs {
    /// The renders to merge (EXR files written by `stokes render` or `stokes merge`).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// The merged EXR.
    #[arg(short, long)]
    output: PathBuf,
    /// Also merge the parts' <part>.variance.exr into <output>.variance.exr.
    #[arg(long)]
    variance: bool,
}

/// The options every rendering command shares: image size, seed, threads and the method.
#[derive(Args, Clone, Debug)]
pub struct MethodArgs {
    /// Resolution WxH (default: the scene's).
    #[arg(long, value_parser = parse_res)]
    res: Option<(u32, u32)>,
    /// Seed of the random streams (default: the scene's).
    #[arg(long)]
    seed: Option<u64>,
    /// Worker threads (0 = one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Wavelength sampling: four hero-driven wavelengths per path, or one.
    #[arg(long, value_enum, default_value_t = Spectral::Hwss)]
    spectral: Spectral,
    /// How the four wavelengths move at a fluorescent vertex (HWSS).
    #[arg(long, value_enum, default_value_t = Shifting::Independent)]
    shifting: Shifting,
    /// Distance sampling in media (default: classic where no medium fluoresces,
    /// fluo-aware where one does; `stokes info` says which).
    #[arg(long, value_enum)]
    tracking: Option<Tracking>,
    /// Path segments from the camera: 1 = emitters only, 2 = direct light, −1 = unbounded.
    #[arg(long, allow_negative_numbers = true)]
    max_depth: Option<i32>,
    /// Trace four paths per Embree packet, or one path at a time.
    #[arg(long, value_enum, default_value_t = Rays::default())]
    rays: Rays,
    /// At a dispersive refraction: drop the three secondary wavelengths, or split the
    /// path into four single-wavelength paths.
    #[arg(long, value_enum, default_value_t = Dispersion::default())]
    dispersion: Dispersion,
}

impl MethodArgs {
    /// The render options these flags give for `scene` (loaded from `path`), with `spp`
    /// samples per pixel; sets the camera's resolution.
    fn options(&self, scene: &mut Scene, path: &Path, spp: u32) -> Result<RenderOptions, String> {
        let (width, height) = match self.res {
            Some(r) => r,
            None => {
                let (w, h) = (scene.camera.width, scene.camera.height);
                if w > MAX_SIDE || h > MAX_SIDE {
                    return Err(format!(
                        "{}: camera.resolution: expected sizes in 1..={MAX_SIDE}, found [{w}, {h}] (--res overrides it)",
                        path.display()
                    ));
                }
                (w, h)
            }
        };
        scene.set_resolution(width, height);
        let opts = RenderOptions {
            width,
            height,
            spp,
            seed: self.seed.unwrap_or(scene.render.seed),
            max_depth: self.max_depth.unwrap_or(scene.render.max_depth),
            spectral: self.spectral,
            shifting: self.shifting,
            tracking: self.tracking,
            threads: self.threads,
            rays: self.rays,
            dispersion: self.dispersion,
        };
        if opts.max_depth == 0 || opts.max_depth < -1 {
            return Err(format!(
                "--max-depth: expected −1 or a depth ≥ 1, found {}",
                opts.max_depth
            ));
        }
        Ok(opts)
    }
}

#[derive(Args, Clone)]
struct RenderArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// Output EXR (default: out/<scene name>.exr).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Samples per pixel (default: the scene's; with --time, a maximum).
    #[arg(long)]
    spp: Option<u32>,
    /// Render whole 1-spp passes while the next one is expected to end within this many
    /// seconds (scene loading not counted); --spp, if given, is then a maximum.
    #[arg(long, value_parser = parse_seconds, allow_negative_numbers = true)]
    time: Option<f64>,
    /// Draw sample indices [K, K + spp) instead of [0, spp): parts with disjoint ranges
    /// are independent and can be merged with `stokes merge`.
    #[arg(long, default_value_t = 0)]
    seed_offset: u32,
    #[command(flatten)]
    method: MethodArgs,
    /// Also write an sRGB PNG preview beside the EXR.
    #[arg(long)]
    png: bool,
    /// Also write the per-pixel variance of the mean as <output>.variance.exr.
    #[arg(long)]
    variance: bool,
    /// Write render statistics as JSON to this file.
    #[arg(long)]
    stats_json: Option<PathBuf>,
    /// Test hook: make every N-th sample NaN (they must be dropped and counted).
    #[arg(long, hide = true)]
    inject_nonfinite_every: Option<u64>,
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(t) if t.is_finite() && t > 0.0 => Ok(t),
        _ => Err(format!(
            "expected a positive number of seconds, found {s:?}"
        )),
    }
}

/// The largest image side: 32768² pixels still index with 32 bits.
const MAX_SIDE: u32 = 32768;

fn parse_res(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WxH such as 512x512, found {s:?}"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("expected a width in {s:?}"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("expected a height in {s:?}"))?;
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!("expected sizes in 1..={MAX_SIDE}, found {s:?}"));
    }
    Ok((w, h))
}

fn main() -> ExitCode {
    let matches = <Cli as clap::CommandFactory>::command().get_matches();
    let cli = match <Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Reference(a) => cmd_reference(&a),
        Command::Converge(a) => {
            cmd_converge(&a, matches.subcommand_matches("converge")).map(|()| ExitCode::SUCCESS)
        }
        Command::Render(a) => cmd_render(&a),
        Command::Info { scene } => cmd_info(&scene).map(|()| ExitCode::SUCCESS),
        Command::Merge(a) => cmd_merge(&a).map(|()| ExitCode::SUCCESS),
        Command::Bench {
            what: BenchCommand::Rays(a),
        } => cmd_bench_rays(&a).map(|()| ExitCode::SUCCESS),
        Command::Bench {
            what: BenchCommand::Render(a),
        } => cmd_bench_render(&a).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// The message with control characters escaped, so that an error is always one line
/// (a file name in a scene may hold a newline escape).
fn one_line(s: &str) -> String {
    s.chars()
        .flat_map(|c| {
            let esc: Vec<char> = if c.is_control() {
                c.escape_default().collect()
            } else {
                vec![c]
            };
            esc
        })
        .collect()
}

/// `<output>.variance.exr` beside `<output>.exr`.
fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}{suffix}"))
}

fn load(path: &Path) -> Result<Scene, String> {
    load_with_hash(path).map(|(scene, _)| scene)
}

/// Loads a scene and fingerprints the scene file's bytes (read once).
fn load_with_hash(path: &Path) -> Result<(Scene, String), String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("{}: cannot read scene file: {e}", path.display()))?;
    let hash = stokes::merge::scene_hash_text(text.as_bytes());
    let scene = Scene::from_str(&text, path)?;
    for w in &scene.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok((scene, hash))
}

/// Set by the first interrupt: the render stops after the pass in flight.
static STOP: AtomicBool = AtomicBool::new(false);

/// On the first Ctrl-C (SIGINT; also SIGTERM and SIGHUP, as a batch scheduler sends at a
/// time limit), ask the render to stop after the pass in flight; on the second, exit at
/// once (outputs are written atomically, so no half-written file is left).
fn install_interrupt_handler(bar: Option<indicatif::ProgressBar>) {
    let r = ctrlc::set_handler(move || {
        if STOP.swap(true, Ordering::SeqCst) {
            eprintln!("\ninterrupted again: exiting without writing the image");
            std::process::exit(130);
        }
        let msg = "interrupted: finishing the pass in flight, then writing the image so far (interrupt again to quit at once)";
        match &bar {
            Some(b) => b.println(msg),
            None => eprintln!("{msg}"),
        }
    });
    if let Err(e) = r {
        eprintln!("warning: cannot catch Ctrl-C ({e}): an interrupted render will be lost");
    }
}

fn cmd_render(a: &RenderArgs) -> Result<ExitCode, String> {
    let (mut scene, scene_hash) = load_with_hash(&a.scene)?;
    // With a time budget, --spp is a maximum and the scene's spp does not apply.
    let max_spp = match (a.time, a.spp) {
        (Some(_), spp) => spp,
        (None, spp) => Some(spp.unwrap_or(scene.render.spp)),
    };
    let opts = a
        .method
        .options(&mut scene, &a.scene, max_spp.unwrap_or(0))?;
    let (width, height) = (opts.width, opts.height);
    if max_spp == Some(0) {
        return Err("--spp: expected at least 1".into());
    }
    if let Some(n) = max_spp {
        if a.seed_offset.checked_add(n).is_none() {
            return Err(format!(
                "--seed-offset: {} + {n} samples exceed the 32-bit sample index",
                a.seed_offset
            ));
        }
    }
    if a.inject_nonfinite_every == Some(0) {
        return Err("--inject-nonfinite-every: expected at least 1".into());
    }
    let out = a
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("{}.exr", scene.name())));
    let png = out.with_extension("png");
    let variance = sibling(&out, ".variance.exr");
    let mut outputs = vec![("-o", out.as_path())];
    if a.png {
        outputs.push(("--png", png.as_path()));
    }
    if a.variance {
        outputs.push(("--variance", variance.as_path()));
    }
    if let Some(p) = &a.stats_json {
        outputs.push(("--stats-json", p.as_path()));
    }
    stokes::output::check_outputs(&outputs)?;

    let bar = if std::io::stderr().is_terminal() {
        let b = match max_spp {
            Some(n) if a.time.is_none() => {
                let b = indicatif::ProgressBar::new(n as u64 * height as u64);
                b.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{spinner} {elapsed_precise} [{bar:40}] {msg}, eta {eta}",
                    )
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                    .progress_chars("=> "),
                );
                b
            }
            _ => {
                let b = indicatif::ProgressBar::new_spinner();
                b.set_style(
                    indicatif::ProgressStyle::with_template("{spinner} {elapsed_precise} {msg}")
                        .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
                );
                b.enable_steady_tick(std::time::Duration::from_millis(200));
                b
            }
        };
        b.set_message("0 spp");
        Some(b)
    } else {
        None
    };
    install_interrupt_handler(bar.clone());
    let on_row = || {
        if let Some(b) = &bar {
            b.inc(1);
        }
    };
    // Without a terminal (logs, batch jobs): a line after the first pass, then at most
    // one a minute.
    let mut last_log = Instant::now();
    let mut on_pass = |p: PassDone| {
        if let Some(b) = &bar {
            b.set_message(format!("{} spp", p.spp));
        } else if p.passes == 1 || last_log.elapsed().as_secs_f64() >= 60.0 {
            last_log = Instant::now();
            let of = match (max_spp, a.time) {
                (Some(n), None) => format!(
                    "{} of {n} spp, about {:.0} s to go",
                    p.spp,
                    p.seconds / p.spp as f64 * (n - p.spp) as f64
                ),
                (_, Some(t)) => format!("{} spp (time budget {t} s)", p.spp),
                _ => format!("{} spp", p.spp),
            };
            eprintln!("pass {} done after {:.2} s: {of}", p.passes, p.seconds);
        }
    };
    let prog = Progressive {
        first_sample: a.seed_offset,
        max_spp,
        time_budget: a.time,
        batch: 1,
        stop: Some(&STOP),
        inject_nonfinite_every: a.inject_nonfinite_every,
    };
    let done = render_progressive(&scene, &opts, &prog, &on_row, &mut on_pass)?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let result = &done.render;
    let film = &result.film;
    let spp = film.spp;

    let range = stokes::merge::SampleRange {
        seed: opts.seed,
        start: a.seed_offset as u64,
        end: a.seed_offset as u64 + spp as u64,
    };
    let mut meta = render_meta(
        &scene,
        &a.scene,
        &scene_hash,
        &opts,
        &[range],
        result.seconds,
        done.stopped,
    );
    if let Some(t) = a.time {
        meta.push(("time_budget".to_string(), t.to_string()));
    }
    if result.stats.nonfinite > 0 {
        meta.push((
            "nonfinite_samples".to_string(),
            result.stats.nonfinite.to_string(),
        ));
    }
    let mean = film.mean();
    stokes::output::write_exr(&out, width, height, &mean, &meta)?;
    if a.png {
        stokes::output::write_png(&png, width, height, &mean)?;
    }
    if a.variance {
        stokes::output::write_exr(&variance, width, height, &film.variance_of_mean(), &meta)?;
    }
    if result.stats.nonfinite > 0 {
        eprintln!(
            "warning: {} samples were NaN or infinite and were dropped",
            result.stats.nonfinite
        );
    }
    let samples = width as f64 * height as f64 * spp as f64;
    let sps = samples / result.seconds;
    let rps = result.stats.rays as f64 / result.seconds;
    if let Some(p) = &a.stats_json {
        let stats = serde_json::json!({
            "seconds": result.seconds,
            "spp": spp,
            "width": width,
            "height": height,
            "samples_per_second": sps,
            "rays": result.stats.rays,
            "rays_per_second": rps,
            "spectral": opts.spectral.name(),
            "ray_mode": opts.rays.name(),
            "packet_lane_occupancy": result.stats.occupancy(),
            "dispersion": opts.dispersion.name(),
            "nonfinite_samples": result.stats.nonfinite,
            "seed": opts.seed,
            "seed_offset": a.seed_offset,
            "passes": done.passes,
            "stopped": done.stopped.name(),
        });
        let text = serde_json::to_string_pretty(&stats).map_err(|e| e.to_string())?;
        stokes::output::write_atomically(p, |tmp| {
            std::fs::write(tmp, text + "\n").map_err(|e| format!("cannot write: {e}"))
        })?;
    }
    let why = match done.stopped {
        Stopped::Complete => String::new(),
        Stopped::TimeBudget => format!(" (time budget {} s)", a.time.unwrap_or(0.0)),
        Stopped::Interrupted => " (interrupted)".to_string(),
    };
    eprintln!(
        "{}: {}x{} {} spp{why} in {:.2} s — {:.2} M samples/s, {:.2} M rays/s → {}",
        scene.name(),
        width,
        height,
        spp,
        result.seconds,
        sps / 1e6,
        rps / 1e6,
        out.display()
    );
    if done.stopped == Stopped::Interrupted {
        eprintln!(
            "error: interrupted after {} passes: {} holds the {} spp rendered so far (samples {}..{}; continue with --seed-offset {})",
            done.passes,
            out.display(),
            spp,
            range.start,
            range.end,
            range.end
        );
        return Ok(ExitCode::from(130));
    }
    Ok(ExitCode::SUCCESS)
}

fn cmd_merge(a: &MergeArgs) -> Result<(), String> {
    let variance = stokes::merge::variance_path(&a.output);
    let mut outputs = vec![("-o", a.output.as_path())];
    if a.variance {
        outputs.push(("--variance", variance.as_path()));
    }
    stokes::output::check_outputs(&outputs)?;
    let report = stokes::merge::merge(&a.inputs, &a.output, a.variance)?;
    eprintln!(
        "merged {} renders: {} spp (samples {}) → {}{}",
        a.inputs.len(),
        report.spp,
        stokes::merge::format_ranges(&report.ranges),
        a.output.display(),
        report
            .variance
            .map(|v| format!(", {}", v.display()))
            .unwrap_or_default()
    );
    Ok(())
}

fn cmd_info(path: &Path) -> Result<(), String> {
    let scene = load(path)?;
    println!("scene       {}", path.display());
    println!(
        "camera      {}x{}, render defaults: {} spp, max depth {}, seed {}",
        scene.camera.width,
        scene.camera.height,
        scene.render.spp,
        scene.render.max_depth,
        scene.render.seed
    );
    println!(
        "geometry    {} meshes, {} triangles",
        scene.geometries.len(),
        scene.triangle_count()
    );
    for g in &scene.geometries {
        let m = g
            .material
            .map(|m| scene.material_names[m as usize].as_str())
            .unwrap_or("(none)");
        println!(
            "  {:<40} {:>8} triangles  material {m}",
            g.name, g.triangles
        );
    }
    println!(
        "lights      {} emitters, {} emissive triangles",
        scene.lights.emitters.len(),
        scene.lights.triangles.len()
    );
    println!("materials   {}", scene.material_names.join(", "));
    let dispersion = scene.has_dispersion();
    println!(
        "spectral    hwss (4 wavelengths per path){}",
        if dispersion {
            "; a dispersive dielectric splits the 4 wavelengths: --dispersion drop keeps the hero only, --dispersion split continues all four as single-wavelength paths"
        } else {
            ""
        }
    );
    if scene.has_fluorescence() || scene.has_fluorescent_media() {
        let wher = match (scene.has_fluorescence(), scene.has_fluorescent_media()) {
            (true, true) => "surfaces and media",
            (true, false) => "surfaces",
            _ => "media",
        };
        println!(
            "fluorescence yes ({wher}): fluorescent HWSS, --shifting independent (default) or constant; --spectral mono for one wavelength per path"
        );
    } else {
        println!("fluorescence none: plain HWSS, no shift sampling (--shifting has no effect)");
    }
    if scene.has_media() {
        let (t, why) = scene.default_tracking();
        println!(
            "media       {} ({}); default tracking {}: {why}",
            scene.medium_names.join(", "),
            if scene.has_fluorescent_media() {
                "fluorescent"
            } else {
                "not fluorescent"
            },
            t.name()
        );
    } else {
        println!("media       none: no distance tracking");
    }
    if scene.regions.is_empty() {
        println!("regions     none (stokes converge measures the whole image)");
    } else {
        for r in &scene.regions {
            println!(
                "region      {}: pixels [{}, {}) x [{}, {}) of {}x{} (stokes converge reports it)",
                r.name, r.min[0], r.max[0], r.min[1], r.max[1], r.resolution[0], r.resolution[1]
            );
        }
    }
    Ok(())
}

fn cmd_bench_render(a: &BenchRenderArgs) -> Result<(), String> {
    if let Some(&d) = a.max_depth.iter().find(|&&d| d == 0 || d < -1) {
        return Err(format!("--max-depth: expected −1 or depths ≥ 1, found {d}"));
    }
    if a.rays.is_empty() || a.max_depth.is_empty() || a.threads.is_empty() {
        return Err("--rays, --max-depth and --threads each need at least one value".into());
    }
    if !(a.seconds.is_finite() && a.seconds > 0.0) {
        return Err(format!(
            "--seconds: expected a positive number, found {}",
            a.seconds
        ));
    }
    let mut scene = load(&a.scene)?;
    let (width, height) = a.res.unwrap_or((scene.camera.width, scene.camera.height));
    scene.set_resolution(width, height);
    let base = RenderOptions {
        width,
        height,
        spp: 1,
        seed: scene.render.seed,
        max_depth: -1,
        spectral: a.spectral,
        shifting: Shifting::Independent,
        tracking: None,
        threads: 0,
        rays: Rays::Single,
        dispersion: a.dispersion,
    };
    let opts = stokes::bench_render::RenderBenchOptions {
        base,
        rays: a.rays.clone(),
        depths: a.max_depth.clone(),
        threads: a.threads.clone(),
        seconds: a.seconds,
        repetitions: a.repetitions,
    };
    let json = a.json;
    let report = stokes::bench_render::bench_render(&scene, &opts, &mut |r| {
        if !json {
            eprintln!(
                "  {} threads, depth {}, {}: {:.3} M samples/s",
                r.threads,
                r.max_depth,
                r.rays,
                r.samples_per_second / 1e6
            );
        }
    })?;
    if json {
        println!(
            "{}",
            serde_json::to_string(&report).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", stokes::bench_render::format_table(&report));
    }
    Ok(())
}

fn cmd_bench_rays(a: &BenchRaysArgs) -> Result<(), String> {
    let scene = load(&a.scene)?;
    let cam = scene.camera.clone();
    let lights = &scene.lights;
    let camera_ray = move |x: f32, y: f32| cam.ray(x, y);
    let light_point = |u: [f32; 3]| lights.sample(u).map(|s| s.p).unwrap_or(glam::Vec3::ZERO);
    let input = stokes::bench_rays::RayBenchInput {
        name: scene.name(),
        accel: &scene.accel,
        width: scene.camera.width,
        height: scene.camera.height,
        camera_ray: &camera_ray,
        light_point: &light_point,
        bounds: scene.bounds,
    };
    let opts = stokes::bench_rays::RayBenchOptions {
        seconds: a.seconds,
        threads: a.threads,
        repetitions: a.repetitions.max(1),
    };
    let report = stokes::bench_rays::bench_rays(&input, &opts);
    if a.json {
        println!(
            "{}",
            serde_json::to_string(&report).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", stokes::bench_rays::format_table(&report));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// `stokes reference` and `stokes converge`

/// The `stokes:*` header of a render of `scene` (the file `scene_path`, fingerprint
/// `scene_hash`) with `opts`, holding the samples `ranges`.
fn render_meta(
    scene: &Scene,
    scene_path: &Path,
    scene_hash: &str,
    opts: &RenderOptions,
    ranges: &[stokes::merge::SampleRange],
    seconds: f64,
    stopped: Stopped,
) -> Vec<(String, String)> {
    let spp: u64 = ranges.iter().map(|r| r.len()).sum();
    let tracking = opts.path_options(scene).tracking;
    let mut meta = vec![
        ("scene".to_string(), scene_path.display().to_string()),
        ("scene_hash".to_string(), scene_hash.to_string()),
        ("spp".to_string(), spp.to_string()),
    ];
    if let Some(first) = ranges.first() {
        if ranges.iter().all(|r| r.seed == first.seed) {
            meta.push(("seed".to_string(), first.seed.to_string()));
        }
        if ranges.len() == 1 {
            meta.push(("seed_offset".to_string(), first.start.to_string()));
        }
    }
    meta.extend([
        (
            "sample_ranges".to_string(),
            stokes::merge::format_ranges(ranges),
        ),
        ("spectral".to_string(), opts.spectral.name().to_string()),
        ("shifting".to_string(), opts.shifting.name().to_string()),
        ("tracking".to_string(), tracking.name().to_string()),
        ("max_depth".to_string(), opts.max_depth.to_string()),
        ("rays".to_string(), opts.rays.name().to_string()),
        ("dispersion".to_string(), opts.dispersion.name().to_string()),
        ("render_seconds".to_string(), format!("{seconds:.3}")),
        ("stopped".to_string(), stopped.name().to_string()),
        ("version".to_string(), env!("CARGO_PKG_VERSION").to_string()),
    ]);
    meta
}

#[derive(Args, Clone)]
struct ReferenceArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// Samples per pixel to render (with --resume: to add to the existing ones).
    #[arg(long)]
    spp: u32,
    /// The reference EXR; the variance of each pixel mean goes beside it, to
    /// <output>.variance.exr.
    #[arg(short, long)]
    output: PathBuf,
    /// If the output exists, add --spp samples to it (the sample indices after the ones
    /// it holds), once its header shows the same scene file, size and settings; without
    /// an existing output, start one. Without --resume an existing output is an error.
    #[arg(long)]
    resume: bool,
    #[command(flatten)]
    method: MethodArgs,
}

/// The reference to resume: its means, its variance, and the checks that it belongs with
/// this run.
fn read_resumed(
    out: &Path,
    var_path: &Path,
    scene_hash: &str,
    settings: &[(&str, String)],
    size: (u32, u32),
) -> Result<(stokes::merge::Part, stokes::merge::Part), String> {
    use stokes::merge::Part;
    let o = out.display();
    let prev = Part::read(out).map_err(|e| format!("--resume: {e}"))?;
    if (prev.width, prev.height) != size {
        return Err(format!(
            "--resume: {o} is {}x{} but this run renders {}x{}: resume at the reference's size (--res {}x{})",
            prev.width, prev.height, size.0, size.1, prev.width, prev.height
        ));
    }
    if prev.meta["scene_hash"] != scene_hash {
        return Err(format!(
            "--resume: {o} is a reference of {} ({}), but this scene file's hash is {scene_hash}: the scene changed or is another one (remove {o} to start again)",
            prev.meta.get("scene").map(String::as_str).unwrap_or("?"),
            prev.meta["scene_hash"]
        ));
    }
    for (k, v) in settings {
        if &prev.meta[*k] != v {
            return Err(format!(
                "--resume: {o} was rendered with {k} = {} but this run has {k} = {v}: resume with the same settings",
                prev.meta[*k]
            ));
        }
    }
    if !var_path.exists() {
        return Err(format!(
            "--resume: {} is missing: a reference keeps its variance beside it (remove {o} to start again)",
            var_path.display()
        ));
    }
    let var = Part::read(var_path).map_err(|e| format!("--resume: {e}"))?;
    if (var.width, var.height) != (prev.width, prev.height)
        || var.spp != prev.spp
        || var.ranges != prev.ranges
        || var.meta["scene_hash"] != prev.meta["scene_hash"]
    {
        return Err(format!(
            "--resume: {} does not belong to {o} (size, spp, samples or scene differ)",
            var_path.display()
        ));
    }
    Ok((prev, var))
}

fn cmd_reference(a: &ReferenceArgs) -> Result<ExitCode, String> {
    use stokes::merge::{self, Part, SampleRange};
    let (mut scene, scene_hash) = load_with_hash(&a.scene)?;
    if a.spp == 0 {
        return Err("--spp: expected at least 1".into());
    }
    let opts = a.method.options(&mut scene, &a.scene, a.spp)?;
    let (width, height) = (opts.width, opts.height);
    let out = &a.output;
    let var_path = merge::variance_path(out);
    stokes::output::check_outputs(&[("-o", out), ("-o", &var_path)])?;
    let tracking = opts.path_options(&scene).tracking;
    let settings: Vec<(&str, String)> = merge::SETTINGS
        .iter()
        .map(|&k| {
            let v = match k {
                "spectral" => opts.spectral.name().to_string(),
                "shifting" => opts.shifting.name().to_string(),
                "tracking" => tracking.name().to_string(),
                "max_depth" => opts.max_depth.to_string(),
                _ => opts.dispersion.name().to_string(),
            };
            (k, v)
        })
        .collect();
    let previous = if out.exists() {
        if !a.resume {
            return Err(format!(
                "{}: the reference exists: pass --resume to add {} samples to it, or remove it (and {}) to start again",
                out.display(),
                a.spp,
                var_path.display()
            ));
        }
        Some(read_resumed(
            out,
            &var_path,
            &scene_hash,
            &settings,
            (width, height),
        )?)
    } else {
        None
    };
    // New samples follow the ones of the same seed the reference holds.
    let start: u64 = previous
        .as_ref()
        .and_then(|(p, _)| {
            p.ranges
                .iter()
                .filter(|r| r.seed == opts.seed)
                .map(|r| r.end)
                .max()
        })
        .unwrap_or(0);
    let first_sample = u32::try_from(start)
        .ok()
        .filter(|s| s.checked_add(a.spp).is_some())
        .ok_or_else(|| {
            format!(
                "--spp: samples {start}..{start} + {} exceed the 32-bit sample index",
                a.spp
            )
        })?;

    install_interrupt_handler(None);
    let mut last_log = Instant::now();
    let mut on_pass = |p: PassDone| {
        if p.passes == 1 || last_log.elapsed().as_secs_f64() >= 60.0 {
            last_log = Instant::now();
            eprintln!(
                "pass {} done after {:.2} s: {} of {} spp, about {:.0} s to go",
                p.passes,
                p.seconds,
                p.spp,
                a.spp,
                p.seconds / p.spp as f64 * (a.spp - p.spp) as f64
            );
        }
    };
    let prog = Progressive {
        first_sample,
        max_spp: Some(a.spp),
        batch: 1,
        stop: Some(&STOP),
        ..Default::default()
    };
    let done = render_progressive(&scene, &opts, &prog, &|| {}, &mut on_pass)?;
    let result = &done.render;
    let film = &result.film;
    let range = SampleRange {
        seed: opts.seed,
        start,
        end: start + film.spp as u64,
    };
    let mut nonfinite = result.stats.nonfinite;
    let (mean, var, ranges, seconds) = match previous {
        None => (
            film.mean(),
            film.variance_of_mean(),
            vec![range],
            result.seconds,
        ),
        Some((prev, prev_var)) => {
            let new = Part {
                path: out.clone(),
                width,
                height,
                pixels: film.mean(),
                meta: prev.meta.clone(),
                spp: film.spp as u64,
                ranges: vec![range],
            };
            let prev_seconds: f64 = prev
                .meta
                .get("render_seconds")
                .and_then(|t| t.parse().ok())
                .unwrap_or(0.0);
            nonfinite += prev
                .meta
                .get("nonfinite_samples")
                .and_then(|t| t.parse::<u64>().ok())
                .unwrap_or(0);
            let mut ranges = prev.ranges.clone();
            ranges.push(range);
            let parts = [prev, new];
            let mean = merge::weighted_mean(&parts);
            let var =
                merge::pooled_variance(&parts, &[prev_var.pixels, film.variance_of_mean()], &mean);
            (
                mean,
                var,
                merge::normalise(ranges),
                prev_seconds + result.seconds,
            )
        }
    };
    let mut meta = render_meta(
        &scene,
        &a.scene,
        &scene_hash,
        &opts,
        &ranges,
        seconds,
        done.stopped,
    );
    if nonfinite > 0 {
        meta.push(("nonfinite_samples".to_string(), nonfinite.to_string()));
    }
    if result.stats.nonfinite > 0 {
        eprintln!(
            "warning: {} samples were NaN or infinite and were dropped",
            result.stats.nonfinite
        );
    }
    // The variance first: the reference itself is written last, so that an interrupted
    // pair of writes leaves a variance that does not match it (caught by --resume)
    // rather than a reference with a stale variance.
    stokes::output::write_exr(&var_path, width, height, &var, &meta)?;
    stokes::output::write_exr(out, width, height, &mean, &meta)?;
    let total: u64 = ranges.iter().map(|r| r.len()).sum();
    eprintln!(
        "{}: reference {width}x{height}, {total} spp (samples {}): added {} spp in {:.2} s → {}, {}",
        scene.name(),
        merge::format_ranges(&ranges),
        film.spp,
        result.seconds,
        out.display(),
        var_path.display()
    );
    if done.stopped == Stopped::Interrupted {
        eprintln!(
            "error: interrupted after {} passes: {} holds {total} spp; add the {} missing with --resume --spp {}",
            done.passes,
            out.display(),
            a.spp - film.spp,
            a.spp - film.spp
        );
        return Ok(ExitCode::from(130));
    }
    Ok(ExitCode::SUCCESS)
}

/// The long help of `stokes converge`: method names, the default list and the outputs.
const CONVERGE_HELP: &str = "\
Methods: a method is one value on each of five axes, joined by `-` in this order:
  spectral     hwss | mono
  shifting     independent | constant
  tracking     classic | max | fluo-aware
  rays         single | packet
  dispersion   drop | split
for example hwss-independent-fluo-aware-packet-drop (the name the outputs use). In
--methods a name may list the values in any order and leave axes out: those take the
method flags' values (--spectral, --shifting, --tracking, --rays, --dispersion), else the
defaults hwss, independent, the scene's default tracking, single, drop. Example:
  --methods hwss-packet,mono-packet,hwss-constant-max

Without --methods: every combination the scene makes meaningful. Spectral and rays
always vary; shifting only where something fluoresces, tracking only where there are
media, dispersion only where a dielectric is dispersive; mono takes one shifting and one
dispersion value (they act on the secondary wavelengths). A method flag given on the
command line fixes its axis (--spectral mono: only mono methods).

Each method renders passes of 1 spp on samples after the reference's, until --budget
seconds of rendering (or --spp). At spp 1, 2, 4, 8, ... and at the final spp it records
the seconds of rendering so far (error computation not counted) and the error against
the reference over the image and over each [[region]] of the scene:
  rmse   = sqrt(mean over pixels and channels of (x - r)^2)
  relmse = mean over pixels and channels of (x - r)^2 / (r^2 + 0.01)

Outputs in --out DIR:
  convergence.csv   method,spectral,shifting,tracking,rays,dispersion,pass,spp,seconds,
                    region,rmse,relmse (one row per checkpoint and region; region `image`
                    is the whole image)
  error-vs-time.svg/.png, error-vs-spp.svg/.png: log-log RMSE over the first region
                    (else the image), one line per method, a dashed line of slope -1/2
and on stdout a table: per method, the fitted log-log slope of RMSE against spp (over
checkpoints with spp >= 4; -0.5 for an unbiased method), the final errors and the
seconds to reach the worst final relMSE of all methods.";

/// The files `stokes converge` writes in its --out directory.
const CONVERGE_FILES: [&str; 5] = [
    "convergence.csv",
    "error-vs-time.svg",
    "error-vs-time.png",
    "error-vs-spp.svg",
    "error-vs-spp.png",
];

#[derive(Args, Clone)]
struct ConvergeArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// The reference EXR (from `stokes reference`) of the same scene file, at the size of
    /// this run.
    #[arg(long)]
    reference: PathBuf,
    /// Methods to compare, comma-separated (names below; default: every combination the
    /// scene makes meaningful).
    #[arg(long)]
    methods: Option<String>,
    /// Seconds of rendering per method (error computation not counted).
    #[arg(long, value_parser = parse_seconds, allow_negative_numbers = true, default_value_t = 10.0)]
    budget: f64,
    /// At most this many samples per pixel per method.
    #[arg(long)]
    spp: Option<u32>,
    /// Output directory (default: out/converge/<scene name>).
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    method: MethodArgs,
}

fn cmd_converge(a: &ConvergeArgs, matches: Option<&clap::ArgMatches>) -> Result<(), String> {
    use stokes::converge::{self, Budget, Method, MethodSpace};
    let (mut scene, scene_hash) = load_with_hash(&a.scene)?;
    if a.spp == Some(0) {
        return Err("--spp: expected at least 1".into());
    }
    let base = a.method.options(&mut scene, &a.scene, 1)?;
    let (width, height) = (base.width, base.height);

    // The reference: same scene file, size and depth.
    let r = a.reference.display();
    if !a.reference.exists() {
        return Err(format!(
            "--reference {r}: no such file (make one with `stokes reference {} --spp N -o {r}`)",
            a.scene.display()
        ));
    }
    let reference = stokes::merge::Part::read(&a.reference)?;
    if (reference.width, reference.height) != (width, height) {
        return Err(format!(
            "--reference {r} is {}x{} but this run renders {width}x{height} (--res or the scene's camera.resolution): give a reference of the same size",
            reference.width, reference.height
        ));
    }
    if reference.meta["scene_hash"] != scene_hash {
        return Err(format!(
            "--reference {r} is a reference of {} ({}), not of {} ({scene_hash})",
            reference
                .meta
                .get("scene")
                .map(String::as_str)
                .unwrap_or("?"),
            reference.meta["scene_hash"],
            a.scene.display()
        ));
    }
    if reference.meta["max_depth"] != base.max_depth.to_string() {
        return Err(format!(
            "--reference {r} was rendered with max_depth = {} but this run uses {}: the images converge to different values (give --max-depth {})",
            reference.meta["max_depth"], base.max_depth, reference.meta["max_depth"]
        ));
    }
    if reference.meta["tracking"] == "classic" && scene.has_fluorescent_media() {
        eprintln!("warning: {r} was rendered with classic tracking, which is biased in fluorescent media: errors are measured against a biased reference");
    }

    // The methods.
    let defaults = Method {
        spectral: a.method.spectral,
        shifting: a.method.shifting,
        tracking: a
            .method
            .tracking
            .unwrap_or_else(|| scene.default_tracking().0),
        rays: a.method.rays,
        dispersion: a.method.dispersion,
    };
    let methods = match &a.methods {
        Some(list) => Method::parse_list(list, &defaults).map_err(|e| format!("--methods: {e}"))?,
        None => {
            let given = |id: &str| {
                matches.and_then(|m| m.value_source(id))
                    == Some(clap::parser::ValueSource::CommandLine)
            };
            let mut space = MethodSpace::for_scene(&scene, &defaults);
            if given("spectral") {
                space.spectral = vec![defaults.spectral];
            }
            if given("shifting") {
                space.shifting = vec![defaults.shifting];
            }
            if given("tracking") {
                space.tracking = vec![defaults.tracking];
            }
            if given("rays") {
                space.rays = vec![defaults.rays];
            }
            if given("dispersion") {
                space.dispersion = vec![defaults.dispersion];
            }
            space.methods()
        }
    };

    // Samples after the reference's, so that no method reuses the reference's samples.
    let first_sample = reference
        .ranges
        .iter()
        .filter(|r| r.seed == base.seed)
        .map(|r| r.end)
        .max()
        .unwrap_or(0);
    let first_sample = u32::try_from(first_sample)
        .ok()
        .filter(|&s| s < u32::MAX / 2)
        .ok_or_else(|| {
            format!("--reference {r} holds samples up to {first_sample} of seed {}: too many to draw new ones after them (give another --seed)", base.seed)
        })?;
    let budget = Budget {
        seconds: a.budget,
        max_spp: a.spp,
        first_sample,
    };
    let regions = converge::measured_regions(&scene, width, height);
    let chart_region = if regions.len() > 1 { 1 } else { 0 };
    let region_name = &regions[chart_region].name;
    let out_dir = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/converge").join(scene.name()));
    let files: Vec<PathBuf> = CONVERGE_FILES.iter().map(|f| out_dir.join(f)).collect();
    let outputs: Vec<(&str, &Path)> = files.iter().map(|f| ("--out", f.as_path())).collect();
    stokes::output::check_outputs(&outputs)?;
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| format!("--out {}: cannot create directory: {e}", out_dir.display()))?;
    let pool = stokes::accel::thread_pool(base.threads)
        .map_err(|e| format!("cannot start threads: {e}"))?;

    eprintln!(
        "{}: {width}x{height}, {} methods, {} s each{}, samples from {first_sample} on (after the reference's {} spp)",
        scene.name(),
        methods.len(),
        a.budget,
        a.spp.map(|n| format!(" (at most {n} spp)")).unwrap_or_default(),
        reference.spp
    );
    // One untimed pass first, so that the first method does not pay for cold caches and
    // sleeping threads.
    if let Some(m) = methods.first() {
        let warm = Budget {
            max_spp: Some(1),
            ..budget
        };
        converge::run_method(&scene, &base, m, &reference.pixels, &regions, &warm, &pool)?;
    }
    let mut runs = Vec::with_capacity(methods.len());
    for (i, m) in methods.iter().enumerate() {
        let run = converge::run_method(
            &scene,
            &base,
            m,
            &reference.pixels,
            &regions,
            &budget,
            &pool,
        )?;
        if let Some(last) = run.checkpoints.last() {
            eprintln!(
                "[{}/{}] {}: {} spp in {:.2} s, RMSE {:.4e} over {region_name}",
                i + 1,
                methods.len(),
                m.name(),
                last.spp,
                last.seconds,
                last.errors[chart_region].rmse
            );
        }
        if run.nonfinite > 0 {
            eprintln!(
                "warning: {}: {} samples were NaN or infinite and were dropped",
                m.name(),
                run.nonfinite
            );
        }
        runs.push(run);
    }

    let csv_path = out_dir.join("convergence.csv");
    let text = converge::csv(&runs, &regions);
    stokes::output::write_atomically(&csv_path, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|e| format!("cannot write: {e}"))
    })?;
    let names = converge::short_names(&methods);
    let over = if chart_region == 0 {
        "the whole image".to_string()
    } else {
        format!("region `{region_name}`")
    };
    for (file, x_label, x_of) in [
        (
            "error-vs-time",
            "seconds of rendering",
            (|c: &converge::Checkpoint| c.seconds) as fn(&converge::Checkpoint) -> f64,
        ),
        ("error-vs-spp", "samples per pixel", |c| c.spp as f64),
    ] {
        let chart = stokes::chart::LogLogChart {
            title: format!(
                "{} {width}x{height}: RMSE over {over} against {}",
                scene.name(),
                if file == "error-vs-time" {
                    "time"
                } else {
                    "spp"
                }
            ),
            x_label: x_label.into(),
            y_label: "RMSE (linear sRGB)".into(),
            series: runs
                .iter()
                .zip(&names)
                .map(|(run, name)| stokes::chart::Series {
                    name: name.clone(),
                    points: run
                        .checkpoints
                        .iter()
                        .map(|c| (x_of(c), c.errors[chart_region].rmse))
                        .collect(),
                })
                .collect(),
            reference_slope: true,
        };
        stokes::chart::write_svg(&chart, &out_dir.join(format!("{file}.svg")))?;
        stokes::chart::write_png(&chart, &out_dir.join(format!("{file}.png")))?;
    }

    let (target, worst, rows) = converge::summarize(&runs, chart_region);
    println!(
        "{} {width}x{height} against {} ({} spp)",
        scene.name(),
        r,
        reference.spp
    );
    let var_path = stokes::merge::variance_path(&a.reference);
    if let Ok((vw, vh, var, _)) = stokes::output::read_exr(&var_path) {
        if (vw, vh) == (width, height) {
            let px = &regions[chart_region].pixels;
            let mean_var = px
                .iter()
                .map(|&i| var[i].iter().map(|&v| v as f64).sum::<f64>())
                .sum::<f64>()
                / (3 * px.len()) as f64;
            println!(
                "the reference's own noise over {over}: RMSE ≈ {:.3e} (from {}); errors near it are the reference's",
                mean_var.sqrt(),
                var_path.display()
            );
        }
    }
    println!();
    print!(
        "{}",
        converge::format_summary(region_name, target, &worst, &rows)
    );
    eprintln!(
        "→ {}, {}/error-vs-time.svg/.png, {}/error-vs-spp.svg/.png",
        csv_path.display(),
        out_dir.display(),
        out_dir.display()
    );
    Ok(())
}
