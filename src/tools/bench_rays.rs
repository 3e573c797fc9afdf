//! `stokes bench rays`: Embree ray throughput on a scene, single rays against 4-wide
//! packets, on one thread and on all of them.
//!
//! Three queries are measured, each with single rays and with packets of four:
//!
//! | query | single | packet |
//! | --- | --- | --- |
//! | `camera`: one ray per pixel centre | `intersect1` | `intersect4` on 2×2 pixel quads, `Coherent` |
//! | `random`: origins uniform in the scene bounds, uniform directions | `intersect1` | `intersect4` on consecutive rays, `Incoherent` |
//! | `shadow`: from the camera hits to points on the lights (one per 2×2 quad) | `occluded1` | `occluded4` on 2×2 pixel quads, `Coherent` |
//!
//! Every ray buffer is generated before the clock starts (the shadow rays from a first,
//! untimed pass of camera hits), so only the queries — and filling Embree's ray structures
//! from the buffer, as a renderer must — are timed. Each query runs on a pool of one
//! thread and on a pool of `threads` threads (0 = one per core), the work split in tiles
//! of pixels (camera, shadow) or chunks of rays (random) handed out by rayon. Every figure
//! is the median of `repetitions` runs of about `seconds / repetitions` each; single and
//! packet runs alternate so that both see the same machine load. Rates count rays: a
//! packet with four active lanes is four rays.
//!
//! The scene is reached through closures ([`RayBenchInput`]) so that this module depends
//! only on [`crate::accel`].

use super::machine::Machine;
use super::spread::median;
use crate::accel::{thread_pool, Coherence, Ray, RayHit4, Scene};
use glam::Vec3;
use rayon::prelude::*;
use rayon::ThreadPool;
use std::fmt::Write as _;
use std::hint::black_box;
use std::time::{Duration, Instant};

/// What [`bench_rays`] measures: a committed scene and how to make its rays.
pub struct RayBenchInput<'a> {
    /// Scene name, for the report.
    pub name: String,
    /// The committed acceleration structure.
    pub accel: &'a Scene,
    /// Film width in pixels.
    pub width: u32,
    /// Film height in pixels.
    pub height: u32,
    /// The camera ray through film position `(x, y)` in pixels (`x + 0.5` is a pixel centre).
    pub camera_ray: &'a (dyn Fn(f32, f32) -> Ray + Sync),
    /// A point on a light from three uniform numbers in `[0, 1)`.
    pub light_point: &'a (dyn Fn([f32; 3]) -> Vec3 + Sync),
    /// The scene's bounding box (min, max), where random rays start.
    pub bounds: (Vec3, Vec3),
}

/// How long and on how many threads [`bench_rays`] measures.
#[derive(Debug, Clone)]
pub struct RayBenchOptions {
    /// Target wall time of each of the 12 figures, split over the repetitions.
    pub seconds: f64,
    /// Threads of the multi-threaded figures (0 = one per core).
    pub threads: usize,
    /// Runs per figure; the median is reported.
    pub repetitions: usize,
}

impl Default for RayBenchOptions {
    fn default() -> RayBenchOptions {
        RayBenchOptions {
            seconds: 1.0,
            threads: 0,
            repetitions: 5,
        }
    }
}

/// One figure of the benchmark.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RayBenchResult {
    /// `camera`, `random` or `shadow`.
    pub query: &'static str,
    /// `single` or `packet`.
    pub mode: &'static str,
    /// Threads of the pool that ran it.
    pub threads: usize,
    /// Million rays per second (median over the repetitions).
    pub mrays_per_s: f64,
}

/// All figures of one scene; serialises as
/// `{"scene", "triangles", "machine", "results": [{"query", "mode", "threads", "mrays_per_s"}]}`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RayBenchReport {
    /// Scene name.
    pub scene: String,
    /// Triangles in the acceleration structure.
    pub triangles: usize,
    /// The machine the figures came from.
    pub machine: Machine,
    /// 12 figures: {camera, random, shadow} × {1 thread, all threads} × {single, packet}.
    pub results: Vec<RayBenchResult>,
}

/// Query names, in report order.
pub const QUERIES: [&str; 3] = ["camera", "random", "shadow"];
/// Mode names, in report order.
pub const MODES: [&str; 2] = ["single", "packet"];

/// Pixels per side of the tiles that camera and shadow work is split into (even, so that
/// tiles hold whole 2×2 quads).
const TILE: u32 = 16;
/// Rays per chunk of random-ray work.
const RANDOM_CHUNK: usize = 256;
/// Random rays generated: at least this many, else one per pixel.
const MIN_RANDOM_RAYS: usize = 1 << 16;

/// Four rays of a 2×2 pixel quad (or four consecutive random rays) and which are real.
#[derive(Clone, Copy)]
struct Quad {
    rays: [Ray; 4],
    active: [bool; 4],
}

/// One query's work: the same rays as single rays and as quads, both split in chunks
/// (`single_chunks[i]` rays and `quad_chunks[i]` quads cover the same tile).
struct Work {
    singles: Vec<Ray>,
    quads: Vec<Quad>,
    single_chunk_ends: Vec<usize>,
    quad_chunk_ends: Vec<usize>,
}

impl Work {
    fn rays(&self) -> u64 {
        self.singles.len() as u64
    }

    fn chunks<'w, T: Sync>(
        items: &'w [T],
        ends: &'w [usize],
    ) -> impl IndexedParallelIterator<Item = &'w [T]> + 'w {
        ends.par_iter().enumerate().map(move |(i, &end)| {
            let start = if i == 0 { 0 } else { ends[i - 1] };
            &items[start..end]
        })
    }

    fn single_chunks(&self) -> impl IndexedParallelIterator<Item = &[Ray]> {
        Work::chunks(&self.singles, &self.single_chunk_ends)
    }

    fn quad_chunks(&self) -> impl IndexedParallelIterator<Item = &[Quad]> {
        Work::chunks(&self.quads, &self.quad_chunk_ends)
    }
}

/// SplitMix64 (Steele, Lea and Flood 2014): a fixed-seed generator for the ray buffers.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / 16_777_216.0)
    }
}

/// Camera rays in tiles of `TILE`² pixels; within a tile, 2×2 quads in row order and the
/// single rays in the same order. Lanes outside the film are inactive (their ray repeats
/// an active one so that nothing odd reaches Embree).
fn camera_work(input: &RayBenchInput) -> Work {
    let (w, h) = (input.width, input.height);
    let mut work = Work {
        singles: Vec::with_capacity(w as usize * h as usize),
        quads: Vec::with_capacity((w as usize).div_ceil(2) * (h as usize).div_ceil(2)),
        single_chunk_ends: vec![],
        quad_chunk_ends: vec![],
    };
    for ty in (0..h).step_by(TILE as usize) {
        for tx in (0..w).step_by(TILE as usize) {
            for y in (ty..(ty + TILE).min(h)).step_by(2) {
                for x in (tx..(tx + TILE).min(w)).step_by(2) {
                    let pixels = [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)];
                    let active = pixels.map(|(px, py)| px < w && py < h);
                    let rays = pixels.map(|(px, py)| {
                        let (px, py) = (px.min(w - 1), py.min(h - 1));
                        (input.camera_ray)(px as f32 + 0.5, py as f32 + 0.5)
                    });
                    for k in 0..4 {
                        if active[k] {
                            work.singles.push(rays[k]);
                        }
                    }
                    work.quads.push(Quad { rays, active });
                }
            }
            work.single_chunk_ends.push(work.singles.len());
            work.quad_chunk_ends.push(work.quads.len());
        }
    }
    work
}

/// Shadow rays from the camera hits of `camera` (found with `intersect1`, untimed) to points
/// on the lights, one point per 2×2 quad, in the same tiles and quads; a lane whose camera
/// ray missed is inactive.
/// The origin is pushed off the surface along the normal (towards the camera side) and the
/// segment stops short of the light point, both by `1e-4` of the scene's diagonal.
fn shadow_work(input: &RayBenchInput, camera: &Work) -> Work {
    let scene = input.accel;
    let eps = (1e-4 * (input.bounds.1 - input.bounds.0).length()).max(1e-6);
    let mut rng = SplitMix64(0x5eed_5ad0);
    let mut work = Work {
        singles: vec![],
        quads: Vec::with_capacity(camera.quads.len()),
        single_chunk_ends: vec![],
        quad_chunk_ends: vec![],
    };
    let mut start = 0;
    for &end in &camera.quad_chunk_ends {
        for q in &camera.quads[start..end] {
            let mut quad = *q;
            // One light point per quad, shared by its four lanes: the coherent case a packet
            // path tracer produces when a 2×2 pixel quad samples a light together.
            let target = (input.light_point)([rng.f32(), rng.f32(), rng.f32()]);
            for k in 0..4 {
                let shadow = if q.active[k] {
                    let r = &q.rays[k];
                    scene.intersect1(r).map(|hit| {
                        let p = r.org + hit.t * r.dir;
                        let mut n = hit.ng.normalize_or_zero();
                        if n.dot(r.dir) > 0.0 {
                            n = -n;
                        }
                        let org = p + eps * n;
                        let dir = target - org;
                        let len = dir.length();
                        Ray {
                            org,
                            dir,
                            tnear: 0.0,
                            tfar: if len > 2.0 * eps {
                                1.0 - eps / len
                            } else {
                                0.0
                            },
                        }
                    })
                } else {
                    None
                };
                match shadow {
                    Some(s) => {
                        quad.rays[k] = s;
                        quad.active[k] = true;
                        work.singles.push(s);
                    }
                    None => quad.active[k] = false,
                }
            }
            // Inactive lanes repeat an active ray (or keep the camera ray).
            if let Some(k0) = (0..4).find(|&k| quad.active[k]) {
                for k in 0..4 {
                    if !quad.active[k] {
                        quad.rays[k] = quad.rays[k0];
                    }
                }
                work.quads.push(quad);
            }
        }
        start = end;
        if work.quads.len() > work.quad_chunk_ends.last().copied().unwrap_or(0) {
            work.single_chunk_ends.push(work.singles.len());
            work.quad_chunk_ends.push(work.quads.len());
        }
    }
    work
}

/// `n` (a multiple of 4) random rays: origins uniform in the bounds, directions uniform on
/// the sphere; quads are four consecutive rays.
fn random_work(input: &RayBenchInput, n: usize) -> Work {
    let (lo, hi) = input.bounds;
    let mut rng = SplitMix64(0x0dd_ba11);
    let singles: Vec<Ray> = (0..n)
        .map(|_| {
            let org = lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let z = 1.0 - 2.0 * rng.f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * rng.f32();
            Ray::new(org, Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect();
    let quads: Vec<Quad> = singles
        .chunks_exact(4)
        .map(|c| Quad {
            rays: [c[0], c[1], c[2], c[3]],
            active: [true; 4],
        })
        .collect();
    let single_chunk_ends = (1..=n.div_ceil(RANDOM_CHUNK))
        .map(|i| (i * RANDOM_CHUNK).min(n))
        .collect();
    let quad_chunk_ends = (1..=n.div_ceil(RANDOM_CHUNK))
        .map(|i| (i * RANDOM_CHUNK / 4).min(n / 4))
        .collect();
    Work {
        singles,
        quads,
        single_chunk_ends,
        quad_chunk_ends,
    }
}

/// Which query a pass runs.
#[derive(Clone, Copy)]
enum Kind {
    Intersect(Coherence),
    Occluded(Coherence),
}

/// One pass of single-ray queries over `work` on the current pool; returns hits.
fn single_pass(scene: &Scene, work: &Work, kind: Kind) -> u64 {
    work.single_chunks()
        .map(|rays| {
            let mut hits = 0u64;
            match kind {
                Kind::Intersect(_) => {
                    for r in rays {
                        hits += scene.intersect1(black_box(r)).is_some() as u64;
                    }
                }
                Kind::Occluded(_) => {
                    for r in rays {
                        hits += scene.occluded1(black_box(r)) as u64;
                    }
                }
            }
            hits
        })
        .sum()
}

/// One pass of packet queries over `work` on the current pool; returns hits.
fn packet_pass(scene: &Scene, work: &Work, kind: Kind) -> u64 {
    work.quad_chunks()
        .map(|quads| {
            let mut hits = 0u64;
            let mut p = RayHit4::new();
            for q in quads {
                let q = black_box(q);
                for k in 0..4 {
                    p.set_ray(k, &q.rays[k]);
                }
                match kind {
                    Kind::Intersect(c) => {
                        scene.intersect4(&mut p, q.active, c);
                        for k in 0..4 {
                            hits += (q.active[k] && p.hit(k).is_some()) as u64;
                        }
                    }
                    Kind::Occluded(c) => {
                        scene.occluded4(&mut p, q.active, c);
                        for k in 0..4 {
                            hits += (q.active[k] && p.occluded(k)) as u64;
                        }
                    }
                }
            }
            hits
        })
        .sum()
}

/// Repeats `pass` (on `pool`) for at least `per_run`; returns Mrays/s of that run.
fn timed_run(
    pool: &ThreadPool,
    per_run: Duration,
    rays: u64,
    pass: &(dyn Fn() -> u64 + Sync),
) -> f64 {
    let start = Instant::now();
    let (mut traced, mut hits) = (0u64, 0u64);
    loop {
        hits = hits.wrapping_add(pool.install(pass));
        traced += rays;
        if start.elapsed() >= per_run {
            break;
        }
    }
    let secs = start.elapsed().as_secs_f64();
    black_box(hits);
    traced as f64 / secs / 1e6
}

/// Measures single and packet passes of one query on one pool, alternating runs; returns
/// (single, packet) Mrays/s medians.
fn measure(
    scene: &Scene,
    pool: &ThreadPool,
    work: &Work,
    single: Kind,
    packet: Kind,
    opts: &RayBenchOptions,
) -> (f64, f64) {
    if work.rays() == 0 {
        return (0.0, 0.0);
    }
    let reps = opts.repetitions.max(1);
    let per_run = opts.seconds / reps as f64;
    let per_run = Duration::from_secs_f64(if per_run > 0.0 { per_run.min(1e6) } else { 0.0 });
    let s = || single_pass(scene, work, single);
    let p = || packet_pass(scene, work, packet);
    // Warm-up (caches, page faults, lazily started threads), and a consistency check.
    let (hs, hp) = (pool.install(s), pool.install(p));
    if let (Kind::Intersect(Coherence::Incoherent), Kind::Intersect(Coherence::Incoherent)) =
        (single, packet)
    {
        debug_assert_eq!(hs, hp, "intersect1 and intersect4 disagree on random rays");
    }
    black_box((hs, hp));
    let (mut rs, mut rp) = (vec![], vec![]);
    for _ in 0..reps {
        rs.push(timed_run(pool, per_run, work.rays(), &s));
        rp.push(timed_run(pool, per_run, work.rays(), &p));
    }
    (median(&rs), median(&rp))
}

/// [`bench_rays`] on a loaded scene: its camera's rays, its lights' points, its bounds.
pub fn bench_scene(scene: &crate::scene::Scene, opts: &RayBenchOptions) -> RayBenchReport {
    let cam = &scene.camera;
    let lights = &scene.lights;
    let camera_ray = |x: f32, y: f32| cam.ray(x, y);
    let light_point = |u: [f32; 3]| lights.sample(u).map(|s| s.p).unwrap_or(Vec3::ZERO);
    let input = RayBenchInput {
        name: scene.name(),
        accel: &scene.accel,
        width: cam.width,
        height: cam.height,
        camera_ray: &camera_ray,
        light_point: &light_point,
        bounds: scene.bounds,
    };
    bench_rays(&input, opts)
}

/// Runs the benchmark: {camera, random, shadow} × {1 thread, all threads} × {single, packet}.
///
/// # Panics
/// If a rayon pool cannot be built.
pub fn bench_rays(input: &RayBenchInput, opts: &RayBenchOptions) -> RayBenchReport {
    let scene = input.accel;
    let pool1 = thread_pool(1).expect("cannot build a rayon pool of 1 thread");
    let pool_n = thread_pool(opts.threads).expect("cannot build a rayon pool");
    let pools = [&pool1, &pool_n];
    let mut results = Vec::with_capacity(12);
    let mut push = |query: &'static str, threads: usize, (s, p): (f64, f64)| {
        for (mode, mrays_per_s) in MODES.into_iter().zip([s, p]) {
            results.push(RayBenchResult {
                query,
                mode,
                threads,
                mrays_per_s,
            });
        }
    };

    let camera = camera_work(input);
    let shadow = shadow_work(input, &camera);
    let intersect_c = Kind::Intersect(Coherence::Coherent);
    for pool in pools {
        let m = measure(scene, pool, &camera, intersect_c, intersect_c, opts);
        push(QUERIES[0], pool.current_num_threads(), m);
    }
    drop(camera);

    let n_random = (input.width as usize * input.height as usize).max(MIN_RANDOM_RAYS) / 4 * 4;
    let random = random_work(input, n_random);
    let intersect_i = Kind::Intersect(Coherence::Incoherent);
    for pool in pools {
        let m = measure(scene, pool, &random, intersect_i, intersect_i, opts);
        push(QUERIES[1], pool.current_num_threads(), m);
    }
    drop(random);

    let occluded_c = Kind::Occluded(Coherence::Coherent);
    for pool in pools {
        let m = measure(scene, pool, &shadow, occluded_c, occluded_c, opts);
        push(QUERIES[2], pool.current_num_threads(), m);
    }

    RayBenchReport {
        scene: input.name.clone(),
        triangles: scene.triangle_count(),
        machine: Machine::detect(),
        results,
    }
}

/// A readable table of a report: Mrays/s per query for single rays and packets on one
/// thread and on all threads, with packet/single and all-threads/one-thread ratios.
pub fn format_table(report: &RayBenchReport) -> String {
    let get = |q: &str, m: &str, t: usize| {
        report
            .results
            .iter()
            .find(|r| r.query == q && r.mode == m && r.threads == t)
            .map(|r| r.mrays_per_s)
    };
    let t1 = report.results.iter().map(|r| r.threads).min().unwrap_or(1);
    let tn = report.results.iter().map(|r| r.threads).max().unwrap_or(1);
    let num = |x: Option<f64>| x.map_or_else(|| "-".to_string(), |x| format!("{x:.2}"));
    let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => format!("{:.2}x", a / b),
        _ => "-".to_string(),
    };
    let plural = |t: usize| if t == 1 { "thread" } else { "threads" };
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {} triangles, Mrays/s (median of the runs)",
        report.scene, report.triangles
    );
    let _ = writeln!(s, "{}", report.machine);
    let g1 = format!("{t1} {}", plural(t1));
    let gn = format!("{tn} {}", plural(tn));
    let gr = format!("{tn}T / {t1}T");
    let _ = writeln!(s, "{:<8} | {g1:^30} | {gn:^30} | {gr:^17}", "");
    let _ = writeln!(
        s,
        "{:<8} | {:>8} {:>8} {:>12} | {:>8} {:>8} {:>12} | {:>8} {:>8}",
        "query",
        "single",
        "packet",
        "packet/single",
        "single",
        "packet",
        "packet/single",
        "single",
        "packet"
    );
    let _ = writeln!(s, "{}", "-".repeat(8 + 3 + 30 + 3 + 30 + 3 + 17));
    for q in QUERIES {
        let (s1, p1) = (get(q, "single", t1), get(q, "packet", t1));
        let (sn, pn) = (get(q, "single", tn), get(q, "packet", tn));
        let _ = writeln!(
            s,
            "{:<8} | {:>8} {:>8} {:>12} | {:>8} {:>8} {:>12} | {:>8} {:>8}",
            q,
            num(s1),
            num(p1),
            ratio(p1, s1),
            num(sn),
            num(pn),
            ratio(pn, sn),
            ratio(sn, s1),
            ratio(pn, p1)
        );
    }
    let _ = writeln!(
        s,
        "camera/shadow packets: 2x2 pixel quads, coherent; random packets: incoherent"
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Device;

    /// A unit box on a floor, a square light above it.
    fn tiny_scene() -> Scene {
        let device = Device::new().unwrap();
        let mut b = device.scene_builder().unwrap();
        let v: Vec<[f32; 3]> = (0..8)
            .map(|i| {
                [
                    (i & 1) as f32 - 0.5,
                    ((i >> 1) & 1) as f32,
                    ((i >> 2) & 1) as f32 - 0.5,
                ]
            })
            .collect();
        let faces = [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ];
        let t: Vec<[u32; 3]> = faces
            .iter()
            .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
            .collect();
        b.attach_triangles(&v, &t).unwrap();
        let floor = [
            [-3.0, 0.0, -3.0],
            [3.0, 0.0, -3.0],
            [3.0, 0.0, 3.0],
            [-3.0, 0.0, 3.0],
        ];
        b.attach_triangles(&floor, &[[0, 2, 1], [0, 3, 2]]).unwrap();
        b.commit().unwrap()
    }

    #[test]
    fn bench_rays_reports_all_figures() {
        let scene = tiny_scene();
        let (w, h) = (33u32, 21u32); // odd sizes: quads with inactive lanes
        let camera_ray = move |x: f32, y: f32| {
            let tan = 0.5f32;
            let aspect = w as f32 / h as f32;
            let d = Vec3::new(
                (2.0 * x / w as f32 - 1.0) * tan * aspect,
                (1.0 - 2.0 * y / h as f32) * tan,
                1.0,
            );
            Ray::new(
                Vec3::new(0.0, 1.5, -5.0),
                (d - Vec3::new(0.0, 0.2, 0.0)).normalize(),
            )
        };
        let light_point = |u: [f32; 3]| Vec3::new(u[0] - 0.5, 3.0, u[1] - 0.5);
        let input = RayBenchInput {
            name: "tiny".into(),
            accel: &scene,
            width: w,
            height: h,
            camera_ray: &camera_ray,
            light_point: &light_point,
            bounds: (Vec3::new(-3.0, 0.0, -3.0), Vec3::new(3.0, 3.0, 3.0)),
        };
        let opts = RayBenchOptions {
            seconds: 0.004,
            threads: 2,
            repetitions: 3,
        };
        let report = bench_rays(&input, &opts);
        assert_eq!(report.scene, "tiny");
        assert_eq!(report.triangles, 14);
        assert_eq!(report.results.len(), 12);
        for q in QUERIES {
            for m in MODES {
                for t in [1, 2] {
                    let n = report
                        .results
                        .iter()
                        .filter(|r| r.query == q && r.mode == m && r.threads == t)
                        .inspect(|r| {
                            assert!(r.mrays_per_s.is_finite() && r.mrays_per_s > 0.0, "{r:?}")
                        })
                        .count();
                    assert_eq!(n, 1, "{q} {m} {t} threads");
                }
            }
        }
        let table = format_table(&report);
        for word in [
            "tiny",
            "camera",
            "random",
            "shadow",
            "packet/single",
            "2T / 1T",
        ] {
            assert!(table.contains(word), "{word} missing from\n{table}");
        }
        let json = serde_json::to_value(&report).unwrap();
        assert_eq!(json["results"].as_array().unwrap().len(), 12);
        assert_eq!(json["triangles"], 14);
        assert!(json["results"][0]["mrays_per_s"].as_f64().unwrap() > 0.0);
    }

    #[test]
    fn work_buffers_cover_the_film() {
        let scene = tiny_scene();
        // Parallel rays through a window around the box's front face.
        let camera_ray =
            |x: f32, y: f32| Ray::new(Vec3::new((x - 18.5) * 0.1, 2.0 - 0.1 * y, -5.0), Vec3::Z);
        let light_point = |_: [f32; 3]| Vec3::new(0.0, 3.0, 0.0);
        let input = RayBenchInput {
            name: "t".into(),
            accel: &scene,
            width: 37,
            height: 19,
            camera_ray: &camera_ray,
            light_point: &light_point,
            bounds: (Vec3::splat(-3.0), Vec3::splat(3.0)),
        };
        let cam = camera_work(&input);
        assert_eq!(cam.singles.len(), 37 * 19);
        let active: usize = cam
            .quads
            .iter()
            .map(|q| q.active.iter().filter(|&&a| a).count())
            .sum();
        assert_eq!(active, 37 * 19);
        // Every pixel centre exactly once.
        let mut seen: Vec<(u32, u32)> = cam
            .singles
            .iter()
            .map(|r| (r.org.x.to_bits(), r.org.y.to_bits()))
            .collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), 37 * 19);
        assert_eq!(cam.single_chunk_ends.last(), Some(&cam.singles.len()));
        assert_eq!(cam.quad_chunk_ends.last(), Some(&cam.quads.len()));
        // Chunks of singles and quads hold the same rays.
        let s: Vec<usize> = cam.single_chunks().map(|c| c.len()).collect();
        let q: Vec<usize> = cam
            .quad_chunks()
            .map(|c| {
                c.iter()
                    .map(|q| q.active.iter().filter(|&&a| a).count())
                    .sum()
            })
            .collect();
        assert_eq!(s, q);

        let sh = shadow_work(&input, &cam);
        let active: usize = sh
            .quads
            .iter()
            .map(|q| q.active.iter().filter(|&&a| a).count())
            .sum();
        assert_eq!(active, sh.singles.len());
        assert!(!sh.singles.is_empty() && sh.singles.len() < 37 * 19);
        let s: Vec<usize> = sh.single_chunks().map(|c| c.len()).collect();
        let q: Vec<usize> = sh
            .quad_chunks()
            .map(|c| {
                c.iter()
                    .map(|q| q.active.iter().filter(|&&a| a).count())
                    .sum()
            })
            .collect();
        assert_eq!(s, q);
        // Shadow rays start in front of the box's face (z = −0.5), towards the camera.
        for r in &sh.singles {
            assert!(r.tfar > 0.0 && r.tfar < 1.0);
            assert!(r.org.z < -0.5 && r.org.z > -0.51, "{r:?}");
        }

        let rnd = random_work(&input, 1000);
        assert_eq!(rnd.singles.len(), 1000);
        assert_eq!(rnd.quads.len(), 250);
        assert_eq!(rnd.single_chunk_ends, vec![256, 512, 768, 1000]);
        assert_eq!(rnd.quad_chunk_ends, vec![64, 128, 192, 250]);
    }
}
