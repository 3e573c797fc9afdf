//! `stokes bench limit`: how close a render comes to Embree's own speed on the rays it
//! traces.
//!
//! 1. The render is traced once with every ray recorded, by kind: camera rays, bounce
//!    rays, next-event shadow rays (occlusion) and shadow-ray segments through media
//!    (closest hit), at a fixed spp sized from a 1-spp warm-up to take about
//!    `seconds / repetitions`. Every pixel sample draws from its own random streams, so
//!    these are the rays every timed run of that render traces.
//! 2. Each kind is replayed through Embree alone in every way Embree offers — single rays,
//!    4- and 8-wide packets of consecutive recorded rays (as the render grouped them),
//!    flagged coherent and incoherent, and (Embree 3) streams of 256 rays — filling
//!    Embree's ray structures from the recording as a renderer must, and the fastest way
//!    is kept for each kind.
//! 3. `repetitions` times: the render is timed as `stokes render` runs it, and right after
//!    it each kind is replayed once its fastest way.
//!
//! The Embree limit is the pixel samples per second of a renderer that did nothing but
//! trace its rays the fastest way: samples ÷ Σ_kind (fastest replay seconds). The render's
//! fraction of that limit says how much of its time the shading takes: 1 would mean none.
//! It is reported twice: the median render over the fastest replays of step 2, and the
//! spread of the fractions of step 3's pairs, each a render and its replays timed seconds
//! apart, which a shared host's drifting load moves less. Render and replays run on the
//! same pool of `threads` threads.

use super::machine::Machine;
use super::spread::{median, paired, Spread};
use crate::accel::{Coherence, Ray, RaysN, Scene as Accel};
use crate::integrator::render::{render, trace_rays, RenderOptions};
use crate::method::Axis;
use crate::scene::Scene;
use crate::Result;
use rayon::prelude::*;
use serde::Serialize;
use std::fmt::Write as _;
use std::hint::black_box;
use std::time::Instant;

/// What to measure: the render's settings (`spp` is chosen from `seconds`).
#[derive(Debug, Clone)]
pub struct LimitOptions {
    /// The render (method, depth, threads, seed, layout).
    pub render: RenderOptions,
    /// Target seconds of the timed render, split over the repetitions.
    pub seconds: f64,
    /// Timed runs of the render and of each replay; the median (render), the fastest
    /// (replays) and the spread of the paired fractions are reported.
    pub repetitions: usize,
}

/// One way of tracing one kind of ray.
#[derive(Debug, Clone, Serialize)]
pub struct Replay {
    /// `single`, `packet4`, `packet4-coherent`, `packet8`, `packet8-coherent`,
    /// `stream256`, `stream256-coherent`.
    pub method: &'static str,
    /// Million rays per second (fastest run).
    pub mrays_per_second: f64,
}

/// The replays of one kind of ray.
#[derive(Debug, Clone, Serialize)]
pub struct KindReport {
    /// `camera`, `bounce`, `shadow` or `segment`.
    pub kind: &'static str,
    /// Rays of this kind in the render.
    pub rays: u64,
    /// Every way, as measured.
    pub replays: Vec<Replay>,
    /// The fastest way.
    pub fastest: &'static str,
    /// Seconds the fastest way takes for all rays of this kind.
    pub seconds: f64,
}

/// The benchmark's result.
#[derive(Debug, Clone, Serialize)]
pub struct LimitReport {
    /// Scene name.
    pub scene: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel of the timed render and of the recording.
    pub spp: u32,
    /// Threads of the render and the replays.
    pub threads: usize,
    /// The render's ray mode.
    pub rays: &'static str,
    /// The render's path depth (−1 = unbounded).
    pub max_depth: i32,
    /// The machine the figures came from.
    pub machine: Machine,
    /// The render's pixel samples per second (median).
    pub render_samples_per_second: f64,
    /// Pixel samples per second if only Embree ran, each kind the fastest way.
    pub embree_samples_per_second: f64,
    /// Render ÷ Embree limit.
    pub fraction: f64,
    /// The same fraction from each repetition's render and the replays timed right after
    /// it: median and quartiles.
    pub fraction_paired: Spread,
    /// Every kind of ray.
    pub kinds: Vec<KindReport>,
}

/// Runs the benchmark; `progress` hears a line about each step.
pub fn bench_limit(
    scene: &Scene,
    opts: &LimitOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<LimitReport> {
    let pool = crate::accel::thread_pool(opts.render.threads)
        .map_err(|e| crate::Error::Other(format!("cannot start threads: {e}")))?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    let pixels = w as f64 * h as f64;
    let reps = opts.repetitions.max(1);
    // Size the timed runs from a warm-up run of 1 spp.
    let time = |spp: u32| -> Result<f64> {
        let o = RenderOptions {
            spp,
            ..opts.render.clone()
        };
        let r = pool.install(|| render(scene, &o, &|| {}))?;
        Ok(r.seconds)
    };
    let warm = time(1)?;
    let spp = ((opts.seconds / reps as f64 / warm.max(1e-6)).round() as u32).clamp(1, 4096);
    let samples = pixels * spp as f64;

    let log = trace_rays(scene, &opts.render, 0, spp);
    let accel = &scene.accel;
    let kinds: [(&'static str, &Vec<Ray>, bool); 4] = [
        ("camera", &log.camera, false),
        ("bounce", &log.bounce, false),
        ("shadow", &log.shadow, true),
        ("segment", &log.segment, false),
    ];
    let mut reports = Vec::new();
    let mut fastest_runs: Vec<(&Vec<Ray>, bool, Method)> = Vec::new();
    for (kind, rays, occlusion) in kinds {
        if rays.is_empty() {
            continue;
        }
        let mut replays = Vec::new();
        let mut fastest: Option<(&'static str, f64, Method)> = None;
        for (method, run) in methods() {
            let mut best = f64::INFINITY;
            for _ in 0..reps {
                let start = Instant::now();
                pool.install(|| run(accel, rays, occlusion));
                best = best.min(start.elapsed().as_secs_f64());
            }
            let rate = rays.len() as f64 / best;
            progress(&format!("{kind}: {method} {:.2} M rays/s", rate / 1e6));
            replays.push(Replay {
                method,
                mrays_per_second: rate / 1e6,
            });
            if fastest.is_none_or(|(_, seconds, _)| best < seconds) {
                fastest = Some((method, best, run));
            }
        }
        let Some((name, seconds, run)) = fastest else {
            continue;
        };
        fastest_runs.push((rays, occlusion, run));
        reports.push(KindReport {
            kind,
            rays: rays.len() as u64,
            replays,
            fastest: name,
            seconds,
        });
    }
    let embree: f64 = reports.iter().map(|k| k.seconds).sum();
    let embree_rate = samples / embree;

    // Each render, then its rays replayed the fastest way, seconds apart.
    let (mut render_runs, mut embree_runs) = (Vec::new(), Vec::new());
    for _ in 0..reps {
        render_runs.push(samples / time(spp)?);
        let start = Instant::now();
        for (rays, occlusion, run) in &fastest_runs {
            pool.install(|| run(accel, rays, *occlusion));
        }
        embree_runs.push(samples / start.elapsed().as_secs_f64());
    }
    let render_rate = median(&render_runs);
    let fraction_paired = paired(&render_runs, &embree_runs);
    progress(&format!(
        "render: {spp} spp, {:.3} M samples/s; paired fraction {:.2}",
        render_rate / 1e6,
        fraction_paired.median
    ));
    Ok(LimitReport {
        scene: scene.name(),
        width: w,
        height: h,
        spp,
        threads: pool.current_num_threads(),
        rays: opts.render.method.rays.name(),
        max_depth: opts.render.max_depth,
        machine: Machine::detect(),
        render_samples_per_second: render_rate,
        embree_samples_per_second: embree_rate,
        fraction: render_rate / embree_rate,
        fraction_paired,
        kinds: reports,
    })
}

/// A way of tracing a list of rays (closest hit, or occlusion when the flag says so).
type Method = fn(&Accel, &[Ray], bool);

/// Every way Embree offers here.
fn methods() -> Vec<(&'static str, Method)> {
    // Embree 4 has no stream queries to add below.
    #[cfg_attr(embree4, allow(unused_mut))]
    let mut m: Vec<(&'static str, Method)> = vec![
        ("single", |a, r, occ| chunks(r, 256, |c| single(a, c, occ))),
        ("packet4", |a, r, occ| {
            chunks(r, 256, |c| packets4(a, c, occ, Coherence::Incoherent))
        }),
        ("packet4-coherent", |a, r, occ| {
            chunks(r, 256, |c| packets4(a, c, occ, Coherence::Coherent))
        }),
        ("packet8", |a, r, occ| {
            chunks(r, 256, |c| packets8(a, c, occ, Coherence::Incoherent))
        }),
        ("packet8-coherent", |a, r, occ| {
            chunks(r, 256, |c| packets8(a, c, occ, Coherence::Coherent))
        }),
    ];
    #[cfg(embree3)]
    {
        m.push(("stream256", |a, r, occ| {
            chunks(r, 256, |c| stream(a, c, occ, Coherence::Incoherent))
        }));
        m.push(("stream256-coherent", |a, r, occ| {
            chunks(r, 256, |c| stream(a, c, occ, Coherence::Coherent))
        }));
        m.push(("soa128", |a, r, occ| {
            chunks(r, 256, |c| soa_stream(a, c, occ, Coherence::Incoherent))
        }));
        m.push(("soa128-coherent", |a, r, occ| {
            chunks(r, 256, |c| soa_stream(a, c, occ, Coherence::Coherent))
        }));
    }
    m
}

/// Runs `f` over chunks of `n` rays in parallel (in the current pool).
fn chunks(rays: &[Ray], n: usize, f: impl Fn(&[Ray]) -> u64 + Sync + Send) {
    let hits: u64 = rays.par_chunks(n).map(f).sum();
    black_box(hits);
}

fn single(a: &Accel, rays: &[Ray], occlusion: bool) -> u64 {
    rays.iter()
        .map(|r| match occlusion {
            true => a.occluded1(r) as u64,
            false => a.intersect1(r).is_some() as u64,
        })
        .sum()
}

/// Consecutive groups of N rays through one N-wide query each; `query` answers how many
/// of a packet's rays hit (or are blocked).
fn packets<const N: usize>(rays: &[Ray], query: impl Fn(&RaysN<N>, [bool; N]) -> usize) -> u64 {
    rays.chunks(N)
        .map(|p| {
            let (soa, active) = RaysN::<N>::from_rays(p);
            query(&soa, active) as u64
        })
        .sum()
}

fn packets4(a: &Accel, rays: &[Ray], occlusion: bool, c: Coherence) -> u64 {
    packets::<4>(rays, |s, m| match occlusion {
        true => a.occluded4_soa(s, m, c).iter().filter(|&&o| o).count(),
        false => a
            .intersect4_soa(s, m, c)
            .geom
            .iter()
            .filter(|&&g| g != u32::MAX)
            .count(),
    })
}

fn packets8(a: &Accel, rays: &[Ray], occlusion: bool, c: Coherence) -> u64 {
    packets::<8>(rays, |s, m| match occlusion {
        true => a.occluded8_soa(s, m, c).iter().filter(|&&o| o).count(),
        false => a
            .intersect8_soa(s, m, c)
            .geom
            .iter()
            .filter(|&&g| g != u32::MAX)
            .count(),
    })
}

#[cfg(embree3)]
fn stream(a: &Accel, rays: &[Ray], occlusion: bool, c: Coherence) -> u64 {
    if occlusion {
        // As the renderer traces its shadow rays.
        let mut s = crate::accel::OcclusionStream::default();
        rays.iter().for_each(|r| s.push(r));
        a.occluded_stream(&mut s, rays.len(), c);
        return s.count_blocked() as u64;
    }
    let mut s = crate::accel::RayStream::default();
    s.fill(rays.iter().copied());
    a.intersect_stream(&mut s, rays.len(), c);
    s.count_hits() as u64
}

/// Streams in structure-of-arrays form of the renderer's paths in flight, each filled
/// with 4-wide packets as the renderer fills its camera and shadow streams
/// (`rtcIntersectNp`, `rtcOccludedNp`).
#[cfg(embree3)]
fn soa_stream(a: &Accel, rays: &[Ray], occlusion: bool, c: Coherence) -> u64 {
    let mut s = Box::<crate::integrator::trace::RayStream>::default();
    let mut hits = 0;
    for part in rays.chunks(crate::integrator::trace::PATHS_IN_FLIGHT) {
        s.clear();
        let pushed: Vec<(usize, [bool; 4])> = part
            .chunks(4)
            .map(|p| {
                let (soa, active) = RaysN::<4>::from_rays(p);
                (s.push(&soa, active), active)
            })
            .collect();
        let at = pushed.iter().map(|p| p.0);
        let count = |b: [bool; 4]| b.iter().filter(|&&b| b).count() as u64;
        if occlusion {
            a.occluded_packets(&mut s, c);
            let blocked = |(at, active): (usize, [bool; 4])| {
                let b = s.blocked::<4>(at);
                count(std::array::from_fn(|k| b[k] & active[k]))
            };
            hits += pushed.iter().map(|&p| blocked(p)).sum::<u64>();
        } else {
            a.intersect_packets(&mut s, c);
            let hit = |at: usize| count(s.hits::<4>(at).geom.map(|g| g != u32::MAX));
            hits += at.map(hit).sum::<u64>();
        }
    }
    hits
}

/// The report as a table.
pub fn format_table(r: &LimitReport) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: {}x{}, {} spp, depth {}, --rays {}, {} thread(s)",
        r.scene, r.width, r.height, r.spp, r.max_depth, r.rays, r.threads
    );
    let _ = writeln!(out, "{}", r.machine);
    let _ = writeln!(
        out,
        "{:>8} {:>10} {:>20} {:>10}  M rays/s by method",
        "kind", "rays", "fastest", "seconds"
    );
    for k in &r.kinds {
        let all: Vec<String> = k
            .replays
            .iter()
            .map(|p| format!("{} {:.2}", p.method, p.mrays_per_second))
            .collect();
        let _ = writeln!(
            out,
            "{:>8} {:>10} {:>20} {:>10.4}  {}",
            k.kind,
            k.rays,
            k.fastest,
            k.seconds,
            all.join(", ")
        );
    }
    let _ = writeln!(
        out,
        "render {:.3} M samples/s; Embree alone {:.3} M samples/s; fraction of the Embree limit {:.2}",
        r.render_samples_per_second / 1e6,
        r.embree_samples_per_second / 1e6,
        r.fraction
    );
    let p = &r.fraction_paired;
    let _ = writeln!(
        out,
        "fraction from each render and its replays: median {:.2} (quartiles {:.2}-{:.2})",
        p.median, p.q1, p.q3
    );
    out
}
