//! Busy lanes per part of the step (cargo feature `census`, off by default): how often
//! each part of [`super::path::Paths::step`] and its driver runs, and how many of its W
//! lanes carry a path when it does. A width-W part costs about W lanes' work whatever its
//! mask holds, so the share of busy lanes shows where a packet pays for divergence.
//!
//! Without the feature [`record`] is empty and compiles to nothing; with it, every call
//! adds to two global counters (relaxed atomics: meant for `--threads 1` profiling runs,
//! not for timing). `stokes render` prints the table after the render
//! (`cargo run --release --features census -- render …`).

use crate::simd::Mask;

/// A part of the step that runs under a mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// New camera paths started in free lanes.
    Start,
    /// The step itself: the lanes whose ray came back.
    Step,
    /// Distance tracking in a medium.
    Track,
    /// A real collision in a medium.
    MediumScatter,
    /// Rays that left the scene (environment light).
    Escaped,
    /// Index-matched boundaries crossed without scattering.
    Cross,
    /// Surface hits on an emitter that faces the path.
    Emitted,
    /// Surface hits that scatter (material look-up, lobes).
    Surface,
    /// The number of lobe kinds among a step's surface hits: one call per kind present.
    LobeKinds,
    /// Next-event estimation at non-specular surface vertices.
    LightSample,
    /// Shadow rays pushed (valid light sample, non-zero BSDF value).
    ShadowRay,
    /// BSDF sampling and the path's continuation.
    Scatter,
    /// Russian roulette (paths past the third bounce).
    Roulette,
}

/// Every part, in the order of the table.
pub const PARTS: [Part; 13] = [
    Part::Start,
    Part::Step,
    Part::Track,
    Part::MediumScatter,
    Part::Escaped,
    Part::Cross,
    Part::Emitted,
    Part::Surface,
    Part::LobeKinds,
    Part::LightSample,
    Part::ShadowRay,
    Part::Scatter,
    Part::Roulette,
];

#[cfg(feature = "census")]
static COUNTS: [[std::sync::atomic::AtomicU64; 2]; PARTS.len()] = [const {
    [
        std::sync::atomic::AtomicU64::new(0),
        std::sync::atomic::AtomicU64::new(0),
    ]
}; PARTS.len()];

/// Counts one run of `part` over the lanes of `m`.
#[inline(always)]
pub fn record<M: Mask>(part: Part, m: M) {
    #[cfg(feature = "census")]
    {
        use std::sync::atomic::Ordering::Relaxed;
        let c = &COUNTS[part as usize];
        c[0].fetch_add(1, Relaxed);
        c[1].fetch_add(u64::from(m.bits().count_ones()), Relaxed);
    }
    #[cfg(not(feature = "census"))]
    let _ = (part, m);
}

/// Whether this build counts.
pub const ENABLED: bool = cfg!(feature = "census");

/// One part's counts: calls and busy lanes over all calls.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tally {
    /// The part.
    pub part: Part,
    /// Times it ran.
    pub calls: u64,
    /// Lanes that carried a path, summed over its runs.
    pub lanes: u64,
}

/// The counts so far, reset to zero (empty without the feature).
pub fn take() -> Vec<Tally> {
    #[cfg(feature = "census")]
    {
        use std::sync::atomic::Ordering::Relaxed;
        PARTS
            .iter()
            .map(|&part| {
                let c = &COUNTS[part as usize];
                Tally {
                    part,
                    calls: c[0].swap(0, Relaxed),
                    lanes: c[1].swap(0, Relaxed),
                }
            })
            .collect()
    }
    #[cfg(not(feature = "census"))]
    Vec::new()
}

/// The table `stokes render` prints: per part, runs and busy lanes per pixel sample, busy
/// lanes per run, and their share of the `width` lanes a run costs.
pub fn table(tallies: &[Tally], samples: u64, width: usize) -> String {
    let per = |v: u64| v as f64 / samples.max(1) as f64;
    let mut out = format!(
        "census ({samples} samples, width {width}):\n{:<14} {:>10} {:>10} {:>10} {:>6}\n",
        "part", "runs/spl", "lanes/spl", "lanes/run", "busy"
    );
    for t in tallies {
        let per_run = t.lanes as f64 / t.calls.max(1) as f64;
        out += &format!(
            "{:<14} {:>10.3} {:>10.3} {:>10.2} {:>5.0}%\n",
            format!("{:?}", t.part),
            per(t.calls),
            per(t.lanes),
            per_run,
            100.0 * per_run / width as f64
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_divides_by_samples_and_runs() {
        let t = [Tally {
            part: Part::Scatter,
            calls: 50,
            lanes: 170,
        }];
        let out = table(&t, 100, 4);
        let row = out.lines().find(|l| l.starts_with("Scatter")).unwrap();
        let cols: Vec<&str> = row.split_whitespace().collect();
        assert_eq!(cols, ["Scatter", "0.500", "1.700", "3.40", "85%"], "{out}");
    }
}
