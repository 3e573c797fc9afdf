//! The `stokes` command line: parse the options ([`args`]), call the library, print.

mod args;
mod bench;
mod progress;

use args::*;
use progress::{install_interrupt_handler, pass_logger, progress_bar, STOP};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use stokes::error::Error;
use stokes::header::{RenderHeader, SampleRange};
use stokes::integrator::render::{render_progressive, PassDone, Progressive};
use stokes::integrator::render::{ProgressiveResult, Stopped};
use stokes::method::{Method, Resolved};
use stokes::output::{RenderFiles, RenderStats};
use stokes::scene::Scene;
use stokes::tools::{converge, converge_chart, figure, merge, reference, submit};
use stokes::Result;

fn main() -> ExitCode {
    let matches = <Cli as clap::CommandFactory>::command().get_matches();
    let cli = match <Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let ok = |r: Result<()>| r.map(|()| ExitCode::SUCCESS);
    let result = match cli.command {
        Command::Render(a) => cmd_render(&a),
        Command::Reference(a) => cmd_reference(&a),
        Command::Converge(a) => ok(cmd_converge(&a, matches.subcommand_matches("converge"))),
        Command::Info { scene: Some(scene) } => ok(load(&scene).map(|s| print!("{}", s.summary()))),
        Command::Info { scene: None } => {
            print!("{}", stokes::bsdf::desc::kinds_help());
            Ok(ExitCode::SUCCESS)
        }
        Command::Merge(a) => ok(cmd_merge(&a)),
        Command::ConvertBispectral { input, output } => {
            ok(stokes::tools::convert::convert_bispectral(&input, &output)
                .map(|report| eprintln!("{}: {report} → {}", input.display(), output.display())))
        }
        Command::Figure(a) => ok(cmd_figure(&a)),
        Command::Submit {
            what: SubmitCommand::Slurm(a),
        } => ok(cmd_submit_slurm(&a)),
        Command::Bench { what } => ok(bench::run(&what)),
    };
    result.unwrap_or_else(|e| {
        eprintln!("error: {}", stokes::one_line(&e.to_string()));
        ExitCode::FAILURE
    })
}

/// Loads a scene and prints its warnings.
fn load(path: &Path) -> Result<Scene> {
    let scene = Scene::load(path)?;
    for w in &scene.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(scene)
}

/// `--{option}: expected at least 1`.
fn at_least_one(option: &str) -> Error {
    Error::option(option, "expected at least 1")
}

/// `--pass-spp`, at least 1.
fn pass_size(p: &PassArgs) -> Result<u32> {
    match p.pass_spp {
        0 => Err(at_least_one("--pass-spp")),
        n => Ok(n),
    }
}

fn cmd_render(a: &RenderArgs) -> Result<ExitCode> {
    let mut scene = load(&a.scene)?;
    // With a time budget, --spp is a maximum and the scene's spp does not apply.
    let max_spp = if a.time.is_some() {
        a.spp
    } else {
        Some(a.spp.unwrap_or(scene.render.spp))
    };
    let opts = a
        .method
        .options(&mut scene, &a.scene, max_spp.unwrap_or(0))?;
    let (width, height) = (scene.camera.width, scene.camera.height);
    match max_spp {
        Some(0) => return Err(at_least_one("--spp")),
        Some(n) if a.seed_offset.checked_add(n).is_none() => {
            return Err(Error::option(
                "--seed-offset",
                format!(
                    "{} + {n} samples exceed the 32-bit sample index",
                    a.seed_offset
                ),
            ))
        }
        _ => {}
    }
    let pass_spp = pass_size(&a.passes)?;
    if a.inject_nonfinite_every == Some(0) {
        return Err(at_least_one("--inject-nonfinite-every"));
    }
    let files = RenderFiles {
        exr: a
            .output
            .clone()
            .unwrap_or_else(|| PathBuf::from("out").join(format!("{}.exr", scene.name()))),
        variance: a.variance,
        png: a.png,
        stats_json: a.stats_json.clone(),
    };
    files.check()?;

    let passes = max_spp.map(|n| n.div_ceil(pass_spp));
    let bar = progress_bar(passes.filter(|_| a.time.is_none()), height);
    install_interrupt_handler(bar.clone());
    let on_row = || bar.iter().for_each(|b| b.inc(1));
    let mut log = pass_logger(|p| match (max_spp, a.time) {
        (Some(n), None) => {
            let to_go = p.seconds / p.spp as f64 * (n - p.spp) as f64;
            format!("{} of {n} spp, about {to_go:.0} s to go", p.spp)
        }
        (_, Some(t)) => format!("{} spp (time budget {t} s)", p.spp),
        _ => format!("{} spp", p.spp),
    });
    let mut on_pass = |p: PassDone| match &bar {
        Some(b) => b.set_message(format!("{} spp", p.spp)),
        None => log(p),
    };
    let prog = Progressive {
        first_sample: a.seed_offset,
        max_spp,
        time_budget: a.time,
        batch: pass_spp,
        stop: Some(&STOP),
        inject_nonfinite_every: a.inject_nonfinite_every,
    };
    let done = render_progressive(&scene, &opts, &prog, &on_row, &mut on_pass)?;
    bar.iter().for_each(|b| b.finish_and_clear());

    let film = &done.render.film;
    let range = SampleRange {
        seed: opts.seed,
        start: a.seed_offset as u64,
        end: a.seed_offset as u64 + film.spp as u64,
    };
    let mut header = RenderHeader::for_render(
        &scene,
        &opts,
        vec![range],
        done.render.seconds,
        done.stopped,
    );
    header.time_budget = a.time;
    header.nonfinite_samples = done.render.stats.nonfinite;
    files.write_images(film, &header)?;
    warn_nonfinite(done.render.stats.nonfinite, "");
    let stats = RenderStats::new(&done, &header);
    if let Some(p) = &a.stats_json {
        stats.write(p)?;
    }
    let why = match done.stopped {
        Stopped::Complete => String::new(),
        Stopped::TimeBudget => format!(" (time budget {} s)", a.time.unwrap_or(0.0)),
        Stopped::Interrupted => " (interrupted)".to_string(),
    };
    eprintln!(
        "{}: {width}x{height} {} spp{why} in {:.2} s — {:.2} M samples/s, {:.2} M rays/s → {}",
        scene.name(),
        film.spp,
        done.render.seconds,
        stats.samples_per_second / 1e6,
        stats.rays_per_second / 1e6,
        files.exr.display()
    );
    if stokes::integrator::census::ENABLED {
        let samples = u64::from(film.spp) * width as u64 * height as u64;
        let tallies = stokes::integrator::census::take();
        let lanes = opts.method.rays.width();
        eprint!(
            "{}",
            stokes::integrator::census::table(&tallies, samples, lanes)
        );
    }
    Ok(interrupted(&done, || {
        format!(
            "{} holds the {} spp rendered so far (samples {}..{}; continue with --seed-offset {})",
            files.exr.display(),
            film.spp,
            range.start,
            range.end,
            range.end
        )
    }))
}

fn warn_nonfinite(count: u64, what: &str) {
    if count > 0 {
        eprintln!("warning: {what}{count} samples were NaN or infinite and were dropped");
    }
}

/// Exit status 130 with `what_now` after an interrupt, else success.
fn interrupted(done: &ProgressiveResult, what_now: impl Fn() -> String) -> ExitCode {
    if done.stopped != Stopped::Interrupted {
        return ExitCode::SUCCESS;
    }
    eprintln!(
        "error: interrupted after {} passes: {}",
        done.passes,
        what_now()
    );
    ExitCode::from(130)
}

fn cmd_merge(a: &MergeArgs) -> Result<()> {
    if a.part_spp == Some(0) {
        return Err(at_least_one("--part-spp"));
    }
    let report = merge::merge(&a.inputs, &a.output, a.variance)?;
    eprintln!("{}", merge::describe(&report, a.inputs.len(), &a.output));
    if let Some((start, end)) = a.expect {
        eprintln!(
            "{}",
            merge::completeness(&report.ranges, start, end, a.part_spp)
        );
    }
    Ok(())
}

fn cmd_figure(a: &FigureArgs) -> Result<()> {
    let panels = a
        .panels
        .iter()
        .map(|p| figure::Panel::parse(p))
        .collect::<Result<Vec<_>>>()?;
    let made = figure::Figure {
        panels,
        output: a.output.clone(),
        reference: a.reference.clone(),
        scene: a.scene.clone(),
        diff: a.diff,
        diff_scale: a.diff_scale,
        exposure: a.exposure,
        zoom: a.zoom,
        title: a.title.clone(),
        table: a.table.clone(),
        csv: a.csv.clone(),
    }
    .make()?;
    for w in &made.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(md) = &made.markdown {
        print!("{md}");
    }
    let mut wrote = vec![a.output.display().to_string()];
    wrote.extend(
        a.table
            .iter()
            .chain(&a.csv)
            .map(|p| p.display().to_string()),
    );
    let scale = made
        .diff_scale
        .map(|s| format!(", difference scale ±{}", figure::format_value(s)))
        .unwrap_or_default();
    let (w, h) = (made.layout.width, made.layout.height);
    eprintln!(
        "{} panels, {w}x{h} px{scale} → {}",
        made.layout.panels.len(),
        wrote.join(", ")
    );
    Ok(())
}

/// A path made absolute against the working directory (not resolving links).
fn absolute(option: &str, p: &Path) -> Result<PathBuf> {
    std::path::absolute(p)
        .map_err(|e| Error::about_option(option, p, format!("has no absolute path: {e}")))
}

fn cmd_submit_slurm(a: &SubmitSlurmArgs) -> Result<()> {
    if a.parts == 0 {
        return Err(at_least_one("--parts"));
    }
    if a.spp_per_part == 0 {
        return Err(at_least_one("--spp-per-part"));
    }
    if (a.parts as u64) * (a.spp_per_part as u64) > u32::MAX as u64 {
        return Err(Error::option(
            "--spp-per-part",
            format!(
                "{} parts × {} spp exceed the 32-bit sample index",
                a.parts, a.spp_per_part
            ),
        ));
    }
    if a.cpus_per_task == Some(0) {
        return Err(at_least_one("--cpus-per-task"));
    }
    if let Some(p) = &a.partition {
        if p.is_empty()
            || !p
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "_-.,".contains(c))
        {
            return Err(Error::option(
                "--partition",
                format!("expected a Slurm partition name (letters, digits, _ - . ,), found {p:?}"),
            ));
        }
    }
    let scene = load(&a.scene)?;
    let out = match (&a.resume, &a.out) {
        (Some(r), Some(o)) if absolute("--out", o)? != absolute("--resume", r)? => {
            return Err(Error::option(
                "--resume",
                format!(
                    "expected the same directory as --out, found {} and {}",
                    r.display(),
                    o.display()
                ),
            ))
        }
        (Some(r), _) => {
            if !r.is_dir() {
                return Err(Error::about_option(
                    "--resume",
                    r,
                    "is not a directory (submit without --resume first)",
                ));
            }
            r.clone()
        }
        (None, Some(o)) => o.clone(),
        (None, None) => PathBuf::from("out/slurm").join(scene.name()),
    };
    let option = if a.resume.is_some() {
        "--resume"
    } else {
        "--out"
    };
    let sbatch = if a.dry_run {
        None
    } else {
        Some(submit::find_on_path("sbatch").ok_or_else(|| {
            Error::Other(
                "sbatch not found on the PATH: submit from a Slurm login node, or use --dry-run to see the scripts"
                    .into(),
            )
        })?)
    };
    let parts = submit::read_parts(&out)?;
    submit::check_same_scene(option, &parts, &a.scene, &scene.hash)?;
    if a.resume.is_none() {
        if let Some(p) = parts.first() {
            return Err(Error::about_option(
                "--out",
                &p.path,
                "exists: the directory already holds parts of this render (add --resume to render only the samples it lacks, or choose another --out)",
            ));
        }
    }
    let seed = scene.render.seed;
    let present: Vec<_> = parts
        .iter()
        .flat_map(|p| p.header.ranges.iter().copied())
        .filter(|r| r.seed == seed)
        .collect();
    let abs_out = absolute(option, &out)?;
    let exe = std::env::current_exe()
        .map_err(|e| Error::Other(format!("cannot find the stokes binary: {e}")))?;
    let name: String = scene
        .name()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_-.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    let req = submit::Request {
        scene: absolute("SCENE", &a.scene)?,
        seed,
        parts: a.parts,
        spp_per_part: a.spp_per_part,
        time_limit: a.time_limit,
        partition: a.partition.clone(),
        cpus_per_task: a.cpus_per_task,
        out: abs_out.clone(),
        stokes: exe,
        job_name: format!("stokes-{name}"),
        sbatch_args: a.sbatch_args.clone(),
    };
    let plan = submit::plan(&req, &present, |f| abs_out.join("parts").join(f).exists())?;
    let Some(sbatch) = sbatch else {
        print!("{}", submit::describe_dry_run(&req, &plan));
        return Ok(());
    };
    let done = submit::submit(&req, &plan, &sbatch)?;
    let asked = submit::asked(&req);
    match &done.render_job {
        Some(id) => {
            let spp: u64 = plan.tasks.iter().map(|t| t.spp).sum();
            println!(
                "render job: {id} ({} tasks, {spp} of the {} spp asked for)",
                plan.tasks.len(),
                asked.len()
            );
        }
        None => println!(
            "render job: none ({} holds every sample asked for)",
            out.display()
        ),
    }
    println!(
        "merge job: {} (after every render task has ended)",
        done.merge_job
    );
    println!("result: {}", abs_out.join("result.exr").display());
    println!("logs: {}", abs_out.join("logs").display());
    Ok(())
}

fn cmd_reference(a: &ReferenceArgs) -> Result<ExitCode> {
    let mut scene = load(&a.scene)?;
    if a.spp == 0 {
        return Err(at_least_one("--spp"));
    }
    let pass_spp = pass_size(&a.passes)?;
    let opts = a.method.options(&mut scene, &a.scene, a.spp)?;
    install_interrupt_handler(None);
    let mut on_pass = pass_logger(|p| {
        let to_go = p.seconds / p.spp as f64 * (a.spp - p.spp) as f64;
        format!("{} of {} spp, about {to_go:.0} s to go", p.spp, a.spp)
    });
    let job = reference::Job {
        scene: &scene,
        opts: &opts,
        spp: a.spp,
        pass_spp,
        out: &a.output,
        resume: a.resume,
        stop: Some(&STOP),
    };
    let r = reference::render(&job, &mut on_pass)?;
    warn_nonfinite(r.nonfinite, "");
    let (total, out) = (r.header.spp(), a.output.display());
    eprintln!(
        "{}: reference {}x{}, {total} spp (samples {}): added {} spp in {:.2} s → {out}, {}",
        scene.name(),
        scene.camera.width,
        scene.camera.height,
        stokes::header::format_ranges(&r.header.ranges),
        r.added,
        r.seconds,
        r.variance.display()
    );
    if r.stopped == Stopped::Interrupted {
        let missing = a.spp - r.added;
        eprintln!("error: interrupted after {} passes: {out} holds {total} spp; add the {missing} missing with --resume --spp {missing}", r.passes);
        return Ok(ExitCode::from(130));
    }
    Ok(ExitCode::SUCCESS)
}

fn cmd_converge(a: &ConvergeArgs, matches: Option<&clap::ArgMatches>) -> Result<()> {
    // Other renderers' curves, read before anything renders.
    let mut curves = Vec::new();
    for file in &a.compare {
        curves.extend(converge_chart::read_compare(file)?);
    }
    if let Some(dir) = &a.redraw {
        let out = a.out.as_deref().unwrap_or(dir);
        print!("{}", converge_chart::redraw(dir, out, &curves)?);
        let d = out.display();
        eprintln!("→ {d}/error-vs-time.svg/.png, {d}/error-vs-spp.svg/.png");
        return Ok(());
    }
    let (Some(scene_path), Some(reference_path)) = (&a.scene, &a.reference) else {
        return Err(Error::Other(
            "stokes converge needs a SCENE and --reference REF.exr (or --redraw DIR)".into(),
        ));
    };
    let mut scene = load(scene_path)?;
    if a.spp == Some(0) {
        return Err(at_least_one("--spp"));
    }
    let base = a.method.options(&mut scene, scene_path, 1)?;
    let r = reference_path.display();
    if !reference_path.exists() {
        return Err(Error::option(
            &format!("--reference {r}"),
            format!(
                "no such file (make one with `stokes reference {} --spp N -o {r}`)",
                scene_path.display()
            ),
        ));
    }
    let reference = merge::Part::read(reference_path)?;
    if let Some(w) = converge::check_reference(&reference, &scene, &base)? {
        eprintln!("warning: {w}");
    }
    let defaults: Resolved = base.method.resolve(&scene);
    let methods = match &a.methods {
        Some(list) => {
            Method::parse_list(list, &defaults).map_err(|e| Error::option("--methods", e))?
        }
        None => {
            // Every combination the scene makes meaningful, but for the axes fixed by a flag.
            let mut space = converge::MethodSpace::for_scene(&scene, &defaults);
            for axis in [
                "spectral",
                "wavelengths",
                "shifting",
                "tracking",
                "rays",
                "dispersion",
            ] {
                let given = matches.and_then(|m| m.value_source(axis));
                if given == Some(clap::parser::ValueSource::CommandLine) {
                    space.fix(axis, &defaults);
                }
            }
            space.methods()
        }
    };
    let job = converge::Job {
        scene: &scene,
        base: &base,
        budget: converge::Budget {
            seconds: a.budget,
            max_spp: a.spp,
            first_sample: converge::first_sample_after(&reference, base.seed)?,
        },
        methods,
        reference: &reference,
        out_dir: a
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("out/converge").join(scene.name())),
    };
    job.prepare()?;
    eprintln!("{}", job.describe());
    let regions = converge::measured_regions(&scene, scene.camera.width, scene.camera.height);
    let region = converge::chart_region(&regions);
    converge_chart::check_compare(&curves, &regions[region].name)?;
    let count = job.methods.len();
    let report = job.run_with(&curves, &mut |i, run| {
        if let Some(last) = run.checkpoints.last() {
            let rmse = last.errors[region].rmse;
            let (spp, secs, over) = (last.spp, last.seconds, &regions[region].name);
            eprintln!(
                "[{}/{count}] {}: {spp} spp in {secs:.2} s, RMSE {rmse:.4e} over {over}",
                i + 1,
                run.method
            );
        }
        warn_nonfinite(run.nonfinite, &format!("{}: ", run.method));
    })?;
    print!("{}", report.summary);
    let d = job.out_dir.display();
    eprintln!("→ {d}/convergence.csv, {d}/error-vs-time.svg/.png, {d}/error-vs-spp.svg/.png");
    Ok(())
}
