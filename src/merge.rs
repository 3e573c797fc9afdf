//! Renders split across machines: the sample ranges an EXR holds, and `stokes merge`.
//!
//! Every pixel sample draws from its own random stream, keyed by (seed, pixel, sample
//! index). A render with `--seed-offset K` and n samples per pixel draws indices
//! `[K, K + n)`, recorded in the header as `stokes:sample_ranges = "SEED:K..K+n"`. Parts
//! with disjoint ranges are independent, and their spp-weighted mean is the render of the
//! union of the ranges — the same image, up to float summation order, as one render of
//! all of them.

use crate::output::{read_exr, write_exr};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// FNV-1a, 64 bits: the scene file's fingerprint in `stokes:scene_hash`.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The header value of a scene hash: `fnv1a64:` and 16 hex digits.
pub fn scene_hash_text(bytes: &[u8]) -> String {
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

impl std::fmt::Display for SampleRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
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

/// The header text of a list of ranges: `SEED:START..END` separated by spaces.
pub fn format_ranges(ranges: &[SampleRange]) -> String {
    ranges
        .iter()
        .map(|r| r.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

/// Parses [`format_ranges`]' text.
pub fn parse_ranges(text: &str) -> Result<Vec<SampleRange>, String> {
    text.split_whitespace()
        .map(|tok| {
            let bad = || format!("expected SEED:START..END, found {tok:?}");
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

/// One input of a merge: an EXR written by `stokes render` (or `stokes merge`).
#[derive(Debug, Clone)]
pub struct Part {
    /// The file.
    pub path: PathBuf,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Pixel means.
    pub pixels: Vec<[f32; 3]>,
    /// The `stokes:*` header attributes, without the prefix.
    pub meta: BTreeMap<String, String>,
    /// Samples per pixel.
    pub spp: u64,
    /// The sample ranges it holds.
    pub ranges: Vec<SampleRange>,
}

/// The render settings that must agree for parts to be merged (besides the scene and
/// the size): they change the image or the estimator.
pub const SETTINGS: [&str; 5] = [
    "spectral",
    "shifting",
    "tracking",
    "max_depth",
    "dispersion",
];

impl Part {
    /// Reads an EXR and its stokes header; errors name the file and the missing or
    /// malformed attribute.
    pub fn read(path: &Path) -> Result<Part, String> {
        let (width, height, pixels, meta) = read_exr(path)?;
        let meta: BTreeMap<String, String> = meta.into_iter().collect();
        let p = path.display();
        let get = |k: &str| -> Result<&String, String> {
            meta.get(k).ok_or_else(|| {
                if meta.is_empty() {
                    format!("{p}: no stokes header (stokes:spp, stokes:scene_hash, …): not an image written by stokes render")
                } else {
                    format!(
                        "{p}: the header lacks stokes:{k} (written by an older stokes?): cannot check that it belongs with the other parts"
                    )
                }
            })
        };
        let spp_text = get("spp")?;
        let spp: u64 =
            spp_text.parse().ok().filter(|&n| n >= 1).ok_or_else(|| {
                format!("{p}: stokes:spp: expected a count ≥ 1, found {spp_text:?}")
            })?;
        get("scene_hash")?;
        for k in SETTINGS {
            get(k)?;
        }
        let ranges = match meta.get("sample_ranges") {
            Some(t) => parse_ranges(t).map_err(|e| format!("{p}: stokes:sample_ranges: {e}"))?,
            None => {
                let seed_text = get("seed")?;
                let seed: u64 = seed_text.parse().map_err(|_| {
                    format!("{p}: stokes:seed: expected an integer, found {seed_text:?}")
                })?;
                let off_text = get("seed_offset")?;
                let start: u64 = off_text.parse().map_err(|_| {
                    format!("{p}: stokes:seed_offset: expected an integer, found {off_text:?}")
                })?;
                vec![SampleRange {
                    seed,
                    start,
                    end: start + spp,
                }]
            }
        };
        let held: u64 = ranges.iter().map(SampleRange::len).sum();
        if held != spp {
            return Err(format!(
                "{p}: stokes:sample_ranges ({}) hold {held} samples but stokes:spp is {spp}",
                format_ranges(&ranges)
            ));
        }
        Ok(Part {
            path: path.to_path_buf(),
            width,
            height,
            pixels,
            meta,
            spp,
            ranges,
        })
    }

    fn scene(&self) -> String {
        format!(
            "{} ({})",
            self.meta.get("scene").map(String::as_str).unwrap_or("?"),
            self.meta["scene_hash"]
        )
    }
}

/// `<dir>/<stem>.variance.exr` beside `<dir>/<stem>.exr`.
pub fn variance_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}.variance.exr"))
}

/// Checks that parts can be merged: same size, scene and settings, disjoint sample
/// ranges.
pub fn check_compatible(parts: &[Part]) -> Result<(), String> {
    let Some(a) = parts.first() else {
        return Err("nothing to merge".into());
    };
    for b in &parts[1..] {
        let (pa, pb) = (a.path.display(), b.path.display());
        if (a.width, a.height) != (b.width, b.height) {
            return Err(format!(
                "{pb} is {}x{} but {pa} is {}x{}: parts must have the same size",
                b.width, b.height, a.width, a.height
            ));
        }
        if a.meta["scene_hash"] != b.meta["scene_hash"] {
            return Err(format!(
                "{pb} is a render of {} but {pa} of {}: parts must render the same scene file",
                b.scene(),
                a.scene()
            ));
        }
        for k in SETTINGS {
            if a.meta[k] != b.meta[k] {
                return Err(format!(
                    "{pb} was rendered with {k} = {} but {pa} with {k} = {}: parts must use the same settings",
                    b.meta[k], a.meta[k]
                ));
            }
        }
    }
    for (i, a) in parts.iter().enumerate() {
        for b in &parts[i + 1..] {
            for ra in &a.ranges {
                for rb in &b.ranges {
                    if let Some(o) = ra.overlap(rb) {
                        return Err(format!(
                            "{} and {} both hold samples {}..{} of seed {}: they are not independent (give each part its own --seed-offset, e.g. i·spp for part i)",
                            a.path.display(),
                            b.path.display(),
                            o.start,
                            o.end,
                            o.seed
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

/// The spp-weighted mean of the parts' pixels.
pub fn weighted_mean(parts: &[Part]) -> Vec<[f32; 3]> {
    let total: f64 = parts.iter().map(|p| p.spp as f64).sum();
    let n = parts.first().map_or(0, |p| p.pixels.len());
    (0..n)
        .map(|i| {
            std::array::from_fn(|c| {
                let s: f64 = parts
                    .iter()
                    .map(|p| p.spp as f64 * p.pixels[i][c] as f64)
                    .sum();
                (s / total) as f32
            })
        })
        .collect()
}

/// The variance of the merged pixel mean from the parts' means `m_i`, spp `n_i` and
/// variances of the mean `v_i = s_i²/n_i`: the pooled sample variance
/// `s² = (Σ (n_i−1)·n_i·v_i + Σ n_i (m_i − M)²) / (N − 1)` over `N = Σ n_i`, divided by
/// `N` — exactly what one render of all `N` samples would report.
pub fn pooled_variance(
    parts: &[Part],
    variances: &[Vec<[f32; 3]>],
    mean: &[[f32; 3]],
) -> Vec<[f32; 3]> {
    let total: f64 = parts.iter().map(|p| p.spp as f64).sum();
    (0..mean.len())
        .map(|i| {
            std::array::from_fn(|c| {
                if total < 2.0 {
                    return 0.0;
                }
                let m = mean[i][c] as f64;
                let ss: f64 = parts
                    .iter()
                    .zip(variances)
                    .map(|(p, v)| {
                        let n = p.spp as f64;
                        let d = p.pixels[i][c] as f64 - m;
                        (n - 1.0) * n * v[i][c] as f64 + n * d * d
                    })
                    .sum();
                (ss / (total - 1.0) / total).max(0.0) as f32
            })
        })
        .collect()
}

/// What [`merge`] wrote.
#[derive(Debug, Clone)]
pub struct MergeReport {
    /// Total samples per pixel.
    pub spp: u64,
    /// The merged sample ranges.
    pub ranges: Vec<SampleRange>,
    /// The variance image, if written.
    pub variance: Option<PathBuf>,
}

/// Merges renders into `out`: the spp-weighted mean, with a header holding the total spp,
/// the merged sample ranges and the list of parts. With `variance`, every part needs its
/// `.variance.exr` beside it, and the pooled variance goes beside `out`.
pub fn merge(inputs: &[PathBuf], out: &Path, variance: bool) -> Result<MergeReport, String> {
    if inputs.is_empty() {
        return Err("merge: expected at least one input EXR".into());
    }
    let parts = inputs
        .iter()
        .map(|p| Part::read(p))
        .collect::<Result<Vec<_>, _>>()?;
    check_compatible(&parts)?;
    let variances = if variance {
        let mut v = Vec::with_capacity(parts.len());
        for p in &parts {
            let vp = variance_path(&p.path);
            if !vp.exists() {
                return Err(format!(
                    "--variance: {} has no variance image {} beside it (render the parts with --variance)",
                    p.path.display(),
                    vp.display()
                ));
            }
            let part = Part::read(&vp)?;
            if (part.width, part.height) != (p.width, p.height)
                || part.spp != p.spp
                || part.ranges != p.ranges
                || part.meta["scene_hash"] != p.meta["scene_hash"]
            {
                return Err(format!(
                    "--variance: {} does not belong to {} (size, spp, samples or scene differ)",
                    vp.display(),
                    p.path.display()
                ));
            }
            v.push(part.pixels);
        }
        Some(v)
    } else {
        None
    };

    let first = &parts[0];
    let spp: u64 = parts.iter().map(|p| p.spp).sum();
    let ranges = normalise(
        parts
            .iter()
            .flat_map(|p| p.ranges.iter().copied())
            .collect(),
    );
    let mut meta: Vec<(String, String)> = Vec::new();
    for k in ["scene", "scene_hash"] {
        if let Some(v) = first.meta.get(k) {
            meta.push((k.into(), v.clone()));
        }
    }
    meta.push(("spp".into(), spp.to_string()));
    let seeds: std::collections::BTreeSet<u64> = ranges.iter().map(|r| r.seed).collect();
    if seeds.len() == 1 {
        meta.push(("seed".into(), ranges[0].seed.to_string()));
    }
    if ranges.len() == 1 {
        meta.push(("seed_offset".into(), ranges[0].start.to_string()));
    }
    meta.push(("sample_ranges".into(), format_ranges(&ranges)));
    for k in SETTINGS {
        meta.push((k.into(), first.meta[k].clone()));
    }
    let seconds: f64 = parts
        .iter()
        .filter_map(|p| p.meta.get("render_seconds")?.parse::<f64>().ok())
        .sum();
    meta.push(("render_seconds".into(), format!("{seconds:.3}")));
    meta.push((
        "parts".into(),
        parts
            .iter()
            .map(|p| format!("{} ({} spp)", p.path.display(), p.spp))
            .collect::<Vec<_>>()
            .join(", "),
    ));
    meta.push(("version".into(), env!("CARGO_PKG_VERSION").into()));

    let mean = weighted_mean(&parts);
    write_exr(out, first.width, first.height, &mean, &meta)?;
    let variance = match variances {
        Some(v) => {
            let var = pooled_variance(&parts, &v, &mean);
            let vp = variance_path(out);
            write_exr(&vp, first.width, first.height, &var, &meta)?;
            Some(vp)
        }
        None => None,
    };
    Ok(MergeReport {
        spp,
        ranges,
        variance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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

    fn part(spp: u64, px: Vec<[f32; 3]>) -> Part {
        Part {
            path: PathBuf::from("p.exr"),
            width: px.len() as u32,
            height: 1,
            pixels: px,
            meta: BTreeMap::new(),
            spp,
            ranges: vec![],
        }
    }

    #[test]
    fn pooled_variance_equals_the_single_sample_set() {
        // Samples 1, 2, 3 | 10, 20: pooled variance of the mean of all five.
        let xs = [1.0f64, 2.0, 3.0, 10.0, 20.0];
        let stats = |s: &[f64]| {
            let n = s.len() as f64;
            let m = s.iter().sum::<f64>() / n;
            let var = s.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
            (m, var / n)
        };
        let (m1, v1) = stats(&xs[..3]);
        let (m2, v2) = stats(&xs[3..]);
        let (m, v) = stats(&xs);
        let parts = [part(3, vec![[m1 as f32; 3]]), part(2, vec![[m2 as f32; 3]])];
        let mean = weighted_mean(&parts);
        assert!((mean[0][0] as f64 - m).abs() < 1e-5);
        let var = pooled_variance(&parts, &[vec![[v1 as f32; 3]], vec![[v2 as f32; 3]]], &mean);
        assert!(
            (var[0][0] as f64 - v).abs() < 1e-5 * v,
            "{} vs {v}",
            var[0][0]
        );
    }
}
