//! `stokes reference`: a long render of a scene with the variance of every pixel mean
//! beside it, which `--resume` extends with more samples.
//!
//! A resumed reference draws the sample indices after the ones it holds
//! ([`crate::header::next_free_sample`]) and pools old and new samples weighted by spp, so
//! that it equals one reference of the total spp (up to float summation order). The
//! variance image is written first and the reference last: an interrupted pair of writes
//! leaves a variance that does not match the reference, which the next `--resume`
//! catches, rather than a reference with a stale variance.

use super::merge::{
    plane_names, pooled_variance, pooled_variance_planes, weighted_mean, weighted_mean_planes, Part,
};
use crate::error::Error;
use crate::header::{next_free_sample, normalise, RenderHeader, SampleRange};
use crate::integrator::render::{
    render_progressive, PassDone, Progressive, RenderOptions, Stopped,
};
use crate::output::{check_outputs, variance_path, write_exr_planes};
use crate::scene::Scene;
use crate::spectral_exr::layout_attributes;
use crate::Result;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// A reference to add samples to: its means and its variance image.
#[derive(Debug, Clone)]
pub struct Previous {
    /// The reference.
    pub mean: Part,
    /// Its variance image.
    pub variance: Part,
}

/// Reads the reference at `out` and its variance image to resume them, and checks that
/// they belong with a run whose header would be `run` at `size`. Errors are
/// [`Error::Option`]s of `--resume` (the cause names the file) and say how to go on.
pub fn read_previous(
    out: &Path,
    run: &RenderHeader,
    size: (u32, u32),
    channels: &[String],
) -> Result<Previous> {
    let o = out.display();
    let resume = |e: Error| Error::option("--resume", e);
    let unlike = |rest: String| Err(resume(Error::about(out, rest)));
    let mean = Part::read(out).map_err(resume)?;
    if (mean.width, mean.height) != size {
        return unlike(format!(
            "is {}x{} but this run renders {}x{}: resume at the reference's size (--res {}x{})",
            mean.width, mean.height, size.0, size.1, mean.width, mean.height
        ));
    }
    if plane_names(&mean.planes) != channels {
        let spectral = |n: usize| match n {
            0 => "no spectral channels".to_string(),
            n => format!("{n} spectral channels"),
        };
        return unlike(format!(
            "has {} but this run writes {}: resume with the reference's --spectral-bins and --spectral-range",
            spectral(mean.planes.len()),
            spectral(channels.len())
        ));
    }
    if mean.header.scene_hash != run.scene_hash {
        return unlike(format!(
            "is a reference of {}, but this scene file's hash is {}: the scene changed or is another one (remove {o} to start again)",
            mean.header.scene_label(),
            run.scene_hash
        ));
    }
    if let Some(m) = mean.header.mismatch(run) {
        return unlike(format!(
            "was rendered with {k} = {} but this run has {k} = {}: resume with the same settings",
            m.ours,
            m.theirs,
            k = m.key
        ));
    }
    let vp = variance_path(out);
    if !vp.exists() {
        return Err(resume(Error::about(
            vp,
            format!(
                "is missing: a reference keeps its variance beside it (remove {o} to start again)"
            ),
        )));
    }
    let variance = mean.read_variance("").map_err(resume)?;
    Ok(Previous { mean, variance })
}

/// The first sample index of a run of `spp` samples per pixel with `seed` after
/// `previous`, if it fits the 32-bit sample index.
pub fn first_new_sample(previous: Option<&Previous>, seed: u64, spp: u32) -> Result<u32> {
    let start = previous.map_or(0, |p| next_free_sample(&p.mean.header.ranges, seed));
    u32::try_from(start)
        .ok()
        .filter(|s| s.checked_add(spp).is_some())
        .ok_or_else(|| {
            Error::option(
                "--spp",
                format!("samples {start}..{start} + {spp} exceed the 32-bit sample index"),
            )
        })
}

/// A reference to render or resume.
pub struct Job<'a> {
    /// The scene, at the reference's resolution.
    pub scene: &'a Scene,
    /// Seed, depth, threads and method (`spp` is not used).
    pub opts: &'a RenderOptions,
    /// Samples per pixel to add.
    pub spp: u32,
    /// Samples per pixel per pass (at least 1; see `stokes render --pass-spp`): a stop
    /// lets the pass in flight finish.
    pub pass_spp: u32,
    /// The reference EXR; its variance goes beside it.
    pub out: &'a Path,
    /// Whether an existing reference is extended (else it is an error).
    pub resume: bool,
    /// Checked between passes: when set, the reference so far is written and the run ends.
    pub stop: Option<&'a AtomicBool>,
}

/// What a reference run did.
#[derive(Debug, Clone)]
pub struct Report {
    /// The header written: all the reference's samples.
    pub header: RenderHeader,
    /// Samples per pixel added by this run.
    pub added: u32,
    /// Seconds this run rendered.
    pub seconds: f64,
    /// Passes this run rendered.
    pub passes: u32,
    /// Why this run ended.
    pub stopped: Stopped,
    /// Samples of this run dropped as NaN or infinite.
    pub nonfinite: u64,
    /// The variance image.
    pub variance: PathBuf,
}

/// Renders (or, with `job.resume`, extends) a reference and writes it with its variance.
pub fn render(job: &Job, on_pass: &mut dyn FnMut(PassDone)) -> Result<Report> {
    let (scene, out) = (job.scene, job.out);
    let var_path = variance_path(out);
    check_outputs(&[("-o", out), ("-o", &var_path)])?;
    crate::output::check_exr_name("-o", out)?;
    let size = (scene.camera.width, scene.camera.height);
    let run_header = |ranges: Vec<SampleRange>, seconds: f64, stopped: Stopped| {
        RenderHeader::for_render(scene, job.opts, ranges, seconds, stopped)
    };
    let previous = if out.exists() {
        if !job.resume {
            return Err(Error::file(
                out,
                None,
                format!(
                    "the reference exists: pass --resume to add {} samples to it, or remove it (and {}) to start again",
                    job.spp,
                    var_path.display()
                ),
            ));
        }
        let this = run_header(Vec::new(), 0.0, Stopped::Complete);
        let channels = job.opts.bins.map_or(Vec::new(), |b| b.channel_names());
        Some(read_previous(out, &this, size, &channels)?)
    } else {
        None
    };
    let first_sample = first_new_sample(previous.as_ref(), job.opts.seed, job.spp)?;
    let prog = Progressive {
        first_sample,
        max_spp: Some(job.spp),
        batch: job.pass_spp,
        stop: job.stop,
        ..Default::default()
    };
    let done = render_progressive(scene, job.opts, &prog, &|| {}, on_pass)?;
    let film = &done.render.film;
    let range = SampleRange {
        seed: job.opts.seed,
        start: first_sample as u64,
        end: first_sample as u64 + film.spp as u64,
    };
    let mut header = run_header(vec![range], done.render.seconds, done.stopped);
    header.nonfinite_samples = done.render.stats.nonfinite;
    let (mean, var, planes, var_planes) = match previous {
        None => (
            film.mean(),
            film.variance_of_mean(),
            film.spectral_mean(),
            film.spectral_variance_of_mean(),
        ),
        Some(prev) => {
            let new = Part {
                path: out.to_path_buf(),
                width: size.0,
                height: size.1,
                pixels: film.mean(),
                planes: film.spectral_mean(),
                header: header.clone(),
            };
            header.ranges = normalise([prev.mean.header.ranges.clone(), vec![range]].concat());
            header.render_seconds += prev.mean.header.render_seconds;
            header.nonfinite_samples += prev.mean.header.nonfinite_samples;
            let parts = [prev.mean, new];
            let mean = weighted_mean(&parts);
            let var = pooled_variance(
                &parts,
                &[prev.variance.pixels, film.variance_of_mean()],
                &mean,
            );
            let planes = weighted_mean_planes(&parts);
            let var_planes = pooled_variance_planes(
                &parts,
                &[prev.variance.planes, film.spectral_variance_of_mean()],
                &planes,
            );
            (mean, var, planes, var_planes)
        }
    };
    let meta = header.attributes();
    let (w, h) = size;
    // The variance first: see the module documentation.
    let layout = layout_attributes(&planes, true);
    write_exr_planes(&var_path, w, h, &var, &var_planes, &meta, layout)?;
    let layout = layout_attributes(&planes, false);
    write_exr_planes(out, w, h, &mean, &planes, &meta, layout)?;
    Ok(Report {
        header,
        added: film.spp,
        seconds: done.render.seconds,
        passes: done.passes,
        stopped: done.stopped,
        nonfinite: done.render.stats.nonfinite,
        variance: var_path,
    })
}
