//! Convergence measurements (`stokes converge`): which methods to compare, progressive
//! renders of one sample per pixel per pass with the error against a reference recorded
//! at log-spaced checkpoints, log–log slope fits and the CSV.
//!
//! **Method names.** A method is one choice on each of five axes, written as its values
//! joined by `-` in this order:
//!
//! | axis | values |
//! | --- | --- |
//! | spectral | `hwss`, `mono` |
//! | shifting | `independent`, `constant` |
//! | tracking | `classic`, `max`, `fluo-aware` |
//! | rays | `single`, `packet` (any value `--rays` takes) |
//! | dispersion | `drop`, `split` |
//!
//! for example `hwss-independent-fluo-aware-packet-drop`. Every value belongs to one axis,
//! so a name given on the command line may list any of them, in any order, and leave
//! axes out (`mono-packet`, `hwss-constant-max`): those take the defaults (the method
//! flags, else `hwss`, `independent`, the scene's default tracking, `single`, `drop`).
//!
//! **Errors.** At a checkpoint, with `x` the image and `r` the reference over the pixels
//! `P` of a region and the three channels: `rmse = √(mean (x − r)²)` and
//! `relmse = mean (x − r)² / (r² + 0.01)`.
//!
//! **CSV** (`convergence.csv`): one row per checkpoint and region, with the columns
//! [`CSV_HEADER`]; region `image` is the whole image.

use crate::integrator::render::{render_pass, Film, RenderOptions};
use crate::integrator::{Dispersion, Rays, Shifting, Spectral};
use crate::medium::tracking::Tracking;
use crate::scene::Scene;
use std::fmt::Write as _;
use std::time::Instant;

/// The columns of `convergence.csv`.
pub const CSV_HEADER: &str =
    "method,spectral,shifting,tracking,rays,dispersion,pass,spp,seconds,region,rmse,relmse";

/// One rendering method: a value on each axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Method {
    /// Wavelength sampling.
    pub spectral: Spectral,
    /// Lane shifting at fluorescent vertices.
    pub shifting: Shifting,
    /// Distance sampling in media (resolved: never the scene default).
    pub tracking: Tracking,
    /// Single rays or packets.
    pub rays: Rays,
    /// Dispersive refraction.
    pub dispersion: Dispersion,
}

/// The command-line names of an axis' values, each with its [`Value`].
fn named<T: clap::ValueEnum>(wrap: fn(T) -> Value) -> Vec<(String, Value)> {
    T::value_variants()
        .iter()
        .filter_map(|v| {
            Some((
                v.to_possible_value()?.get_name().to_string(),
                wrap(v.clone()),
            ))
        })
        .collect()
}

/// A value of one axis.
enum Value {
    Spectral(Spectral),
    Shifting(Shifting),
    Tracking(Tracking),
    Rays(Rays),
    Dispersion(Dispersion),
}

impl Value {
    fn axis(&self) -> &'static str {
        match self {
            Value::Spectral(_) => "spectral",
            Value::Shifting(_) => "shifting",
            Value::Tracking(_) => "tracking",
            Value::Rays(_) => "rays",
            Value::Dispersion(_) => "dispersion",
        }
    }
}

/// Every value of every axis, by name, and a description of them for errors.
fn all_values() -> (Vec<(String, Value)>, String) {
    let mut all: Vec<(String, Value)> = Vec::new();
    let mut text: Vec<String> = Vec::new();
    let mut axis = |name: &str, values: Vec<(String, Value)>| {
        let names: Vec<&str> = values.iter().map(|(n, _)| n.as_str()).collect();
        text.push(format!("{name} ({})", names.join(", ")));
        all.extend(values);
    };
    axis("spectral", named(Value::Spectral));
    axis("shifting", named(Value::Shifting));
    axis("tracking", named(Value::Tracking));
    axis("rays", named(Value::Rays));
    axis("dispersion", named(Value::Dispersion));
    (all, text.join(", "))
}

impl Method {
    /// The canonical name: the five values joined by `-`, axes in the order spectral,
    /// shifting, tracking, rays, dispersion.
    pub fn name(&self) -> String {
        self.parts().join("-")
    }

    /// The five values, in axis order.
    pub fn parts(&self) -> [&'static str; 5] {
        [
            self.spectral.name(),
            self.shifting.name(),
            self.tracking.name(),
            self.rays.name(),
            self.dispersion.name(),
        ]
    }

    /// Parses a name: values of the axes joined by `-`, in any order, each axis at most
    /// once; the axes left out take their value from `defaults`.
    pub fn parse(text: &str, defaults: &Method) -> Result<Method, String> {
        let text = text.trim();
        if text.is_empty() {
            return Err("expected a method name such as hwss-independent-fluo-aware-packet, found an empty one".into());
        }
        let (values, described) = all_values();
        let mut m = *defaults;
        let mut seen: Vec<&str> = Vec::new();
        let tokens: Vec<&str> = text.split('-').collect();
        let mut i = 0;
        while i < tokens.len() {
            // Values may hold a dash themselves (`fluo-aware`): take the longest match.
            let found = values
                .iter()
                .filter_map(|(name, v)| {
                    let k = name.split('-').count();
                    (i + k <= tokens.len() && tokens[i..i + k].join("-") == *name)
                        .then_some((k, name, v))
                })
                .max_by_key(|(k, _, _)| *k);
            let Some((k, name, value)) = found else {
                return Err(format!(
                    "unknown component `{}` in method `{text}`: expected values of {described}, joined by `-`",
                    tokens[i]
                ));
            };
            i += k;
            let axis = value.axis();
            if seen.contains(&axis) {
                return Err(format!(
                    "method `{text}` gives the {axis} axis twice (at `{name}`): name one value per axis"
                ));
            }
            seen.push(axis);
            match *value {
                Value::Spectral(v) => m.spectral = v,
                Value::Shifting(v) => m.shifting = v,
                Value::Tracking(v) => m.tracking = v,
                Value::Rays(v) => m.rays = v,
                Value::Dispersion(v) => m.dispersion = v,
            }
        }
        Ok(m)
    }

    /// Parses a comma-separated list of names; duplicates are an error.
    pub fn parse_list(text: &str, defaults: &Method) -> Result<Vec<Method>, String> {
        let mut out: Vec<(Method, &str)> = Vec::new();
        for item in text.split(',') {
            let m = Method::parse(item, defaults)?;
            if let Some((_, first)) = out.iter().find(|(o, _)| *o == m) {
                return Err(format!(
                    "`{}` and `{}` name the same method ({})",
                    first.trim(),
                    item.trim(),
                    m.name()
                ));
            }
            out.push((m, item));
        }
        Ok(out.into_iter().map(|(m, _)| m).collect())
    }

    /// `base` with this method's choices.
    pub fn options(&self, base: &RenderOptions) -> RenderOptions {
        RenderOptions {
            spectral: self.spectral,
            shifting: self.shifting,
            tracking: Some(self.tracking),
            rays: self.rays,
            dispersion: self.dispersion,
            ..base.clone()
        }
    }
}

/// The values each axis takes in a comparison.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MethodSpace {
    /// Spectral sampling.
    pub spectral: Vec<Spectral>,
    /// Shifting (HWSS only: mono takes the first).
    pub shifting: Vec<Shifting>,
    /// Tracking.
    pub tracking: Vec<Tracking>,
    /// Rays.
    pub rays: Vec<Rays>,
    /// Dispersion (HWSS only: mono takes the first).
    pub dispersion: Vec<Dispersion>,
}

impl MethodSpace {
    /// The axes the scene makes meaningful: spectral sampling and rays always; shifting
    /// where something fluoresces; tracking where there are media; dispersion where a
    /// dielectric is dispersive. Fixed axes hold `defaults`' value.
    pub fn for_scene(scene: &Scene, defaults: &Method) -> MethodSpace {
        let fluorescent = scene.has_fluorescence() || scene.has_fluorescent_media();
        MethodSpace {
            spectral: vec![Spectral::Hwss, Spectral::Mono],
            shifting: if fluorescent {
                vec![Shifting::Independent, Shifting::Constant]
            } else {
                vec![defaults.shifting]
            },
            tracking: if scene.has_media() {
                vec![Tracking::Classic, Tracking::Max, Tracking::FluoAware]
            } else {
                vec![defaults.tracking]
            },
            rays: vec![Rays::Single, Rays::Packet],
            dispersion: if scene.has_dispersion() {
                vec![Dispersion::Drop, Dispersion::Split]
            } else {
                vec![defaults.dispersion]
            },
        }
    }

    /// Every combination, spectral outermost and rays innermost. Shifting and dispersion
    /// act on the secondary wavelengths, which mono does not have: mono takes only the
    /// first value of each.
    pub fn methods(&self) -> Vec<Method> {
        let mut out = Vec::new();
        for &spectral in &self.spectral {
            let mono = spectral == Spectral::Mono;
            let shifting = if mono {
                &self.shifting[..self.shifting.len().min(1)]
            } else {
                &self.shifting[..]
            };
            let dispersion = if mono {
                &self.dispersion[..self.dispersion.len().min(1)]
            } else {
                &self.dispersion[..]
            };
            for &shifting in shifting {
                for &tracking in &self.tracking {
                    for &dispersion in dispersion {
                        for &rays in &self.rays {
                            out.push(Method {
                                spectral,
                                shifting,
                                tracking,
                                rays,
                                dispersion,
                            });
                        }
                    }
                }
            }
        }
        out
    }
}

/// Names for a legend: the values of the axes on which `methods` differ (the full name
/// where they all agree).
pub fn short_names(methods: &[Method]) -> Vec<String> {
    let parts: Vec<[&str; 5]> = methods.iter().map(Method::parts).collect();
    let varies: Vec<bool> = (0..5)
        .map(|k| parts.iter().any(|p| p[k] != parts[0][k]))
        .collect();
    parts
        .iter()
        .map(|p| {
            let kept: Vec<&str> = (0..5).filter(|&k| varies[k]).map(|k| p[k]).collect();
            if kept.is_empty() {
                p.join("-")
            } else {
                kept.join("-")
            }
        })
        .collect()
}

/// The error of an image against the reference over some pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    /// Root mean square error over pixels and channels.
    pub rmse: f64,
    /// Mean of (x − r)² / (r² + 0.01) over pixels and channels.
    pub relmse: f64,
}

/// The errors of `image` against `reference` over the pixels `pixels` (indices into
/// both) and the three channels. An empty set gives NaN.
pub fn errors(image: &[[f32; 3]], reference: &[[f32; 3]], pixels: &[usize]) -> Errors {
    let (mut se, mut rel) = (0.0f64, 0.0f64);
    for &i in pixels {
        for c in 0..3 {
            let r = reference[i][c] as f64;
            let d = image[i][c] as f64 - r;
            se += d * d;
            rel += d * d / (r * r + 0.01);
        }
    }
    let n = (3 * pixels.len()) as f64;
    Errors {
        rmse: (se / n).sqrt(),
        relmse: rel / n,
    }
}

/// A region of the image to measure: `image` (every pixel) or a scene's `[[region]]`.
#[derive(Debug, Clone)]
pub struct MeasuredRegion {
    /// Its name in the CSV.
    pub name: String,
    /// Row-major pixel indices.
    pub pixels: Vec<usize>,
}

/// `image` and then the scene's regions, at the resolution of `opts`.
pub fn measured_regions(scene: &Scene, width: u32, height: u32) -> Vec<MeasuredRegion> {
    let mut out = vec![MeasuredRegion {
        name: "image".into(),
        pixels: (0..width as usize * height as usize).collect(),
    }];
    out.extend(scene.regions.iter().map(|r| MeasuredRegion {
        name: r.name.clone(),
        pixels: r.pixels(width, height),
    }));
    out
}

/// Whether the error is recorded after `spp` samples: at 1, 2, 4, 8, … (the final spp
/// is recorded too, whatever it is).
pub fn is_checkpoint(spp: u32) -> bool {
    spp.is_power_of_two()
}

/// The state of a progressive render at a checkpoint.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    /// Passes rendered.
    pub pass: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Seconds spent in passes so far (error computation excluded).
    pub seconds: f64,
    /// The errors, one per measured region, in order.
    pub errors: Vec<Errors>,
}

/// How long one method renders.
#[derive(Debug, Clone, Copy)]
pub struct Budget {
    /// Seconds of rendering: a pass starts only if, at the mean pass time so far, it
    /// ends within them (the first pass always runs).
    pub seconds: f64,
    /// At most this many samples per pixel.
    pub max_spp: Option<u32>,
    /// The first sample index drawn (samples are `[first_sample, first_sample + spp)`).
    pub first_sample: u32,
}

/// One method's run: its checkpoints and the samples that came out NaN or infinite.
#[derive(Debug, Clone)]
pub struct Run {
    /// The method.
    pub method: Method,
    /// Checkpoints in order; the last is the final state.
    pub checkpoints: Vec<Checkpoint>,
    /// Non-finite samples dropped.
    pub nonfinite: u64,
}

/// Renders `method` progressively, one sample per pixel per pass, on `pool`, recording
/// the errors against `reference` at every checkpoint. `base` gives the size, seed,
/// depth and threads; the scene's camera must have its resolution.
pub fn run_method(
    scene: &Scene,
    base: &RenderOptions,
    method: &Method,
    reference: &[[f32; 3]],
    regions: &[MeasuredRegion],
    budget: &Budget,
    pool: &rayon::ThreadPool,
) -> Result<Run, String> {
    let opts = method.options(base);
    if (scene.camera.width, scene.camera.height) != (opts.width, opts.height) {
        return Err(format!(
            "render options ask for {}x{} but the camera is {}x{}",
            opts.width, opts.height, scene.camera.width, scene.camera.height
        ));
    }
    let pixels = opts.width as usize * opts.height as usize;
    if reference.len() != pixels {
        return Err(format!(
            "the reference has {} pixels but the render {}x{} has {pixels}",
            reference.len(),
            opts.width,
            opts.height
        ));
    }
    if !(budget.seconds.is_finite() && budget.seconds > 0.0) {
        return Err(format!(
            "expected a positive time budget, found {}",
            budget.seconds
        ));
    }
    let max_spp = crate::integrator::render::sample_count(budget.first_sample, budget.max_spp)?;
    let mut film = Film::try_new(opts.width, opts.height)?;
    let mut seconds = 0.0f64;
    let mut pass = 0u32;
    let mut nonfinite = 0u64;
    let mut checkpoints: Vec<Checkpoint> = Vec::new();
    let measure = |film: &Film, pass: u32, seconds: f64| {
        let image = film.mean();
        Checkpoint {
            pass,
            spp: film.spp,
            seconds,
            errors: regions
                .iter()
                .map(|r| errors(&image, reference, &r.pixels))
                .collect(),
        }
    };
    while film.spp < max_spp && (pass == 0 || seconds + seconds / pass as f64 <= budget.seconds) {
        let first = budget.first_sample + film.spp;
        let start = Instant::now();
        let stats = pool.install(|| render_pass(scene, &opts, &mut film, first, 1, &|| {}));
        seconds += start.elapsed().as_secs_f64();
        pass += 1;
        nonfinite += stats.nonfinite;
        if is_checkpoint(film.spp) {
            checkpoints.push(measure(&film, pass, seconds));
        }
    }
    if checkpoints.last().map(|c| c.spp) != Some(film.spp) {
        checkpoints.push(measure(&film, pass, seconds));
    }
    Ok(Run {
        method: *method,
        checkpoints,
        nonfinite,
    })
}

/// The CSV text of some runs (header included): one row per checkpoint and region.
pub fn csv(runs: &[Run], regions: &[MeasuredRegion]) -> String {
    let mut out = String::new();
    out.push_str(CSV_HEADER);
    out.push('\n');
    for run in runs {
        let m = &run.method;
        let [spectral, shifting, tracking, rays, dispersion] = m.parts();
        for c in &run.checkpoints {
            for (r, e) in regions.iter().zip(&c.errors) {
                let _ = writeln!(
                    out,
                    "{},{spectral},{shifting},{tracking},{rays},{dispersion},{},{},{:.6},{},{:.6e},{:.6e}",
                    m.name(),
                    c.pass,
                    c.spp,
                    c.seconds,
                    r.name,
                    e.rmse,
                    e.relmse
                );
            }
        }
    }
    out
}

/// The least-squares slope of `ln y` against `ln x` over the points with positive,
/// finite coordinates; `None` with fewer than two distinct `x`.
pub fn loglog_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    if logs.len() < 2 {
        return None;
    }
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The smallest spp of the checkpoints a slope is fitted over: earlier ones are
/// dominated by start-up effects (a single sample per pixel, the first passes' timing).
pub const SLOPE_MIN_SPP: u32 = 4;

/// The log–log slope of a run's RMSE in region `region` against spp, over the
/// checkpoints with at least [`SLOPE_MIN_SPP`] samples.
pub fn rmse_slope(run: &Run, region: usize) -> Option<f64> {
    let pts: Vec<(f64, f64)> = run
        .checkpoints
        .iter()
        .filter(|c| c.spp >= SLOPE_MIN_SPP)
        .map(|c| (c.spp as f64, c.errors[region].rmse))
        .collect();
    loglog_slope(&pts)
}

/// The time at which the error first falls to `target`, interpolated log–log between
/// the checkpoints around the crossing, from `(seconds, error)` points in order;
/// `None` if it never does.
pub fn time_to_reach(points: &[(f64, f64)], target: f64) -> Option<f64> {
    let i = points.iter().position(|&(_, e)| e <= target)?;
    if i == 0 {
        return Some(points[0].0);
    }
    let (t0, e0) = points[i - 1];
    let (t1, e1) = points[i];
    if !(t0 > 0.0 && t1 > 0.0 && e0 > 0.0 && e1 > 0.0 && target > 0.0) || e0 == e1 {
        return Some(t1);
    }
    let f = (target.ln() - e0.ln()) / (e1.ln() - e0.ln());
    Some((t0.ln() + f * (t1.ln() - t0.ln())).exp())
}

/// One line of the summary table.
#[derive(Debug, Clone)]
pub struct SummaryRow {
    /// The method's name.
    pub method: String,
    /// Samples per pixel reached.
    pub spp: u32,
    /// Seconds of rendering.
    pub seconds: f64,
    /// Fitted slope of RMSE against spp (log–log).
    pub slope: Option<f64>,
    /// Final RMSE.
    pub rmse: f64,
    /// Final relative MSE.
    pub relmse: f64,
    /// Seconds to reach the target relative MSE.
    pub time_to_target: Option<f64>,
}

/// The summary over one region: per method, slope, final errors and the time to reach
/// the target relative MSE — the worst final relative MSE of all methods (named in
/// the returned `(target, its method)`), which every method reaches.
pub fn summarize(runs: &[Run], region: usize) -> (f64, String, Vec<SummaryRow>) {
    let finals: Vec<Errors> = runs
        .iter()
        .map(|r| {
            r.checkpoints.last().map_or(
                Errors {
                    rmse: f64::NAN,
                    relmse: f64::NAN,
                },
                |c| c.errors[region],
            )
        })
        .collect();
    let (mut target, mut worst) = (f64::NAN, String::new());
    for (run, e) in runs.iter().zip(&finals) {
        if e.relmse.is_finite() && (target.is_nan() || e.relmse > target) {
            target = e.relmse;
            worst = run.method.name();
        }
    }
    let rows = runs
        .iter()
        .zip(&finals)
        .map(|(run, e)| {
            let pts: Vec<(f64, f64)> = run
                .checkpoints
                .iter()
                .map(|c| (c.seconds, c.errors[region].relmse))
                .collect();
            let last = run.checkpoints.last();
            SummaryRow {
                method: run.method.name(),
                spp: last.map_or(0, |c| c.spp),
                seconds: last.map_or(0.0, |c| c.seconds),
                slope: rmse_slope(run, region),
                rmse: e.rmse,
                relmse: e.relmse,
                time_to_target: time_to_reach(&pts, target),
            }
        })
        .collect();
    (target, worst, rows)
}

/// The summary as a Markdown table, with a line naming the region and the target.
pub fn format_summary(region: &str, target: f64, worst: &str, rows: &[SummaryRow]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Errors over {}; slope: least squares of ln RMSE on ln spp over checkpoints with spp ≥ {SLOPE_MIN_SPP} (−0.5 for an unbiased estimator); target: relMSE {target:.3e}, the worst final relMSE (of {worst}).",
        if region == "image" {
            "the whole image".to_string()
        } else {
            format!("region `{region}`")
        }
    );
    out.push('\n');
    out.push_str(
        "| method | spp | seconds | slope | final RMSE | final relMSE | seconds to target |\n",
    );
    out.push_str("| --- | --- | --- | --- | --- | --- | --- |\n");
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {:.2} | {} | {:.4e} | {:.4e} | {} |",
            r.method,
            r.spp,
            r.seconds,
            r.slope.map_or("—".into(), |s| format!("{s:.3}")),
            r.rmse,
            r.relmse,
            r.time_to_target.map_or("—".into(), |t| format!("{t:.3}"))
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn default_method() -> Method {
        Method {
            spectral: Spectral::Hwss,
            shifting: Shifting::Independent,
            tracking: Tracking::Classic,
            rays: Rays::Single,
            dispersion: Dispersion::Drop,
        }
    }

    #[test]
    fn names_round_trip_and_parse_in_any_order() {
        let d = default_method();
        let m = Method::parse("hwss-independent-fluo-aware-packet", &d).unwrap();
        assert_eq!(m.tracking, Tracking::FluoAware);
        assert_eq!(m.rays, Rays::Packet);
        assert_eq!(m.name(), "hwss-independent-fluo-aware-packet-drop");
        assert_eq!(Method::parse(&m.name(), &d).unwrap(), m);
        let n = Method::parse("packet-fluo-aware-split-mono", &d).unwrap();
        assert_eq!(n.name(), "mono-independent-fluo-aware-packet-split");
        assert_eq!(Method::parse("max", &d).unwrap().tracking, Tracking::Max);
        for bad in [
            "hwss-fluo",
            "aware",
            "hwss-mono",
            "",
            "hwss--single",
            "HWSS",
        ] {
            assert!(Method::parse(bad, &d).is_err(), "{bad:?} parsed");
        }
        let e = Method::parse("hwss-bogus", &d).unwrap_err();
        assert!(e.contains("`bogus`"), "{e}");
        assert!(Method::parse_list("hwss,hwss-single", &d).is_err());
        assert_eq!(Method::parse_list("hwss, mono", &d).unwrap().len(), 2);
    }

    #[test]
    fn method_space_skips_what_mono_lacks() {
        let space = MethodSpace {
            spectral: vec![Spectral::Hwss, Spectral::Mono],
            shifting: vec![Shifting::Independent, Shifting::Constant],
            tracking: vec![Tracking::Classic, Tracking::Max, Tracking::FluoAware],
            rays: vec![Rays::Single, Rays::Packet],
            dispersion: vec![Dispersion::Drop],
        };
        let ms = space.methods();
        assert_eq!(ms.len(), (2 + 1) * 3 * 2);
        let names: std::collections::BTreeSet<String> = ms.iter().map(Method::name).collect();
        assert_eq!(names.len(), ms.len());
        assert!(ms
            .iter()
            .all(|m| m.spectral == Spectral::Hwss || m.shifting == Shifting::Independent));
    }

    #[test]
    fn errors_and_slopes() {
        let r = vec![[1.0f32, 0.0, 0.5]; 4];
        let x = vec![[1.1f32, 0.1, 0.5]; 4];
        let e = errors(&x, &r, &[0, 1, 2, 3]);
        assert!((e.rmse - (0.02f64 / 3.0).sqrt()).abs() < 1e-6, "{e:?}");
        let want = (0.01 / 1.01 + 0.01 / 0.01) / 3.0;
        assert!((e.relmse - want).abs() < 1e-6, "{e:?}");
        assert!(errors(&x, &r, &[]).rmse.is_nan());

        let pts: Vec<(f64, f64)> = (0..8)
            .map(|k| {
                let n = (1u32 << k) as f64;
                (n, 3.0 / n.sqrt())
            })
            .collect();
        assert!((loglog_slope(&pts).unwrap() + 0.5).abs() < 1e-12);
        assert!(loglog_slope(&pts[..1]).is_none());
        assert!(loglog_slope(&[(2.0, 1.0), (2.0, 3.0)]).is_none());
    }

    #[test]
    fn time_to_reach_interpolates_log_log() {
        let pts = [(1.0, 1.0), (4.0, 0.25), (16.0, 0.0625)];
        assert_eq!(time_to_reach(&pts, 2.0), Some(1.0));
        assert!((time_to_reach(&pts, 0.5).unwrap() - 2.0).abs() < 1e-12);
        assert!((time_to_reach(&pts, 0.0625).unwrap() - 16.0).abs() < 1e-9);
        assert_eq!(time_to_reach(&pts, 0.01), None);
    }

    #[test]
    fn checkpoints_are_powers_of_two() {
        let cps: Vec<u32> = (1..=40).filter(|&n| is_checkpoint(n)).collect();
        assert_eq!(cps, [1, 2, 4, 8, 16, 32]);
    }
}
