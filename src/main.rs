//! The `stokes` command line: thin over the library.

use clap::{Args, Parser, Subcommand};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use stokes::integrator::render::{render, RenderOptions};
use stokes::integrator::{Shifting, Spectral};
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

#[derive(Args, Clone)]
struct RenderArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// Output EXR (default: out/<scene name>.exr).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Samples per pixel (default: the scene's).
    #[arg(long)]
    spp: Option<u32>,
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
    /// Also write an sRGB PNG preview beside the EXR.
    #[arg(long)]
    png: bool,
    /// Also write the per-pixel variance of the mean as <output>.variance.exr.
    #[arg(long)]
    variance: bool,
    /// Write render statistics as JSON to this file.
    #[arg(long)]
    stats_json: Option<PathBuf>,
}

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
    if w == 0 || h == 0 || w > 32768 || h > 32768 {
        return Err(format!("expected sizes in 1..=32768, found {s:?}"));
    }
    Ok((w, h))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => cmd_render(&a),
        Command::Info { scene } => cmd_info(&scene),
        Command::Bench {
            what: BenchCommand::Rays(a),
        } => cmd_bench_rays(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
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
    let scene = Scene::load(path)?;
    for w in &scene.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(scene)
}

fn cmd_render(a: &RenderArgs) -> Result<(), String> {
    let mut scene = load(&a.scene)?;
    let (width, height) = a.res.unwrap_or((scene.camera.width, scene.camera.height));
    scene.set_resolution(width, height);
    let opts = RenderOptions {
        width,
        height,
        spp: a.spp.unwrap_or(scene.render.spp),
        seed: a.seed.unwrap_or(scene.render.seed),
        max_depth: a.max_depth.unwrap_or(scene.render.max_depth),
        spectral: a.spectral,
        shifting: a.shifting,
        tracking: a.tracking,
        threads: a.threads,
    };
    if opts.spp == 0 {
        return Err("--spp: expected at least 1".into());
    }
    if opts.max_depth == 0 || opts.max_depth < -1 {
        return Err(format!(
            "--max-depth: expected −1 or a depth ≥ 1, found {}",
            opts.max_depth
        ));
    }
    let out = a
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("{}.exr", scene.name())));

    let bar = if std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(height as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {elapsed_precise} [{bar:40}] {pos}/{len} rows, eta {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        Some(b)
    } else {
        None
    };
    let on_row = || {
        if let Some(b) = &bar {
            b.inc(1);
        }
    };
    let result = render(&scene, &opts, &on_row)?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }

    let samples = width as f64 * height as f64 * opts.spp as f64;
    let meta = vec![
        ("scene".to_string(), a.scene.display().to_string()),
        ("spp".to_string(), opts.spp.to_string()),
        ("seed".to_string(), opts.seed.to_string()),
        ("spectral".to_string(), opts.spectral.name().to_string()),
        ("shifting".to_string(), opts.shifting.name().to_string()),
        (
            "tracking".to_string(),
            format!("{:?}", opts.tracking.unwrap_or_else(|| scene.default_tracking().0)).to_lowercase(),
        ),
        ("max_depth".to_string(), opts.max_depth.to_string()),
        (
            "render_seconds".to_string(),
            format!("{:.3}", result.seconds),
        ),
    ];
    let film = &result.film;
    stokes::output::write_exr(&out, width, height, &film.mean(), &meta)?;
    if a.png {
        stokes::output::write_png(&out.with_extension("png"), width, height, &film.mean())?;
    }
    if a.variance {
        stokes::output::write_exr(
            &sibling(&out, ".variance.exr"),
            width,
            height,
            &film.variance_of_mean(),
            &meta,
        )?;
    }
    if result.stats.nonfinite > 0 {
        eprintln!(
            "warning: {} samples were NaN or infinite and were dropped",
            result.stats.nonfinite
        );
    }
    let sps = samples / result.seconds;
    let rps = result.stats.rays as f64 / result.seconds;
    if let Some(p) = &a.stats_json {
        let stats = serde_json::json!({
            "seconds": result.seconds,
            "spp": opts.spp,
            "width": width,
            "height": height,
            "samples_per_second": sps,
            "rays": result.stats.rays,
            "rays_per_second": rps,
            "spectral": opts.spectral.name(),
            "nonfinite_samples": result.stats.nonfinite,
        });
        let text = serde_json::to_string_pretty(&stats).map_err(|e| e.to_string())?;
        stokes::output::write_atomically(p, |tmp| {
            std::fs::write(tmp, text + "\n").map_err(|e| format!("cannot write: {e}"))
        })?;
    }
    eprintln!(
        "{}: {}x{} {} spp in {:.2} s — {:.2} M samples/s, {:.2} M rays/s → {}",
        scene.name(),
        width,
        height,
        opts.spp,
        result.seconds,
        sps / 1e6,
        rps / 1e6,
        out.display()
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
            "; a dispersive dielectric drops the 3 secondary lanes at each refraction"
        } else {
            ""
        }
    );
    if scene.has_fluorescence() {
        println!(
            "fluorescence yes: fluorescent HWSS, --shifting independent (default) or constant; --spectral mono for one wavelength per path"
        );
    } else {
        println!("fluorescence none: plain HWSS, no shift sampling (--shifting has no effect)");
    }
    if scene.has_media() {
        let (t, why) = scene.default_tracking();
        println!(
            "media       {} ({}); default tracking {:?}: {why}",
            scene.medium_names.join(", "),
            if scene.has_fluorescent_media() { "fluorescent" } else { "not fluorescent" },
            t
        );
    } else {
        println!("media       none: no distance tracking");
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
