//! `stokes bench render`: path-tracing throughput (pixel samples per second) of the ray
//! modes — packets of four paths against single rays — at several path depths and thread
//! counts, measured in one run so that their ratios are taken under the same machine load.
//!
//! For every depth, each (threads, mode) runs in turn, `repetitions` times round-robin,
//! each run a fixed number of samples per pixel sized from a first untimed warm-up run to
//! take about `seconds / repetitions` at the first thread count; the median rate is
//! reported, with its ratio to single rays and to the fewest threads. Scene loading and the BVH
//! build are not timed.

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
    /// Every figure.
    pub results: Vec<RenderBenchResult>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
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
        for _ in 0..reps {
            for (c, &(threads, mode)) in combos.iter().enumerate() {
                let (r, rps, occ, medium) = run(threads, depth, mode, spp)?;
                rates[c].push(r);
                seen[c] = (rps, occ, medium);
            }
        }
        for (c, &(threads, (rays, layout))) in combos.iter().enumerate() {
            let res = RenderBenchResult {
                rays: rays.name(),
                layout: layout.name(),
                max_depth: depth,
                threads: threads_used(threads),
                samples_per_second: median(std::mem::take(&mut rates[c])),
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

/// A table of the figures with each mode's rate relative to single rays; in scenes with
/// media, a last column gives how busy the packets' medium steps ran.
pub fn format_table(report: &RenderBenchReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {}x{}, M samples/s (median of the runs)",
        report.scene, report.width, report.height
    );
    let media = report.results.iter().any(|r| r.medium_occupancy.is_some());
    let share =
        |o: Option<f64>| o.map_or_else(|| "-".to_string(), |o| format!("{:.0}%", 100.0 * o));
    let _ = write!(
        s,
        "{:>7} {:>9} {:>14} {:>11} {:>11} {:>9} {:>9} {:>11}",
        "threads",
        "max depth",
        "rays",
        "M samples/s",
        "rays/sample",
        "lanes",
        "vs single",
        "vs 1st thr."
    );
    let _ = writeln!(s, "{}", if media { "  medium lanes" } else { "" });
    let fewest = report.results.iter().map(|r| r.threads).min();
    for r in &report.results {
        let single = report
            .results
            .iter()
            .find(|q| q.rays == "single" && q.max_depth == r.max_depth && q.threads == r.threads)
            .map(|q| q.samples_per_second);
        let ratio = single.map_or_else(
            || "-".to_string(),
            |b| format!("{:.2}x", r.samples_per_second / b),
        );
        let scaling = report
            .results
            .iter()
            .find(|q| {
                Some(q.threads) == fewest
                    && (q.rays, q.layout, q.max_depth) == (r.rays, r.layout, r.max_depth)
            })
            .map_or_else(
                || "-".to_string(),
                |b| format!("{:.2}x", r.samples_per_second / b.samples_per_second),
            );
        let depth = if r.max_depth < 0 {
            "inf".to_string()
        } else {
            r.max_depth.to_string()
        };
        let lanes = share(r.occupancy);
        let mode = match (r.rays, r.layout) {
            ("single", _) | (_, "quad") => r.rays.to_string(),
            (rays, layout) => format!("{rays}/{layout}"),
        };
        let _ = write!(
            s,
            "{:>7} {:>9} {:>14} {:>11.3} {:>11.2} {:>9} {:>9} {:>11}",
            r.threads,
            depth,
            mode,
            r.samples_per_second / 1e6,
            r.rays_per_sample,
            lanes,
            ratio,
            scaling
        );
        if media {
            let _ = write!(s, " {:>13}", share(r.medium_occupancy));
        }
        s.push('\n');
    }
    s
}
