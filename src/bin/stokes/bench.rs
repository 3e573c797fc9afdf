//! `stokes bench rays|render|limit`: parse, call the library's benchmark, print a table
//! or one line of JSON.

use super::args::{BenchCommand, BenchLimitArgs, BenchRaysArgs, BenchRenderArgs};
use super::load;
use stokes::error::{Detail, Error};
use stokes::integrator::render::RenderOptions;
use stokes::method::{Layout, Method, Rays};
use stokes::tools::{bench_limit, bench_rays, bench_render};
use stokes::Result;

/// Runs the benchmark `what` asks for.
pub fn run(what: &BenchCommand) -> Result<()> {
    match what {
        BenchCommand::Rays(a) => cmd_bench_rays(a),
        BenchCommand::Render(a) => cmd_bench_render(a),
        BenchCommand::Limit(a) => cmd_bench_limit(a),
    }
}

fn cmd_bench_render(a: &BenchRenderArgs) -> Result<()> {
    let expected = |option: &str, expected: &str, found: String| {
        Err(Error::option(
            option,
            Detail::Expected {
                expected: expected.into(),
                found,
            },
        ))
    };
    if let Some(&d) = a.max_depth.iter().find(|&&d| d == 0 || d < -1) {
        return expected("--max-depth", "−1 or depths ≥ 1", d.to_string());
    }
    if a.rays.is_empty() || a.layouts.is_empty() || a.max_depth.is_empty() || a.threads.is_empty() {
        // Several options at once: no one of them to name.
        return Err(Error::Other(
            "--rays, --layouts, --max-depth and --threads each need at least one value".into(),
        ));
    }
    if !(a.seconds.is_finite() && a.seconds > 0.0) {
        return expected("--seconds", "a positive number", a.seconds.to_string());
    }
    let mut scene = load(&a.scene)?;
    let (width, height) = a.res.unwrap_or((scene.camera.width, scene.camera.height));
    scene.set_resolution(width, height);
    let method = Method {
        spectral: a.spectral,
        wavelengths: a.wavelengths,
        dispersion: a.dispersion,
        ..Method::default()
    };
    let opts = bench_render::RenderBenchOptions {
        base: RenderOptions {
            spp: 1,
            seed: scene.render.seed,
            method,
            ..RenderOptions::default()
        },
        modes: modes(&a.rays, &a.layouts),
        depths: a.max_depth.clone(),
        threads: a.threads.clone(),
        seconds: a.seconds,
        repetitions: a.repetitions,
    };
    let report = bench_render::bench_render(&scene, &opts, &mut |r| {
        if !a.json {
            let rate = r.samples_per_second / 1e6;
            eprintln!(
                "  {} threads, depth {}, {} ({}): {rate:.3} M samples/s",
                r.threads, r.max_depth, r.rays, r.layout
            );
        }
    })?;
    match a.json {
        true => println!("{}", json(&report)?),
        false => print!("{}", bench_render::format_table(&report)),
    }
    Ok(())
}

/// Every ray mode with every layout, single rays once (their layout changes nothing).
fn modes(rays: &[Rays], layouts: &[Layout]) -> Vec<(Rays, Layout)> {
    let mut out = Vec::new();
    for &r in rays {
        match r {
            Rays::Single => out.push((r, Layout::default())),
            _ => out.extend(layouts.iter().map(|&l| (r, l))),
        }
    }
    out
}

fn cmd_bench_limit(a: &BenchLimitArgs) -> Result<()> {
    if !(a.seconds.is_finite() && a.seconds > 0.0) {
        return Err(Error::option("--seconds", "expected a positive number"));
    }
    let mut scene = load(&a.scene)?;
    let render = a.method.options(&mut scene, &a.scene, 1)?;
    let opts = bench_limit::LimitOptions {
        render,
        seconds: a.seconds,
        repetitions: a.repetitions,
    };
    let report = bench_limit::bench_limit(&scene, &opts, &mut |line| {
        if !a.json {
            eprintln!("  {line}");
        }
    })?;
    match a.json {
        true => println!("{}", json(&report)?),
        false => print!("{}", bench_limit::format_table(&report)),
    }
    Ok(())
}

fn cmd_bench_rays(a: &BenchRaysArgs) -> Result<()> {
    let scene = load(&a.scene)?;
    let opts = bench_rays::RayBenchOptions {
        seconds: a.seconds,
        threads: a.threads,
        repetitions: a.repetitions.max(1),
    };
    let report = bench_rays::bench_scene(&scene, &opts);
    match a.json {
        true => println!("{}", json(&report)?),
        false => print!("{}", bench_rays::format_table(&report)),
    }
    Ok(())
}

/// A benchmark report as one line of JSON (plain numbers and names: serialising does not
/// fail, and would have no input to blame).
fn json(report: &impl serde::Serialize) -> Result<String> {
    serde_json::to_string(report).map_err(|e| Error::Other(e.to_string()))
}
