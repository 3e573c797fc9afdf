//! `stokes bench render`: path-tracing throughput (pixel samples per second) of the ray
//! modes — packets of four paths against single rays — at several path depths and thread
//! counts, measured in one run so that their ratios are taken under the same machine load.
//!
//! For every depth, each (threads, mode) runs in turn, `repetitions` times round-robin
//! (every other repetition in reverse order), each run a fixed number of samples per pixel
//! sized from a first untimed warm-up run to take about `seconds / repetitions` at the
//! first thread count. The median rate is reported, and its ratio to single rays and to
//! the fewest threads as *paired* ratios: each repetition's rate over the other figure's
//! rate in the same repetition, seconds apart, then the median and quartiles of those.
//! A shared machine's load drifts over minutes, which a ratio of two medians keeps and a
//! paired ratio divides out. Scene loading and the BVH build are not timed.

use super::machine::Machine;
use super::spread::{median, paired, Spread};
use crate::integrator::render::{render, RenderOptions};
use crate::method::{Axis, Layout, Method, Rays};
use crate::scene::Scene;
use serde::Serialize;
use std::fmt::Write as _;

/// What and how long to measure.
#[derive(Debug, Clone)]
pub struct RenderBenchOptions {
    /// The render settings besides rays, depth, threads and spp (the method's other axes);
    /// the resolution is the scene camera's.
    pub base: RenderOptions,
    /// The ray modes to compare, each with a packet layout (ignored for single rays).
    pub modes: Vec<(Rays, Layout)>,
    /// Path depths (−1 = unbounded).
    pub depths: Vec<i32>,
    /// Thread counts (0 = one per core).
    pub threads: Vec<usize>,
    /// Target seconds per figure, split over the repetitions.
    pub seconds: f64,
    /// Runs per figure; the median is reported.
    pub repetitions: usize,
}

/// One measured figure.
#[derive(Debug, Clone, Serialize)]
pub struct RenderBenchResult {
    /// `single`, `packet`, `packet8` or `lockstep`.
    pub rays: &'static str,
    /// `quad` or `pixel` (packet modes).
    pub layout: &'static str,
    /// Path depth (−1 = unbounded).
    pub max_depth: i32,
    /// Worker threads.
    pub threads: usize,
    /// Median pixel samples per second.
    pub samples_per_second: f64,
    /// Pixel samples per second of each repetition, in the order they ran.
    pub runs: Vec<f64>,
    /// Each repetition's rate over single rays' in the same repetition (same depth and
    /// threads), when single rays were measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vs_single: Option<Spread>,
    /// Each repetition's rate over the same mode's at the fewest threads.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vs_fewest_threads: Option<Spread>,
    /// Samples per pixel of each timed run.
    pub spp: u32,
    /// Rays per pixel sample (camera, bounce and shadow rays).
    pub rays_per_sample: f64,
    /// Packet modes: the share of packet lanes that carried a ray.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub occupancy: Option<f64>,
    /// Packet modes, scenes with media: the share of busy lanes in the steps that
    /// started with a path inside a medium.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub medium_occupancy: Option<f64>,
}

/// The figures of one scene.
#[derive(Debug, Clone, Serialize)]
pub struct RenderBenchReport {
    /// Scene name.
    pub scene: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The machine the figures came from.
    pub machine: Machine,
    /// Every figure.
    pub results: Vec<RenderBenchResult>,
}

/// Runs the benchmark; `progress` hears about each figure as it is measured.
///
/// For each depth, the repetitions are the outer loop and every (threads, mode) runs once
/// in each, so that thread-count ratios, not only mode ratios, are taken under the same
/// load. Every run of a depth draws the same number of samples per pixel, sized from an
/// untimed warm-up of the first mode at the first thread count.
pub fn bench_render(
    scene: &Scene,
    opts: &RenderBenchOptions,
    progress: &mut dyn FnMut(&RenderBenchResult),
) -> crate::Result<RenderBenchReport> {
    let reps = opts.repetitions.max(1);
    let pixels = scene.camera.pixel_count() as f64;
    let run = |threads: usize,
               depth: i32,
               (rays, layout): (Rays, Layout),
               spp: u32|
     -> crate::Result<(f64, f64, Option<f64>, Option<f64>)> {
        let o = RenderOptions {
            spp,
            max_depth: depth,
            threads,
            method: Method {
                rays,
                ..opts.base.method
            },
            layout,
            ..opts.base.clone()
        };
        let r = render(scene, &o, &|| {})?;
        let samples = pixels * spp as f64;
        Ok((
            samples / r.seconds,
            r.stats.rays as f64 / samples,
            r.stats.occupancy(),
            r.stats.medium_occupancy(),
        ))
    };
    let combos: Vec<(usize, (Rays, Layout))> = opts
        .threads
        .iter()
        .flat_map(|&t| opts.modes.iter().map(move |&m| (t, m)))
        .collect();
    let mut results = Vec::new();
    for &depth in &opts.depths {
        let (rate, ..) = run(opts.threads[0], depth, opts.modes[0], 1)?;
        let spp = ((rate * opts.seconds / reps as f64) / pixels)
            .round()
            .max(1.0) as u32;
        let mut rates = vec![Vec::new(); combos.len()];
        let mut seen = vec![(0.0, None, None); combos.len()];
        for rep in 0..reps {
            // Every other repetition in reverse, so that no figure always runs first.
            let order: Vec<usize> = match rep % 2 {
                0 => (0..combos.len()).collect(),
                _ => (0..combos.len()).rev().collect(),
            };
            for c in order {
                let (threads, mode) = combos[c];
                let (r, rps, occ, medium) = run(threads, depth, mode, spp)?;
                rates[c].push(r);
                seen[c] = (rps, occ, medium);
            }
        }
        let fewest = opts.threads.iter().map(|&t| threads_used(t)).min();
        let single = |threads: usize| {
            combos
                .iter()
                .position(|&(t, (rays, _))| t == threads && rays == Rays::Single)
        };
        let at_fewest = |mode: (Rays, Layout)| {
            combos
                .iter()
                .position(|&(t, m)| Some(threads_used(t)) == fewest && m == mode)
        };
        for (c, &(threads, (rays, layout))) in combos.iter().enumerate() {
            let res = RenderBenchResult {
                rays: rays.name(),
                layout: layout.name(),
                max_depth: depth,
                threads: threads_used(threads),
                samples_per_second: median(&rates[c]),
                runs: rates[c].clone(),
                vs_single: single(threads).map(|b| paired(&rates[c], &rates[b])),
                vs_fewest_threads: at_fewest((rays, layout)).map(|b| paired(&rates[c], &rates[b])),
                spp,
                rays_per_sample: seen[c].0,
                occupancy: seen[c].1,
                medium_occupancy: seen[c].2,
            };
            progress(&res);
            results.push(res);
        }
    }
    // Report thread-major, as the table reads.
    results.sort_by_key(|r| (r.threads, r.max_depth < 0, r.max_depth));
    Ok(RenderBenchReport {
        scene: scene.name(),
        width: scene.camera.width,
        height: scene.camera.height,
        machine: Machine::detect(),
        results,
    })
}

/// The worker threads a thread count of 0 (one per core) stands for.
fn threads_used(threads: usize) -> usize {
    match threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        t => t,
    }
}

/// A table of the figures with each mode's rate relative to single rays and to the fewest
/// threads (medians of the paired ratios, with their quartiles beside the ratio to single
/// rays once there are four repetitions); in scenes with media, a last column gives how
/// busy the packets' medium steps ran.
pub fn format_table(report: &RenderBenchReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {}x{}, M samples/s (median of the runs; ratios: median of each run's ratio \
         to the other figure's run in the same repetition)",
        report.scene, report.width, report.height
    );
    let _ = writeln!(s, "{}", report.machine);
    let media = report.results.iter().any(|r| r.medium_occupancy.is_some());
    let quartiles = report.results.iter().any(|r| r.runs.len() >= 4);
    let share =
        |o: Option<f64>| o.map_or_else(|| "-".to_string(), |o| format!("{:.0}%", 100.0 * o));
    let ratio =
        |o: Option<Spread>| o.map_or_else(|| "-".to_string(), |o| format!("{:.2}x", o.median));
    let _ = write!(
        s,
        "{:>7} {:>9} {:>14} {:>11} {:>11} {:>9} {:>9}",
        "threads", "max depth", "rays", "M samples/s", "rays/sample", "lanes", "vs single",
    );
    if quartiles {
        let _ = write!(s, " {:>11}", "quartiles");
    }
    let _ = write!(s, " {:>11}", "vs 1st thr.");
    let _ = writeln!(s, "{}", if media { "  medium lanes" } else { "" });
    for r in &report.results {
        let depth = if r.max_depth < 0 {
            "inf".to_string()
        } else {
            r.max_depth.to_string()
        };
        let mode = match (r.rays, r.layout) {
            ("single", _) | (_, "quad") => r.rays.to_string(),
            (rays, layout) => format!("{rays}/{layout}"),
        };
        let _ = write!(
            s,
            "{:>7} {:>9} {:>14} {:>11.3} {:>11.2} {:>9} {:>9}",
            r.threads,
            depth,
            mode,
            r.samples_per_second / 1e6,
            r.rays_per_sample,
            share(r.occupancy),
            ratio(r.vs_single),
        );
        if quartiles {
            let q = r
                .vs_single
                .filter(|_| r.rays != "single")
                .map_or_else(|| "-".to_string(), |o| format!("{:.2}–{:.2}", o.q1, o.q3));
            let _ = write!(s, " {q:>11}");
        }
        let _ = write!(s, " {:>11}", ratio(r.vs_fewest_threads));
        if media {
            let _ = write!(s, " {:>13}", share(r.medium_occupancy));
        }
        s.push('\n');
    }
    s
}
