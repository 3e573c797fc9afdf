//! The render driver: pixels in parallel, samples in passes, a film of per-pixel sums.
//!
//! Every pixel sample draws from its own random stream (seed, pixel, sample index), and a
//! pixel's samples are accumulated in order by one thread, so the image is the same
//! whatever the number of threads.

use super::{radiance, PathOptions, PathStats, Shifting, Spectral};
use crate::medium::tracking::Tracking;
use crate::color;
use crate::sampler::{LazyStream, Pcg32};
use crate::scene::Scene;
use crate::spectrum::{self, SampledWavelengths};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// What to render and how.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Seed of the random streams.
    pub seed: u64,
    /// Path segments from the camera, −1 for unbounded.
    pub max_depth: i32,
    /// Wavelength sampling.
    pub spectral: Spectral,
    /// Lane shifting at fluorescent vertices (HWSS).
    pub shifting: Shifting,
    /// Distance sampling in media (`None`: the scene's default, see
    /// [`Scene::default_tracking`]).
    pub tracking: Option<Tracking>,
    /// Worker threads (0 = one per core).
    pub threads: usize,
}

/// Per-pixel sums of linear sRGB samples: the mean and the variance of the mean.
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
}

impl Film {
    /// An empty film.
    pub fn new(width: u32, height: u32) -> Film {
        let n = (width * height) as usize;
        Film {
            width,
            height,
            spp: 0,
            sum: vec![[0.0; 3]; n],
            sum_sq: vec![[0.0; 3]; n],
        }
    }

    /// The pixel means (box filter: each sample counts for the pixel it fell in).
    pub fn mean(&self) -> Vec<[f32; 3]> {
        let n = self.spp.max(1) as f64;
        self.sum.iter().map(|s| s.map(|v| (v / n) as f32)).collect()
    }

    /// The estimated variance of each pixel mean: the sample variance over `spp`.
    pub fn variance_of_mean(&self) -> Vec<[f32; 3]> {
        let n = self.spp as f64;
        if n < 2.0 {
            return vec![[0.0; 3]; self.sum.len()];
        }
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| {
                std::array::from_fn(|c| {
                    let m = s[c] / n;
                    let var = ((q[c] - n * m * m) / (n - 1.0)).max(0.0);
                    (var / n) as f32
                })
            })
            .collect()
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

/// One pixel sample: linear sRGB, or `None` if the estimate is NaN or infinite.
#[inline]
pub fn pixel_sample(
    scene: &Scene,
    opts: &RenderOptions,
    x: u32,
    y: u32,
    sample: u32,
    stats: &mut PathStats,
) -> Option<Vec3> {
    let cam = &scene.camera;
    let pixel = (y as u64) * opts.width as u64 + x as u64;
    let mut rng = Pcg32::for_sample(opts.seed, pixel, sample as u64);
    let [jx, jy] = rng.next_2d();
    let ray = cam.ray(x as f32 + jx, y as f32 + jy);
    let u = rng.next_f32();
    let wl = match opts.spectral {
        Spectral::Hwss => SampledWavelengths::sample_hwss(u),
        Spectral::Mono => SampledWavelengths::sample_mono(u),
    };
    // The shift stream: a second, independent stream of the same pixel sample.
    let mut shift_rng = LazyStream::new(opts.seed, pixel, sample as u64);
    let path = PathOptions {
        spectral: opts.spectral,
        shifting: opts.shifting,
        tracking: opts.tracking.unwrap_or_else(|| scene.default_tracking().0),
        max_depth: opts.max_depth,
    };
    let l = radiance(scene, ray, wl.lambda, &path, &mut rng, &mut shift_rng, stats);
    let rgb = color::xyz_to_linear_srgb(spectrum::xyz_estimate(wl.lambda, l));
    if rgb.is_finite() {
        Some(rgb)
    } else {
        stats.nonfinite += 1;
        None
    }
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
    let w = opts.width as usize;
    let stats: PathStats = film
        .sum
        .par_chunks_mut(w)
        .zip(film.sum_sq.par_chunks_mut(w))
        .enumerate()
        .map(|(y, (sum, sq))| {
            let mut st = PathStats::default();
            for x in 0..w {
                for s in first..first + count {
                    if let Some(c) = pixel_sample(scene, opts, x as u32, y as u32, s, &mut st) {
                        let c = [c.x as f64, c.y as f64, c.z as f64];
                        for k in 0..3 {
                            sum[x][k] += c[k];
                            sq[x][k] += c[k] * c[k];
                        }
                    }
                }
            }
            on_row();
            st
        })
        .reduce(PathStats::default, |a, b| PathStats {
            rays: a.rays + b.rays,
            nonfinite: a.nonfinite + b.nonfinite,
        });
    film.spp += count;
    stats
}

/// Renders `opts.spp` samples per pixel on a pool of `opts.threads` threads. The scene's
/// camera must have the resolution of `opts` (see [`Scene::set_resolution`]).
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    on_row: &(dyn Fn() + Sync),
) -> Result<RenderResult, String> {
    if (scene.camera.width, scene.camera.height) != (opts.width, opts.height) {
        return Err(format!(
            "render options ask for {}x{} but the camera is {}x{}",
            opts.width, opts.height, scene.camera.width, scene.camera.height
        ));
    }
    let pool = crate::accel::thread_pool(opts.threads)
        .map_err(|e| format!("cannot start threads: {e}"))?;
    let mut film = Film::new(opts.width, opts.height);
    let start = Instant::now();
    let stats = pool.install(|| render_pass(scene, opts, &mut film, 0, opts.spp, on_row));
    Ok(RenderResult {
        film,
        stats,
        seconds: start.elapsed().as_secs_f64(),
    })
}
