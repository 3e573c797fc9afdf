//! `stokes merge`: renders split across machines, merged.
//!
//! Parts rendered with disjoint sample ranges (`--seed-offset`) of the same scene, size
//! and method are independent ([`crate::header`]), and their spp-weighted mean is the
//! render of the union of the ranges — the same image, up to float summation order, as
//! one render of all of them; their pooled variance is that render's variance.

use crate::error::Error;
use crate::header::{format_ranges, normalise, RenderHeader, SampleRange, VERSION};
use crate::output::{check_outputs, variance_path, write_exr_planes, Channels, Plane};
use crate::spectral_exr;
use crate::Result;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// An image written by `stokes render`, `reference` or `merge`, with its header.
#[derive(Debug, Clone)]
pub struct Part {
    /// The file.
    pub path: PathBuf,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Pixel means (or, in a variance image, variances of the mean).
    pub pixels: Vec<[f32; 3]>,
    /// The channels beside R, G and B (a spectral render's bins), likewise.
    pub planes: Vec<Plane>,
    /// What it holds and how it was made.
    pub header: RenderHeader,
}

impl Part {
    /// Reads an EXR and its header; errors name the file and the missing or malformed
    /// attribute.
    pub fn read(path: &Path) -> Result<Part> {
        let mut image = Channels::read(path)?;
        let attrs: BTreeMap<String, String> = image.stokes_attributes().into_iter().collect();
        let header = RenderHeader::from_attributes(path, &attrs)?;
        let pixels = image.take_rgb().ok_or_else(|| {
            Error::about(
                path,
                "has no R, G and B channels: it is not a stokes render",
            )
        })?;
        Ok(Part {
            path: path.to_path_buf(),
            width: image.width,
            height: image.height,
            pixels,
            planes: image.planes,
            header,
        })
    }

    /// Samples per pixel.
    pub fn spp(&self) -> u64 {
        self.header.spp()
    }

    /// Reads the variance image beside this one (`<stem>.variance.exr`) and checks that
    /// it belongs to it; `missing` says what to do when there is none.
    pub fn read_variance(&self, missing: &str) -> Result<Part> {
        let vp = variance_path(&self.path);
        if !vp.exists() {
            return Err(Error::about(
                &self.path,
                format!(
                    "has no variance image {} beside it ({missing})",
                    vp.display()
                ),
            ));
        }
        let v = Part::read(&vp)?;
        if (v.width, v.height) != (self.width, self.height)
            || plane_names(&v.planes) != plane_names(&self.planes)
            || v.header.ranges != self.header.ranges
            || v.header.scene_hash != self.header.scene_hash
        {
            return Err(Error::about(
                vp,
                format!(
                    "does not belong to {} (size, channels, spp, samples or scene differ)",
                    self.path.display()
                ),
            ));
        }
        Ok(v)
    }
}

/// Checks that parts can be merged: same size, scene and settings, disjoint sample
/// ranges. Errors are [`Error::About`] a part that does not fit.
pub fn check_compatible(parts: &[Part]) -> Result<()> {
    let Some(a) = parts.first() else {
        return Err(Error::Other("nothing to merge".into()));
    };
    for b in &parts[1..] {
        let pa = a.path.display();
        let unlike = |rest: String| Err(Error::about(&b.path, rest));
        if (a.width, a.height) != (b.width, b.height) {
            return unlike(format!(
                "is {}x{} but {pa} is {}x{}: parts must have the same size",
                b.width, b.height, a.width, a.height
            ));
        }
        if plane_names(&a.planes) != plane_names(&b.planes) {
            return unlike(format!(
                "has {} but {pa} has {}: parts must have the same channels (render them with the same --spectral-bins and --spectral-range)",
                describe_planes(&b.planes),
                describe_planes(&a.planes)
            ));
        }
        if a.header.scene_hash != b.header.scene_hash {
            return unlike(format!(
                "is a render of {} but {pa} of {}: parts must render the same scene file",
                b.header.scene_label(),
                a.header.scene_label()
            ));
        }
        if let Some(m) = a.header.mismatch(&b.header) {
            return unlike(format!(
                "was rendered with {k} = {} but {pa} with {k} = {}: parts must use the same settings",
                m.theirs,
                m.ours,
                k = m.key
            ));
        }
    }
    for (i, a) in parts.iter().enumerate() {
        for b in &parts[i + 1..] {
            for ra in &a.header.ranges {
                for rb in &b.header.ranges {
                    if let Some(o) = ra.overlap(rb) {
                        return Err(Error::about(
                            &a.path,
                            format!(
                                "and {} both hold samples {}..{} of seed {}: they are not independent (give each part its own --seed-offset, e.g. i·spp for part i)",
                                b.path.display(),
                                o.start,
                                o.end,
                                o.seed
                            ),
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

/// The names of `planes`, in order.
pub fn plane_names(planes: &[Plane]) -> Vec<&str> {
    planes.iter().map(|p| p.name.as_str()).collect()
}

/// "no channels beside R, G, B" or "N channels beside R, G, B (first … last)".
fn describe_planes(planes: &[Plane]) -> String {
    match (planes.first(), planes.last()) {
        (Some(a), Some(b)) => format!(
            "{} channels beside R, G, B ({} … {})",
            planes.len(),
            a.name,
            b.name
        ),
        _ => "no channels beside R, G, B".into(),
    }
}

/// The spp-weighted mean of one value over the parts, `value(i)` being part i's.
fn pooled_mean(spp: &[f64], value: impl Fn(usize) -> f32) -> f32 {
    let total: f64 = spp.iter().sum();
    let s: f64 = spp
        .iter()
        .enumerate()
        .map(|(i, n)| n * value(i) as f64)
        .sum();
    (s / total) as f32
}

/// The variance of the merged mean `m` of one value from the parts' spp `n_i`, means
/// `mean(i)` and variances of the mean `var(i)` ([`pooled_variance`]).
fn pooled_var(spp: &[f64], m: f32, mean: impl Fn(usize) -> f32, var: impl Fn(usize) -> f32) -> f32 {
    let total: f64 = spp.iter().sum();
    if total < 2.0 {
        return 0.0;
    }
    let m = m as f64;
    let ss: f64 = spp
        .iter()
        .enumerate()
        .map(|(i, &n)| {
            let d = mean(i) as f64 - m;
            (n - 1.0) * n * var(i) as f64 + n * d * d
        })
        .sum();
    (ss / (total - 1.0) / total).max(0.0) as f32
}

/// Each part's spp, as floats.
fn spps(parts: &[Part]) -> Vec<f64> {
    parts.iter().map(|p| p.spp() as f64).collect()
}

/// The spp-weighted mean of the parts' pixels.
pub fn weighted_mean(parts: &[Part]) -> Vec<[f32; 3]> {
    let spp = spps(parts);
    let n = parts.first().map_or(0, |p| p.pixels.len());
    (0..n)
        .map(|i| std::array::from_fn(|c| pooled_mean(&spp, |k| parts[k].pixels[i][c])))
        .collect()
}

/// The spp-weighted mean of the parts' other channels (checked alike).
pub fn weighted_mean_planes(parts: &[Part]) -> Vec<Plane> {
    let spp = spps(parts);
    let Some(first) = parts.first() else {
        return Vec::new();
    };
    (0..first.planes.len())
        .map(|c| Plane {
            name: first.planes[c].name.clone(),
            data: (0..first.planes[c].data.len())
                .map(|i| pooled_mean(&spp, |k| parts[k].planes[c].data[i]))
                .collect(),
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
    let spp = spps(parts);
    (0..mean.len())
        .map(|i| {
            std::array::from_fn(|c| {
                pooled_var(
                    &spp,
                    mean[i][c],
                    |k| parts[k].pixels[i][c],
                    |k| variances[k][i][c],
                )
            })
        })
        .collect()
}

/// [`pooled_variance`] of the other channels: `variances[k]` are part k's variance
/// planes, `mean` the merged planes.
pub fn pooled_variance_planes(
    parts: &[Part],
    variances: &[Vec<Plane>],
    mean: &[Plane],
) -> Vec<Plane> {
    let spp = spps(parts);
    mean.iter()
        .enumerate()
        .map(|(c, m)| Plane {
            name: m.name.clone(),
            data: (0..m.data.len())
                .map(|i| {
                    pooled_var(
                        &spp,
                        m.data[i],
                        |k| parts[k].planes[c].data[i],
                        |k| variances[k][c].data[i],
                    )
                })
                .collect(),
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

/// The header of the merge of `parts` (checked compatible): the first part's scene and
/// method, every part's samples and seconds, and the list of parts.
pub fn merged_header(parts: &[Part]) -> RenderHeader {
    let first = &parts[0].header;
    RenderHeader {
        ranges: normalise(
            parts
                .iter()
                .flat_map(|p| p.header.ranges.iter().copied())
                .collect(),
        ),
        render_seconds: parts.iter().map(|p| p.header.render_seconds).sum(),
        stopped: None,
        time_budget: None,
        nonfinite_samples: parts.iter().map(|p| p.header.nonfinite_samples).sum(),
        parts: Some(
            parts
                .iter()
                .map(|p| format!("{} ({} spp)", p.path.display(), p.spp()))
                .collect::<Vec<_>>()
                .join(", "),
        ),
        version: VERSION.into(),
        ..first.clone()
    }
}

/// Merges renders into `out`: the spp-weighted mean, with a header holding the total spp,
/// the merged sample ranges and the list of parts. With `variance`, every part needs its
/// `.variance.exr` beside it, and the pooled variance goes beside `out`.
pub fn merge(inputs: &[PathBuf], out: &Path, variance: bool) -> Result<MergeReport> {
    let vp = variance_path(out);
    let mut outputs = vec![("-o", out)];
    if variance {
        outputs.push(("--variance", vp.as_path()));
    }
    check_outputs(&outputs)?;
    crate::output::check_exr_name("-o", out)?;
    if inputs.is_empty() {
        // The command line requires inputs: only a library caller gets here.
        return Err(Error::Other(
            "merge: expected at least one input EXR".into(),
        ));
    }
    let parts = inputs
        .iter()
        .map(|p| Part::read(p))
        .collect::<Result<Vec<_>, _>>()?;
    check_compatible(&parts)?;
    let variances = if variance {
        let read = |p: &Part| {
            p.read_variance("render the parts with --variance")
                .map(|v| (v.pixels, v.planes))
                .map_err(|e| Error::option("--variance", e))
        };
        Some(parts.iter().map(read).collect::<Result<Vec<_>, _>>()?)
    } else {
        None
    };
    let header = merged_header(&parts);
    let meta = header.attributes();
    let (width, height) = (parts[0].width, parts[0].height);
    let mean = weighted_mean(&parts);
    let planes = weighted_mean_planes(&parts);
    let layout = spectral_exr::layout_attributes(&planes, false);
    write_exr_planes(out, width, height, &mean, &planes, &meta, layout)?;
    let variance = match variances {
        Some(v) => {
            let (rgb, other): (Vec<_>, Vec<_>) = v.into_iter().unzip();
            let var = pooled_variance(&parts, &rgb, &mean);
            let var_planes = pooled_variance_planes(&parts, &other, &planes);
            let layout = spectral_exr::layout_attributes(&planes, true);
            write_exr_planes(&vp, width, height, &var, &var_planes, &meta, layout)?;
            Some(vp)
        }
        None => None,
    };
    Ok(MergeReport {
        spp: header.spp(),
        ranges: header.ranges,
        variance,
    })
}

/// The one-line report of a merge, as `stokes merge` prints it.
pub fn describe(report: &MergeReport, inputs: usize, out: &Path) -> String {
    format!(
        "merged {inputs} renders: {} spp (samples {}) → {}{}",
        report.spp,
        format_ranges(&report.ranges),
        out.display(),
        report
            .variance
            .as_ref()
            .map(|v| format!(", {}", v.display()))
            .unwrap_or_default()
    )
}

/// Parses `START..END`, the sample indices `--expect` asks for.
pub fn parse_expected(text: &str) -> std::result::Result<(u64, u64), String> {
    let bad = || format!("expected START..END (sample indices, START < END), found {text:?}");
    let (a, b) = text.split_once("..").ok_or_else(bad)?;
    let (a, b): (u64, u64) = (a.parse().map_err(|_| bad())?, b.parse().map_err(|_| bad())?);
    if a >= b {
        return Err(bad());
    }
    Ok((a, b))
}

/// How much of samples `[start, end)` `ranges` hold, of the seed of their first range:
/// `complete: 32 of the 32 spp asked for (samples 0..32)` or `incomplete: 24 of the 32 spp
/// asked for (samples 0..32); missing part 1 (samples 8..16)`. With `part_spp` K, part i
/// is samples `[i·K, (i+1)·K)` and the missing samples are named by part (`samples
/// 20..24 of 16..24` for a piece of one); without it, as ranges.
pub fn completeness(ranges: &[SampleRange], start: u64, end: u64, part_spp: Option<u64>) -> String {
    let seed = ranges.first().map_or(0, |r| r.seed);
    let held: Vec<SampleRange> = ranges.iter().filter(|r| r.seed == seed).copied().collect();
    let gaps = crate::header::gaps(&held, start, end);
    let asked = end - start;
    let missing: u64 = gaps.iter().map(|(a, b)| b - a).sum();
    let head = format!(
        "{} of the {asked} spp asked for (samples {start}..{end} of seed {seed})",
        asked - missing
    );
    if gaps.is_empty() {
        return format!("complete: {head}");
    }
    let named: Vec<String> = match part_spp.filter(|&k| k > 0) {
        Some(k) => gaps
            .iter()
            .flat_map(|&(a, b)| {
                let mut pieces = Vec::new();
                let mut x = a;
                while x < b {
                    let i = x / k;
                    let (lo, hi) = (i * k, (i + 1) * k);
                    let y = b.min(hi);
                    pieces.push(if x == lo && y == hi {
                        format!("part {i} (samples {x}..{y})")
                    } else {
                        format!("part {i} (samples {x}..{y} of {lo}..{hi})")
                    });
                    x = y;
                }
                pieces
            })
            .collect(),
        None => gaps
            .iter()
            .map(|(a, b)| format!("samples {a}..{b}"))
            .collect(),
    };
    format!("incomplete: {head}; missing {}", named.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(spp: u64, px: Vec<[f32; 3]>) -> Part {
        let header = RenderHeader {
            scene: "s.toml".into(),
            scene_hash: crate::header::scene_hash(b""),
            ranges: vec![crate::header::SampleRange {
                seed: 0,
                start: 0,
                end: spp,
            }],
            method: crate::method::Method::default()
                .with_tracking(crate::medium::tracking::Tracking::Classic),
            max_depth: -1,
            render_seconds: 0.0,
            stopped: None,
            time_budget: None,
            nonfinite_samples: 0,
            parts: None,
            version: VERSION.into(),
        };
        Part {
            path: PathBuf::from("p.exr"),
            width: px.len() as u32,
            height: 1,
            pixels: px,
            planes: Vec::new(),
            header,
        }
    }

    #[test]
    fn completeness_names_the_missing_parts() {
        let r = |start, end| SampleRange {
            seed: 3,
            start,
            end,
        };
        assert_eq!(
            completeness(&[r(0, 8), r(24, 32)], 0, 32, Some(8)),
            "incomplete: 16 of the 32 spp asked for (samples 0..32 of seed 3); missing part 1 (samples 8..16), part 2 (samples 16..24)"
        );
        assert_eq!(
            completeness(&[r(0, 8), r(8, 13)], 0, 16, Some(8)),
            "incomplete: 13 of the 16 spp asked for (samples 0..16 of seed 3); missing part 1 (samples 13..16 of 8..16)"
        );
        assert_eq!(
            completeness(&[r(0, 16)], 0, 16, None),
            "complete: 16 of the 16 spp asked for (samples 0..16 of seed 3)"
        );
        assert_eq!(parse_expected("0..32"), Ok((0, 32)));
        assert!(parse_expected("5..5").is_err());
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
