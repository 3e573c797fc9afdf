//! The `stokes:*` attributes of every EXR the renderer writes: which scene, which samples,
//! which method. `stokes merge`, `stokes reference --resume` and `stokes converge` read
//! them back to check that images belong together.
//!
//! | attribute | meaning |
//! | --- | --- |
//! | `scene`, `scene_hash` | the scene file as given, and FNV-1a of its bytes ([`scene_hash`]) |
//! | `spp` | samples per pixel, the total of `sample_ranges` |
//! | `sample_ranges` | `SEED:START..END …`: the sample indices drawn ([`SampleRange`]) |
//! | `seed`, `seed_offset` | the seed (when every range has the same) and the first index (one range) |
//! | `spectral`, `shifting`, `tracking`, `rays`, `dispersion` | the method ([`crate::method`]) |
//! | `max_depth` | path segments from the camera, −1 unbounded |
//! | `render_seconds` | seconds of rendering (summed over merged parts) |
//! | `stopped` | why the render ended: `complete`, `time budget`, `interrupted` (not in merges) |
//! | `time_budget` | `--time`, when given |
//! | `nonfinite_samples` | samples dropped as NaN or infinite, when any |
//! | `parts` | a merge's inputs, `file (N spp), …` |
//! | `version` | the stokes version that wrote the file |
//!
//! Every pixel sample draws from its own random stream keyed by (seed, pixel, sample
//! index), so images with disjoint sample ranges of the same scene and method are
//! independent, and their spp-weighted mean is the image of the union of the ranges.

use crate::error::{Detail, Error, Key};
use crate::integrator::render::{RenderOptions, Stopped};
use crate::medium::tracking::Tracking;
use crate::method::{Axis, Dispersion, Rays, Resolved, Shifting, Spectral, Wavelengths};
use crate::scene::Scene;
use crate::Result;
use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

/// FNV-1a, 64 bits: the scene file's fingerprint.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The header value of a scene file's fingerprint: `fnv1a64:` and 16 hex digits.
pub fn scene_hash(bytes: &[u8]) -> String {
    format!("fnv1a64:{:016x}", fnv1a64(bytes))
}

/// Sample indices `[start, end)` of the streams of `seed`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct SampleRange {
    /// The seed.
    pub seed: u64,
    /// First sample index.
    pub start: u64,
    /// One past the last.
    pub end: u64,
}

impl SampleRange {
    /// Samples in the range.
    pub fn len(&self) -> u64 {
        self.end - self.start
    }

    /// Whether the range is empty.
    pub fn is_empty(&self) -> bool {
        self.end <= self.start
    }

    /// The samples two ranges share, if any.
    pub fn overlap(&self, other: &SampleRange) -> Option<SampleRange> {
        let (start, end) = (self.start.max(other.start), self.end.min(other.end));
        (self.seed == other.seed && start < end).then_some(SampleRange {
            seed: self.seed,
            start,
            end,
        })
    }
}

impl fmt::Display for SampleRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}..{}", self.seed, self.start, self.end)
    }
}

/// Sorts ranges and joins adjacent ones of the same seed.
pub fn normalise(mut ranges: Vec<SampleRange>) -> Vec<SampleRange> {
    ranges.sort();
    let mut out: Vec<SampleRange> = Vec::with_capacity(ranges.len());
    for r in ranges {
        match out.last_mut() {
            Some(last) if last.seed == r.seed && last.end == r.start => last.end = r.end,
            _ => out.push(r),
        }
    }
    out
}

/// The sample indices of `[start, end)` that no range of `held` covers, as `(start, end)`
/// pairs in order (every range counts, whatever its seed: pass one seed's ranges).
pub fn gaps(held: &[SampleRange], start: u64, end: u64) -> Vec<(u64, u64)> {
    let mut held = held.to_vec();
    held.sort();
    let mut out = Vec::new();
    let mut at = start;
    for r in &held {
        if r.end <= at || r.start >= end {
            continue;
        }
        if r.start > at {
            out.push((at, r.start));
        }
        at = at.max(r.end);
    }
    if at < end {
        out.push((at, end));
    }
    out
}

/// The header text of a list of ranges: `SEED:START..END` separated by spaces.
pub fn format_ranges(ranges: &[SampleRange]) -> String {
    ranges
        .iter()
        .map(|r| r.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

/// Parses [`format_ranges`]' text. The error says what is wrong with it; the caller
/// knows where the text came from.
pub fn parse_ranges(text: &str) -> Result<Vec<SampleRange>, Detail> {
    text.split_whitespace()
        .map(|tok| {
            let bad = || Detail::Expected {
                expected: "SEED:START..END".into(),
                found: format!("{tok:?}"),
            };
            let (seed, range) = tok.split_once(':').ok_or_else(bad)?;
            let (a, b) = range.split_once("..").ok_or_else(bad)?;
            let r = SampleRange {
                seed: seed.parse().map_err(|_| bad())?,
                start: a.parse().map_err(|_| bad())?,
                end: b.parse().map_err(|_| bad())?,
            };
            if r.is_empty() {
                return Err(bad());
            }
            Ok(r)
        })
        .collect()
}

/// The first sample index of `seed` after every range of that seed: where new samples
/// that must be independent of `ranges` start.
pub fn next_free_sample(ranges: &[SampleRange], seed: u64) -> u64 {
    ranges
        .iter()
        .filter(|r| r.seed == seed)
        .map(|r| r.end)
        .max()
        .unwrap_or(0)
}

/// What an image holds and how it was made.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderHeader {
    /// The scene file, as given on the command line.
    pub scene: String,
    /// Its fingerprint ([`scene_hash`]).
    pub scene_hash: String,
    /// The sample indices drawn, normalised.
    pub ranges: Vec<SampleRange>,
    /// The method, with its tracking resolved.
    pub method: Resolved,
    /// Path segments from the camera, −1 unbounded.
    pub max_depth: i32,
    /// Seconds of rendering.
    pub render_seconds: f64,
    /// Why the render ended (`None` for a merge).
    pub stopped: Option<Stopped>,
    /// The `--time` budget, when given.
    pub time_budget: Option<f64>,
    /// Samples dropped as NaN or infinite.
    pub nonfinite_samples: u64,
    /// A merge's inputs, `file (N spp), …`.
    pub parts: Option<String>,
    /// The stokes version that wrote it.
    pub version: String,
}

/// The settings besides the scene and size that images must share to be merged or
/// compared: they change the image (`rays` does not, but one header names one method).
pub const SETTINGS: [&str; 7] = [
    "spectral",
    "wavelengths",
    "shifting",
    "tracking",
    "max_depth",
    "rays",
    "dispersion",
];

/// A setting on which two headers differ.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mismatch {
    /// The attribute, one of [`SETTINGS`].
    pub key: &'static str,
    /// This header's value.
    pub ours: String,
    /// The other's.
    pub theirs: String,
}

impl RenderHeader {
    /// The header of a render of `scene` with `opts` that drew `ranges`.
    pub fn for_render(
        scene: &Scene,
        opts: &RenderOptions,
        ranges: Vec<SampleRange>,
        render_seconds: f64,
        stopped: Stopped,
    ) -> RenderHeader {
        RenderHeader {
            scene: scene.path.display().to_string(),
            scene_hash: scene.hash.clone(),
            ranges,
            method: opts.method.resolve(scene),
            max_depth: opts.max_depth,
            render_seconds,
            stopped: Some(stopped),
            time_budget: None,
            nonfinite_samples: 0,
            parts: None,
            version: VERSION.into(),
        }
    }

    /// Samples per pixel.
    pub fn spp(&self) -> u64 {
        self.ranges.iter().map(SampleRange::len).sum()
    }

    /// The value of one of [`SETTINGS`].
    pub fn setting(&self, key: &str) -> String {
        let m = &self.method;
        match key {
            "spectral" => m.spectral.name().into(),
            "wavelengths" => m.wavelengths.name().into(),
            "shifting" => m.shifting.name().into(),
            "tracking" => m.tracking.name().into(),
            "max_depth" => self.max_depth.to_string(),
            "rays" => m.rays.name().into(),
            "dispersion" => m.dispersion.name().into(),
            _ => unreachable!("not a setting: {key}"),
        }
    }

    /// The first setting on which `other` differs, if any.
    pub fn mismatch(&self, other: &RenderHeader) -> Option<Mismatch> {
        SETTINGS.iter().find_map(|&key| {
            let (ours, theirs) = (self.setting(key), other.setting(key));
            (ours != theirs).then_some(Mismatch { key, ours, theirs })
        })
    }

    /// The attributes as written, without the `stokes:` prefix.
    pub fn attributes(&self) -> Vec<(String, String)> {
        let mut a: Vec<(String, String)> = Vec::new();
        let mut put = |k: &str, v: String| a.push((k.to_string(), v));
        put("scene", self.scene.clone());
        put("scene_hash", self.scene_hash.clone());
        put("spp", self.spp().to_string());
        if let Some(first) = self.ranges.first() {
            if self.ranges.iter().all(|r| r.seed == first.seed) {
                put("seed", first.seed.to_string());
            }
            if self.ranges.len() == 1 {
                put("seed_offset", first.start.to_string());
            }
        }
        put("sample_ranges", format_ranges(&self.ranges));
        for key in SETTINGS {
            put(key, self.setting(key));
        }
        put("render_seconds", format!("{:.3}", self.render_seconds));
        if let Some(s) = self.stopped {
            put("stopped", s.name().to_string());
        }
        if let Some(t) = self.time_budget {
            put("time_budget", t.to_string());
        }
        if self.nonfinite_samples > 0 {
            put("nonfinite_samples", self.nonfinite_samples.to_string());
        }
        if let Some(p) = &self.parts {
            put("parts", p.clone());
        }
        put("version", self.version.clone());
        a
    }

    /// Reads the attributes of `file` (without the `stokes:` prefix). A malformed
    /// attribute is an [`Error::Value`] at its key (`stokes:spp`); a missing one, or a
    /// header that does not add up, an [`Error::File`].
    pub fn from_attributes(file: &Path, attrs: &BTreeMap<String, String>) -> Result<RenderHeader> {
        let get = |k: &str| -> Result<&String> {
            attrs.get(k).ok_or_else(|| {
                Error::file(
                    file,
                    None,
                    if attrs.is_empty() {
                        "no stokes header (stokes:spp, stokes:scene_hash, …): not an image written by stokes render".to_string()
                    } else {
                        format!("the header lacks stokes:{k} (written by an older stokes?): cannot check that it belongs with the other parts")
                    },
                )
            })
        };
        let spp_text = get("spp")?;
        let spp: u64 = value(file, "spp", spp_text, "a count ≥ 1")?;
        if spp == 0 {
            return Err(expected(file, "spp", "a count ≥ 1", spp_text));
        }
        let scene_hash = get("scene_hash")?.clone();
        for k in SETTINGS.iter().filter(|&&k| k != "wavelengths") {
            get(k)?;
        }
        // Files from before the wavelengths axis (stokes 0.x up to this change) have no
        // stokes:wavelengths: they all sampled uniformly, so that is what they hold.
        let wavelengths = match attrs.get("wavelengths") {
            Some(v) => axis::<Wavelengths>(file, "wavelengths", v)?,
            None => Wavelengths::Uniform,
        };
        let method = Resolved {
            spectral: axis::<Spectral>(file, "spectral", get("spectral")?)?,
            wavelengths,
            shifting: axis::<Shifting>(file, "shifting", get("shifting")?)?,
            tracking: axis::<Tracking>(file, "tracking", get("tracking")?)?,
            rays: axis::<Rays>(file, "rays", get("rays")?)?,
            dispersion: axis::<Dispersion>(file, "dispersion", get("dispersion")?)?,
        };
        let max_depth: i32 = value(file, "max_depth", get("max_depth")?, "an integer")?;
        let ranges = match attrs.get("sample_ranges") {
            Some(t) => parse_ranges(t).map_err(|detail| Error::Value {
                file: file.to_path_buf(),
                error: attribute("sample_ranges").error(detail),
            })?,
            // Written before sample ranges were recorded: one range from the seed offset.
            None => {
                let seed: u64 = value(file, "seed", get("seed")?, "an integer")?;
                let start: u64 = value(file, "seed_offset", get("seed_offset")?, "an integer")?;
                vec![SampleRange {
                    seed,
                    start,
                    end: start + spp,
                }]
            }
        };
        let held: u64 = ranges.iter().map(SampleRange::len).sum();
        if held != spp {
            return Err(Error::file(
                file,
                None,
                format!(
                    "stokes:sample_ranges ({}) hold {held} samples but stokes:spp is {spp}",
                    format_ranges(&ranges)
                ),
            ));
        }
        let optional = |k: &str| attrs.get(k).map(String::as_str);
        let stopped = match optional("stopped") {
            None => None,
            Some(t) => Some(Stopped::from_name(t).ok_or_else(|| {
                expected(file, "stopped", "complete, time budget or interrupted", t)
            })?),
        };
        Ok(RenderHeader {
            scene: optional("scene").unwrap_or("?").to_string(),
            scene_hash,
            ranges,
            method,
            max_depth,
            render_seconds: match optional("render_seconds") {
                Some(t) => value(file, "render_seconds", t, "a number of seconds")?,
                None => 0.0,
            },
            stopped,
            time_budget: optional("time_budget")
                .map(|t| value(file, "time_budget", t, "a number of seconds"))
                .transpose()?,
            nonfinite_samples: optional("nonfinite_samples")
                .map(|t| value(file, "nonfinite_samples", t, "a count"))
                .transpose()?
                .unwrap_or(0),
            parts: optional("parts").map(str::to_string),
            version: optional("version").unwrap_or("?").to_string(),
        })
    }

    /// The scene as reports name it: `file (hash)`.
    pub fn scene_label(&self) -> String {
        format!("{} ({})", self.scene, self.scene_hash)
    }
}

/// The key of header attribute `name`: `stokes:name`.
fn attribute(name: &str) -> Key {
    Key::root(&format!("stokes:{name}"))
}

/// `file: stokes:key: expected {what}, found "text"`.
fn expected(file: &Path, key: &str, what: &str, text: &str) -> Error {
    Error::Value {
        file: file.to_path_buf(),
        error: attribute(key).expected(what, format!("{text:?}")),
    }
}

/// Attribute `key`'s `text` parsed, or an error saying it is not `what`.
fn value<T: std::str::FromStr>(file: &Path, key: &str, text: &str, what: &str) -> Result<T> {
    text.parse().map_err(|_| expected(file, key, what, text))
}

/// Attribute `key`'s `text` as a value of the method axis `A`.
fn axis<A: Axis>(file: &Path, key: &str, text: &str) -> Result<A> {
    A::from_name(text).ok_or_else(|| expected(file, key, &format!("one of {}", A::names()), text))
}

/// The stokes version writing headers now.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::Method;

    #[test]
    fn fnv_reference_values() {
        assert_eq!(fnv1a64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a64(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn ranges_round_trip_join_and_overlap() {
        let r = parse_ranges("0:32..64 0:0..32 7:0..8").unwrap();
        assert_eq!(format_ranges(&normalise(r)), "0:0..64 7:0..8");
        assert!(parse_ranges("0:5..5").is_err());
        assert!(parse_ranges("x").is_err());
        let a = SampleRange {
            seed: 1,
            start: 0,
            end: 32,
        };
        let b = SampleRange {
            seed: 1,
            start: 16,
            end: 48,
        };
        let c = SampleRange {
            seed: 2,
            start: 0,
            end: 32,
        };
        assert_eq!(a.overlap(&b).map(|o| (o.start, o.end)), Some((16, 32)));
        assert!(a.overlap(&c).is_none());
        assert!(a
            .overlap(&SampleRange {
                seed: 1,
                start: 32,
                end: 40
            })
            .is_none());
    }

    #[test]
    fn next_free_sample_follows_the_seeds_ranges() {
        let r = parse_ranges("3:0..16 3:32..40 5:0..100").unwrap();
        assert_eq!(next_free_sample(&r, 3), 40);
        assert_eq!(next_free_sample(&r, 5), 100);
        assert_eq!(next_free_sample(&r, 9), 0);
    }

    fn header() -> RenderHeader {
        RenderHeader {
            scene: "scenes/x.toml".into(),
            scene_hash: scene_hash(b"x"),
            ranges: parse_ranges("0:0..16 7:4..8").unwrap(),
            method: Method::default().with_tracking(Tracking::Max),
            max_depth: 5,
            render_seconds: 1.5,
            stopped: Some(Stopped::TimeBudget),
            time_budget: Some(2.0),
            nonfinite_samples: 3,
            parts: None,
            version: VERSION.into(),
        }
    }

    #[test]
    fn attributes_round_trip() {
        let h = header();
        let attrs: BTreeMap<String, String> = h.attributes().into_iter().collect();
        assert_eq!(attrs["spp"], "20");
        assert_eq!(attrs["tracking"], "max");
        assert!(!attrs.contains_key("seed"), "two seeds: no single seed");
        let back = RenderHeader::from_attributes(Path::new("x.exr"), &attrs).unwrap();
        assert_eq!(back, h);
        let mut broken = attrs.clone();
        broken.insert("rays".into(), "lanes".into());
        let e = RenderHeader::from_attributes(Path::new("x.exr"), &broken)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "x.exr: stokes:rays: expected one of packet, packet8, lockstep, single, found \"lanes\""
        );
        broken.remove("rays");
        let e = RenderHeader::from_attributes(Path::new("x.exr"), &broken)
            .unwrap_err()
            .to_string();
        assert!(e.contains("lacks stokes:rays"), "{e}");
    }

    #[test]
    fn wavelengths_are_read_and_absent_means_uniform() {
        let h = header();
        assert_eq!(h.method.wavelengths, Wavelengths::Visible, "the default");
        let mut attrs: BTreeMap<String, String> = h.attributes().into_iter().collect();
        assert_eq!(attrs["wavelengths"], "visible");
        let back = RenderHeader::from_attributes(Path::new("x.exr"), &attrs).unwrap();
        assert_eq!(back.method.wavelengths, Wavelengths::Visible);
        // Written before the axis existed: every such render sampled uniformly.
        attrs.remove("wavelengths");
        let old = RenderHeader::from_attributes(Path::new("x.exr"), &attrs).unwrap();
        assert_eq!(old.method.wavelengths, Wavelengths::Uniform);
        assert_eq!(
            old.mismatch(&h),
            Some(Mismatch {
                key: "wavelengths",
                ours: "uniform".into(),
                theirs: "visible".into()
            })
        );
        attrs.insert("wavelengths".into(), "eye".into());
        let e = RenderHeader::from_attributes(Path::new("x.exr"), &attrs)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "x.exr: stokes:wavelengths: expected one of visible, uniform, found \"eye\""
        );
    }

    #[test]
    fn mismatch_names_the_first_differing_setting() {
        let a = header();
        assert_eq!(a.mismatch(&a.clone()), None);
        let mut b = header();
        b.max_depth = -1;
        b.method.dispersion = Dispersion::Drop;
        assert_eq!(
            a.mismatch(&b),
            Some(Mismatch {
                key: "max_depth",
                ours: "5".into(),
                theirs: "-1".into()
            })
        );
    }
}
