//! The render driver: pixels in parallel, samples in passes, a film of per-pixel sums.
//!
//! Every pixel sample draws from its own random stream (seed, pixel, sample index), and a
//! pixel's samples are accumulated in order by one thread, so the image is the same
//! whatever the number of threads.

use super::trace::{RayLog, SampleId, Tracer, Width};
use super::{PathOptions, PathStats};
use crate::error::{Detail, Error};
use crate::method::{Layout, Method, Rays};
use crate::output::Plane;
use crate::scene::RenderDesc;
use crate::scene::Scene;
use crate::simd::{F4, F8};
use crate::spectral_exr::Bins;
use crate::spectrum::{RgbWeights, SampledWavelengths, Wavelengths};
use crate::Result;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// What to render and how. The image size is the scene camera's
/// ([`Scene::set_resolution`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Samples per pixel.
    pub spp: u32,
    /// Seed of the random streams.
    pub seed: u64,
    /// Path segments from the camera, −1 for unbounded.
    pub max_depth: i32,
    /// Worker threads (0 = one per core).
    pub threads: usize,
    /// The method; its tracking, if left open, is the scene's default.
    pub method: Method,
    /// Which pixel samples share a packet (packet modes; the image does not depend on it).
    pub layout: Layout,
    /// Wavelength bins to accumulate beside RGB (`--spectral-bins`), if any.
    pub bins: Option<Bins>,
}

impl Default for RenderOptions {
    /// The scene file's defaults (16 spp, seed 0, unbounded depth), one thread per core,
    /// the default method.
    fn default() -> RenderOptions {
        let d = RenderDesc::default();
        RenderOptions {
            spp: d.spp,
            seed: d.seed,
            max_depth: d.max_depth,
            threads: 0,
            method: Method::default(),
            layout: Layout::default(),
            bins: None,
        }
    }
}

impl RenderOptions {
    /// The scene file's `[render]` defaults with the default method.
    pub fn for_scene(scene: &Scene) -> RenderOptions {
        RenderOptions {
            spp: scene.render.spp,
            seed: scene.render.seed,
            max_depth: scene.render.max_depth,
            ..RenderOptions::default()
        }
    }

    /// Checks the values a render cannot take; the error is an [`Error::Option`] of the
    /// setting's command-line option.
    pub fn validate(&self) -> Result<()> {
        if self.max_depth == 0 || self.max_depth < -1 {
            return Err(Error::option(
                "--max-depth",
                Detail::Expected {
                    expected: "−1 or a depth ≥ 1".into(),
                    found: self.max_depth.to_string(),
                },
            ));
        }
        Ok(())
    }

    /// The estimator these options select, with the scene's default tracking resolved
    /// (once per render, not per sample).
    pub fn path_options(&self, scene: &Scene) -> PathOptions {
        PathOptions {
            method: self.method.resolve(scene),
            max_depth: self.max_depth,
        }
    }
}

/// Per-pixel sums of linear sRGB samples and, for a spectral film, of binned spectral
/// radiance: the mean and the variance of the mean of each.
#[derive(Debug, Clone)]
pub struct Film {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Samples accumulated per pixel.
    pub spp: u32,
    sum: Vec<[f64; 3]>,
    sum_sq: Vec<[f64; 3]>,
    spectral: Option<SpectralSums>,
}

/// A spectral film's per-pixel, per-bin sums, pixel-major (`pixel · bins + bin`).
#[derive(Debug, Clone)]
struct SpectralSums {
    bins: Bins,
    sum: Vec<f64>,
    sum_sq: Vec<f64>,
}

/// `n` zeros, or `None` if their memory cannot be had.
fn zeros<T: Clone + Default>(n: usize) -> Option<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).ok()?;
    v.resize(n, T::default());
    Some(v)
}

impl Film {
    /// An empty RGB film.
    pub fn new(width: u32, height: u32) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            spp: 0,
            sum: vec![[0.0; 3]; n],
            sum_sq: vec![[0.0; 3]; n],
            spectral: None,
        }
    }

    /// An empty RGB film, or an error naming the size if its memory cannot be had.
    pub fn try_new(width: u32, height: u32) -> Result<Film> {
        Film::try_with_bins(width, height, None)
    }

    /// An empty film that also accumulates `bins`, or an error naming the size if its
    /// memory cannot be had.
    pub fn try_with_bins(width: u32, height: u32, bins: Option<Bins>) -> Result<Film> {
        let n = width as usize * height as usize;
        let channels = 3 + bins.map_or(0, |b| b.count as usize);
        let fail = || {
            Error::Other(format!(
                "cannot allocate a film of {width}x{height} pixels and {channels} channels ({:.1} GB)",
                n as f64 * channels as f64 * 16.0 / 1e9
            ))
        };
        let spectral = match bins {
            Some(bins) => {
                let m = n * bins.count as usize;
                Some(SpectralSums {
                    bins,
                    sum: zeros(m).ok_or_else(fail)?,
                    sum_sq: zeros(m).ok_or_else(fail)?,
                })
            }
            None => None,
        };
        Ok(Film {
            width,
            height,
            spp: 0,
            sum: zeros(n).ok_or_else(fail)?,
            sum_sq: zeros(n).ok_or_else(fail)?,
            spectral,
        })
    }

    /// The wavelength bins this film accumulates, if it is spectral.
    pub fn bins(&self) -> Option<Bins> {
        self.spectral.as_ref().map(|s| s.bins)
    }

    /// The pixel means (box filter: each sample counts for the pixel it fell in).
    pub fn mean(&self) -> Vec<[f32; 3]> {
        let n = self.spp.max(1) as f64;
        self.sum.iter().map(|s| s.map(|v| (v / n) as f32)).collect()
    }

    /// The estimated variance of each pixel mean: the sample variance over `spp`.
    pub fn variance_of_mean(&self) -> Vec<[f32; 3]> {
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| std::array::from_fn(|c| variance_of_mean(s[c], q[c], self.spp)))
            .collect()
    }

    /// The bin-averaged spectral radiance of every pixel, one plane per bin named as the
    /// spectral layout names it; empty for an RGB film.
    pub fn spectral_mean(&self) -> Vec<Plane> {
        let n = self.spp.max(1) as f64;
        self.spectral_planes(|s, _| (s / n) as f32)
    }

    /// The variance of each pixel's bin means, planes as in [`Film::spectral_mean`].
    pub fn spectral_variance_of_mean(&self) -> Vec<Plane> {
        self.spectral_planes(|s, q| variance_of_mean(s, q, self.spp))
    }

    /// One plane per bin of `value(sum, sum of squares)`.
    fn spectral_planes(&self, value: impl Fn(f64, f64) -> f32) -> Vec<Plane> {
        let Some(s) = &self.spectral else {
            return Vec::new();
        };
        let nb = s.bins.count as usize;
        s.bins
            .channel_names()
            .into_iter()
            .enumerate()
            .map(|(b, name)| Plane {
                name,
                data: (0..self.sum.len())
                    .map(|i| value(s.sum[i * nb + b], s.sum_sq[i * nb + b]))
                    .collect(),
            })
            .collect()
    }

    /// The film's rows in groups of `rows`, each with its RGB and spectral sums.
    fn row_groups(&mut self, rows: usize) -> Vec<RowSums<'_>> {
        let px = rows * self.width as usize;
        let rgb = self.sum.chunks_mut(px).zip(self.sum_sq.chunks_mut(px));
        match &mut self.spectral {
            Some(s) => {
                let (bins, k) = (s.bins, px * s.bins.count as usize);
                rgb.zip(s.sum.chunks_mut(k).zip(s.sum_sq.chunks_mut(k)))
                    .map(|((sum, sq), (ssum, ssq))| RowSums {
                        sum,
                        sq,
                        bins: Some(bins),
                        spectral_sum: ssum,
                        spectral_sq: ssq,
                    })
                    .collect()
            }
            None => rgb
                .map(|(sum, sq)| RowSums {
                    sum,
                    sq,
                    bins: None,
                    spectral_sum: &mut [],
                    spectral_sq: &mut [],
                })
                .collect(),
        }
    }
}

/// The variance of a mean of `n` samples from their sum and sum of squares.
fn variance_of_mean(sum: f64, sum_sq: f64, n: u32) -> f32 {
    let n = n as f64;
    if n < 2.0 {
        return 0.0;
    }
    let m = sum / n;
    let var = ((sum_sq - n * m * m) / (n - 1.0)).max(0.0);
    (var / n) as f32
}

/// A group of rows' sums, handed to one rayon job.
struct RowSums<'a> {
    sum: &'a mut [[f64; 3]],
    sq: &'a mut [[f64; 3]],
    bins: Option<Bins>,
    spectral_sum: &'a mut [f64],
    spectral_sq: &'a mut [f64],
}

impl RowSums<'_> {
    /// Adds pixel `i`'s sample: its colour `c` and, if spectral, each lane's radiance
    /// `l` at `lambda` (drawn with pdf `w`) to the bin holding that wavelength.
    #[inline]
    fn add(&mut self, i: usize, c: Vec3, w: Wavelengths, lambda: Vec4, l: Vec4) {
        accumulate(&mut self.sum[i], &mut self.sq[i], c);
        if let Some(bins) = self.bins {
            let l = w.film_weight(lambda).map_or(l, |v| l * v);
            let nb = bins.count as usize;
            let range = i * nb..(i + 1) * nb;
            accumulate_bins(
                &bins,
                lambda,
                l,
                &mut self.spectral_sum[range.clone()],
                &mut self.spectral_sq[range],
            );
        }
    }
}

/// Adds one pixel sample to its bin sums. Lane k's value `l_k` already carries its MIS
/// weight (lanes that were dropped or not traced carry 0 and add nothing), so its estimate
/// of the bin-averaged radiance is `l_k / (p(λ_k) · width)` in the bin holding `λ_k`.
/// Lanes that share a bin are summed before squaring: the variance is that of the pixel
/// sample's estimate, as for RGB.
#[inline]
fn accumulate_bins(bins: &Bins, lambda: Vec4, l: Vec4, sum: &mut [f64], sq: &mut [f64]) {
    let scale = 1.0 / (SampledWavelengths::pdf() as f64 * bins.width() as f64);
    let mut hit: [(usize, f64); 4] = [(usize::MAX, 0.0); 4];
    let mut used = 0;
    for (lk, vk) in lambda.to_array().into_iter().zip(l.to_array()) {
        if vk == 0.0 {
            continue;
        }
        let Some(b) = bins.index(lk) else { continue };
        let v = vk as f64 * scale;
        match hit[..used].iter_mut().find(|h| h.0 == b) {
            Some(h) => h.1 += v,
            None => {
                hit[used] = (b, v);
                used += 1;
            }
        }
    }
    for &(b, v) in &hit[..used] {
        sum[b] += v;
        sq[b] += v * v;
    }
}

/// A finished render.
pub struct RenderResult {
    /// The accumulated film.
    pub film: Film,
    /// Ray and sample counters.
    pub stats: PathStats,
    /// Wall-clock seconds spent rendering.
    pub seconds: f64,
}

/// A pixel sample's linear sRGB, or `None` (counted) if it is NaN or infinite.
#[inline]
fn finish_sample(rgb: Vec3, poison: bool, stats: &mut PathStats) -> Option<Vec3> {
    let rgb = if poison { Vec3::NAN } else { rgb };
    if rgb.is_finite() {
        Some(rgb)
    } else {
        stats.nonfinite += 1;
        None
    }
}

/// Whether the test hook poisons sample `sample` of pixel `pixel`: the samples are numbered
/// pass-major (`sample · width · height + pixel`) and every `every`-th one, counting from 1,
/// is made NaN.
#[inline]
fn poisoned(every: Option<u64>, pixels: u64, pixel: u64, sample: u32) -> bool {
    match every {
        None => false,
        Some(n) => (sample as u64 * pixels + pixel + 1).is_multiple_of(n.max(1)),
    }
}

/// How many samples [`poisoned`] hits among samples `[first, first + count)` of every
/// pixel of a `pixels`-pixel image.
pub fn poisoned_count(every: u64, pixels: u64, first: u32, count: u32) -> u64 {
    let n = every.max(1);
    let end = (first as u64 + count as u64) * pixels;
    end / n - (first as u64 * pixels) / n
}

/// Adds samples `[first, first + count)` of every pixel to `film`. A non-finite sample
/// is dropped and counted, and still counts towards `spp` (it is a zero sample: keeping
/// the denominator fixed keeps the estimator unbiased whenever such samples have zero
/// expected value — and they are reported either way).
pub fn render_pass(
    scene: &Scene,
    opts: &RenderOptions,
    film: &mut Film,
    first: u32,
    count: u32,
    on_row: &(dyn Fn() + Sync),
) -> PathStats {
    render_pass_with(scene, opts, film, first, count, None, on_row)
}

/// [`render_pass`] with the non-finite test hook (see [`Progressive`]).
fn render_pass_with(
    scene: &Scene,
    opts: &RenderOptions,
    film: &mut Film,
    first: u32,
    count: u32,
    inject_nonfinite_every: Option<u64>,
    on_row: &(dyn Fn() + Sync),
) -> PathStats {
    let path = opts.path_options(scene);
    // Scenes without media get a path loop with the medium code compiled out.
    let pass = match (opts.method.rays, scene.has_media()) {
        (Rays::Single, false) => pass::<f32, false>,
        (Rays::Single, true) => pass::<f32, true>,
        (Rays::Packet | Rays::Lockstep, false) => pass::<F4, false>,
        (Rays::Packet | Rays::Lockstep, true) => pass::<F4, true>,
        (Rays::Packet8, false) => pass::<F8, false>,
        (Rays::Packet8, true) => pass::<F8, true>,
    };
    let job = Job {
        scene,
        opts,
        path: &path,
        first,
        count,
        inject_nonfinite_every,
    };
    let stats = pass(&job, film, on_row);
    film.spp += count;
    stats
}

/// Adds `c` to a pixel's sums.
#[inline]
fn accumulate(sum: &mut [f64; 3], sq: &mut [f64; 3], c: Vec3) {
    let c = [c.x as f64, c.y as f64, c.z as f64];
    for k in 0..3 {
        sum[k] += c[k];
        sq[k] += c[k] * c[k];
    }
}

/// Sums two threads' counters.
fn add_stats(mut a: PathStats, b: PathStats) -> PathStats {
    a.add(&b);
    a
}

/// What a pass renders: samples `[first, first + count)` of every pixel.
struct Job<'a> {
    scene: &'a Scene,
    opts: &'a RenderOptions,
    path: &'a PathOptions,
    first: u32,
    count: u32,
    inject_nonfinite_every: Option<u64>,
}

/// Rows per rayon job.
const ROWS: usize = 2;

/// Samples per pixel a tracer runs at once (bounds the result buffers).
const CHUNK: u32 = 16;

/// The order in which the pixel samples of `rows` rows from `y0`, samples `[s0, s0 + n)`,
/// meet the lanes; sample k of local pixel i goes to slot i·n + k.
fn samples(layout: Layout, w: usize, rows: usize, y0: usize, s0: u32, n: u32) -> Vec<SampleId> {
    let id = |x: usize, ly: usize, k: u32| SampleId {
        x: x as u32,
        y: (y0 + ly) as u32,
        index: s0 + k,
        slot: (ly * w + x) as u32 * n + k,
    };
    let mut out = Vec::with_capacity(w * rows * n as usize);
    match layout {
        Layout::Quad => {
            for k in 0..n {
                for qx in 0..w.div_ceil(2) {
                    for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                        let x = 2 * qx + dx;
                        if x < w && dy < rows {
                            out.push(id(x, dy, k));
                        }
                    }
                }
            }
        }
        Layout::Pixel => {
            for ly in 0..rows {
                for x in 0..w {
                    out.extend((0..n).map(|k| id(x, ly, k)));
                }
            }
        }
    }
    out
}

/// A pass at lane width `F`: pairs of rows in parallel; in each, the pixel samples go
/// through one [`Tracer`] in the order of the layout, and each pixel's samples are added
/// to the film in sample order afterwards, so the film depends neither on the thread
/// count nor on the width.
fn pass<F: Width, const MEDIA: bool>(
    job: &Job,
    film: &mut Film,
    on_row: &(dyn Fn() + Sync),
) -> PathStats {
    let (scene, opts) = (job.scene, job.opts);
    let (w, pixels) = (scene.camera.width as usize, scene.camera.pixel_count());
    let wavelengths = job.path.method.wavelengths;
    let rgb_weights = RgbWeights::of(wavelengths);
    film.row_groups(ROWS)
        .into_par_iter()
        .enumerate()
        // One tracer and its buffers per rayon job, reused over its rows.
        .map_init(
            || {
                let mut tracer = Tracer::<F>::default();
                tracer.lockstep = opts.method.rays == Rays::Lockstep;
                (tracer, Vec::new(), Vec::new())
            },
            |(tracer, results, lambdas), (chunk, mut sums)| {
                let mut st = PathStats::default();
                let rows = sums.sum.len() / w;
                let y0 = chunk * ROWS;
                let mut done = 0;
                while done < job.count {
                    let n = CHUNK.min(job.count - done);
                    let s0 = job.first + done;
                    results.clear();
                    results.resize(rows * w * n as usize, Vec4::ZERO);
                    lambdas.resize(results.len(), Vec4::ZERO);
                    let work = samples(opts.layout, w, rows, y0, s0, n);
                    let mut work = work.into_iter();
                    tracer.run::<MEDIA>(
                        scene, job.path, opts.seed, &mut work, results, lambdas, &mut st,
                    );
                    for i in 0..rows * w {
                        let pixel = (y0 * w + i) as u64;
                        for k in 0..n {
                            let slot = i * n as usize + k as usize;
                            let poison =
                                poisoned(job.inject_nonfinite_every, pixels, pixel, s0 + k);
                            let (lambda, l) = (lambdas[slot], results[slot]);
                            let rgb = rgb_weights.rgb(lambda, l);
                            if let Some(c) = finish_sample(rgb, poison, &mut st) {
                                sums.add(i, c, wavelengths, lambda, l);
                            }
                        }
                    }
                    done += n;
                }
                st.lanes_used += std::mem::take(&mut tracer.lanes_used);
                st.lanes_total += std::mem::take(&mut tracer.lanes_total);
                st.medium_lanes_used += std::mem::take(&mut tracer.medium_lanes_used);
                st.medium_lanes_total += std::mem::take(&mut tracer.medium_lanes_total);
                st.camera_lanes_used += std::mem::take(&mut tracer.camera_lanes_used);
                st.camera_lanes_total += std::mem::take(&mut tracer.camera_lanes_total);
                for _ in 0..rows {
                    on_row();
                }
                st
            },
        )
        .reduce(PathStats::default, add_stats)
}

/// Every ray a render of samples `[first, first + count)` traces, as `render` would trace
/// them with `opts` (the same rays in the same packets, on one thread).
pub fn trace_rays(scene: &Scene, opts: &RenderOptions, first: u32, count: u32) -> RayLog {
    let path = opts.path_options(scene);
    match (opts.method.rays, scene.has_media()) {
        (Rays::Single, false) => log_rays::<f32, false>(scene, opts, &path, first, count),
        (Rays::Single, true) => log_rays::<f32, true>(scene, opts, &path, first, count),
        (Rays::Packet | Rays::Lockstep, false) => {
            log_rays::<F4, false>(scene, opts, &path, first, count)
        }
        (Rays::Packet | Rays::Lockstep, true) => {
            log_rays::<F4, true>(scene, opts, &path, first, count)
        }
        (Rays::Packet8, false) => log_rays::<F8, false>(scene, opts, &path, first, count),
        (Rays::Packet8, true) => log_rays::<F8, true>(scene, opts, &path, first, count),
    }
}

/// [`trace_rays`] at width `F`.
fn log_rays<F: Width, const MEDIA: bool>(
    scene: &Scene,
    opts: &RenderOptions,
    path: &PathOptions,
    first: u32,
    count: u32,
) -> RayLog {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let mut tracer = Tracer::<F>::default();
    tracer.lockstep = opts.method.rays == Rays::Lockstep;
    tracer.log = Some(Box::default());
    let mut stats = PathStats::default();
    let (mut results, mut lambdas) = (Vec::new(), Vec::new());
    for y0 in (0..h).step_by(ROWS) {
        let rows = ROWS.min(h - y0);
        let mut done = 0;
        while done < count {
            let n = CHUNK.min(count - done);
            results.clear();
            results.resize(rows * w * n as usize, Vec4::ZERO);
            lambdas.resize(results.len(), Vec4::ZERO);
            let mut work = samples(opts.layout, w, rows, y0, first + done, n).into_iter();
            tracer.run::<MEDIA>(
                scene,
                path,
                opts.seed,
                &mut work,
                &mut results,
                &mut lambdas,
                &mut stats,
            );
            done += n;
        }
    }
    *tracer.log.take().unwrap_or_default()
}

/// Renders `opts.spp` samples per pixel on a pool of `opts.threads` threads, at the
/// scene camera's resolution.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    on_row: &(dyn Fn() + Sync),
) -> Result<RenderResult> {
    opts.validate()?;
    let pool = thread_pool(opts.threads)?;
    let mut film = Film::try_with_bins(scene.camera.width, scene.camera.height, opts.bins)?;
    let start = Instant::now();
    let stats = pool.install(|| render_pass(scene, opts, &mut film, 0, opts.spp, on_row));
    Ok(RenderResult {
        film,
        stats,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// How a progressive render proceeds: passes of `batch` samples per pixel, from sample
/// `first_sample` on, until `max_spp` samples, the time budget or a stop request.
#[derive(Debug, Clone, Default)]
pub struct Progressive<'a> {
    /// The first sample index drawn (the seed offset): a render of n samples per pixel
    /// draws samples `[first_sample, first_sample + n)` of every pixel's streams.
    pub first_sample: u32,
    /// At most this many samples per pixel (`None`: until the budget or a stop).
    pub max_spp: Option<u32>,
    /// Wall-clock seconds: a pass starts only if, at the mean pass time so far, it ends
    /// within the budget. The first pass always runs.
    pub time_budget: Option<f64>,
    /// Samples per pixel per pass (at least 1).
    pub batch: u32,
    /// Checked between passes: when set, the render stops after the pass in flight.
    pub stop: Option<&'a AtomicBool>,
    /// Test hook: every n-th sample (numbered pass-major, see [`poisoned_count`]) is made
    /// NaN inside the pixel sample, before the finiteness check.
    #[doc(hidden)]
    pub inject_nonfinite_every: Option<u64>,
}

/// Why a progressive render ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stopped {
    /// All `max_spp` samples were rendered.
    Complete,
    /// The time budget was spent.
    TimeBudget,
    /// A stop was requested (Ctrl-C).
    Interrupted,
}

impl Stopped {
    const ALL: [Stopped; 3] = [Stopped::Complete, Stopped::TimeBudget, Stopped::Interrupted];

    /// A short name for headers and statistics.
    pub fn name(self) -> &'static str {
        match self {
            Stopped::Complete => "complete",
            Stopped::TimeBudget => "time budget",
            Stopped::Interrupted => "interrupted",
        }
    }

    /// The value called `name` ([`Stopped::name`]), if any.
    pub fn from_name(name: &str) -> Option<Stopped> {
        Stopped::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// One finished pass, as reported to the caller.
#[derive(Debug, Clone, Copy)]
pub struct PassDone {
    /// Passes finished so far (1 for the first).
    pub passes: u32,
    /// Samples per pixel accumulated so far.
    pub spp: u32,
    /// Seconds since the render started.
    pub seconds: f64,
}

/// A finished progressive render.
pub struct ProgressiveResult {
    /// The film, statistics and seconds.
    pub render: RenderResult,
    /// Passes run.
    pub passes: u32,
    /// Why it ended.
    pub stopped: Stopped,
}

/// How many samples per pixel a render starting at sample index `first` may draw:
/// `max_spp`, or as many as the 32-bit sample index allows; an error if that is none or
/// `max_spp` overflows the index.
pub fn sample_count(first: u32, max_spp: Option<u32>) -> Result<u32> {
    let room = u32::MAX - first;
    let n = max_spp.unwrap_or(room);
    if n == 0 || n > room {
        return Err(Error::Other(format!(
            "samples [{first}, {first} + {n}) do not fit the 32-bit sample index"
        )));
    }
    Ok(n)
}

/// A pool of `threads` render threads (0 = one per core).
fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    crate::accel::thread_pool(threads)
        .map_err(|e| Error::Other(format!("cannot start threads: {e}")))
}

/// Renders passes of `prog.batch` samples per pixel (samples `first_sample`, … in order,
/// so the film equals that of one [`render_pass`] over the same range) until
/// `prog.max_spp`, the time budget or `prog.stop`. `opts.spp` is not used. `on_pass` is
/// called after every pass.
pub fn render_progressive(
    scene: &Scene,
    opts: &RenderOptions,
    prog: &Progressive,
    on_row: &(dyn Fn() + Sync),
    on_pass: &mut dyn FnMut(PassDone),
) -> Result<ProgressiveResult> {
    opts.validate()?;
    if prog.max_spp.is_none() && prog.time_budget.is_none() {
        return Err(Error::Other(
            "a progressive render needs a sample count or a time budget".into(),
        ));
    }
    if let Some(t) = prog.time_budget {
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::Other(format!(
                "expected a positive time budget, found {t}"
            )));
        }
    }
    let max_spp = sample_count(prog.first_sample, prog.max_spp)?;
    let batch = prog.batch.max(1);
    let pool = thread_pool(opts.threads)?;
    let mut film = Film::try_with_bins(scene.camera.width, scene.camera.height, opts.bins)?;
    let mut stats = PathStats::default();
    let mut passes = 0u32;
    let start = Instant::now();
    let stopped = loop {
        if film.spp >= max_spp {
            break Stopped::Complete;
        }
        if passes > 0 {
            if prog.stop.is_some_and(|s| s.load(Ordering::SeqCst)) {
                break Stopped::Interrupted;
            }
            if let Some(budget) = prog.time_budget {
                let elapsed = start.elapsed().as_secs_f64();
                if elapsed + elapsed / passes as f64 > budget {
                    break Stopped::TimeBudget;
                }
            }
        }
        let count = batch.min(max_spp - film.spp);
        let first = prog.first_sample + film.spp;
        let st = pool.install(|| {
            render_pass_with(
                scene,
                opts,
                &mut film,
                first,
                count,
                prog.inject_nonfinite_every,
                on_row,
            )
        });
        stats.add(&st);
        passes += 1;
        on_pass(PassDone {
            passes,
            spp: film.spp,
            seconds: start.elapsed().as_secs_f64(),
        });
    };
    Ok(ProgressiveResult {
        render: RenderResult {
            film,
            stats,
            seconds: start.elapsed().as_secs_f64(),
        },
        passes,
        stopped,
    })
}
