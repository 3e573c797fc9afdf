//! Image output: OpenEXR float RGB (linear sRGB) with render metadata in the header, and an
//! 8-bit sRGB PNG preview.
//!
//! Files are written whole or not at all: the data goes to a temporary file beside the
//! target, which is renamed over it only when the write succeeded, so an interrupted or
//! failed write leaves any previous file intact.

use crate::color;
use crate::error::{Detail, Error};
use crate::header::RenderHeader;
use crate::integrator::render::{Film, ProgressiveResult};
use crate::spectral_exr;
use crate::Result;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// A temporary path beside `target` (same directory, so the rename is atomic).
fn temp_beside(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "image".into());
    target.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Runs `write` on a temporary file and renames it over `target` if it succeeded. What
/// `write` reports goes out as an [`Error::File`] of `target`.
pub fn write_atomically(
    target: &Path,
    write: impl FnOnce(&Path) -> Result<(), Detail>,
) -> Result<()> {
    if let Some(dir) = target.parent() {
        if !dir.as_os_str().is_empty() && !dir.is_dir() {
            std::fs::create_dir_all(dir)
                .map_err(|e| Error::file(dir, None, format!("cannot create directory: {e}")))?;
        }
    }
    let tmp = temp_beside(target);
    match write(&tmp) {
        Ok(()) => std::fs::rename(&tmp, target).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            Error::file(
                target,
                None,
                format!("cannot move the finished image into place: {e}"),
            )
        }),
        Err(detail) => {
            let _ = std::fs::remove_file(&tmp);
            Err(Error::file(target, None, detail))
        }
    }
}

/// Checks, before any work, that every output can be written: `outputs` pairs the
/// command-line option that names a file with its path. Each must be a file name (not a
/// directory), distinct from the others, in a directory that exists and takes a new file
/// or can be created (the nearest existing ancestor must be a writable directory). A
/// render that would fail at its last step fails here instead, in milliseconds.
///
/// The check leaves nothing behind: writability is tested with a probe file that is
/// removed at once, and missing directories are not created (the writes do that).
///
/// Errors are [`Error::Option`]s of the option and its path (`-o out/x.exr`).
pub fn check_outputs(outputs: &[(&str, &Path)]) -> Result<()> {
    for (i, &(option, path)) in outputs.iter().enumerate() {
        check_output(option, path)?;
        if let Some(&(first, _)) = outputs[..i].iter().find(|(_, p)| same_file_name(p, path)) {
            return Err(output_error(
                option,
                path,
                "a file of its own",
                format!("the file {first} writes"),
            ));
        }
    }
    Ok(())
}

/// `{option} {path}: expected {expected}, found {found}`.
fn output_error(option: &str, path: &Path, expected: &str, found: impl Into<String>) -> Error {
    Error::option(
        &format!("{option} {}", path.display()),
        Detail::Expected {
            expected: expected.into(),
            found: found.into(),
        },
    )
}

/// Checks that the image `option` names ends in .exr: an OpenEXR image written under a
/// .png name fools every viewer.
pub fn check_exr_name(option: &str, path: &Path) -> Result<()> {
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    match is_exr {
        true => Ok(()),
        false => Err(output_error(
            option,
            path,
            "a file name ending in .exr (stokes writes OpenEXR; --png adds a PNG preview)",
            format!("{:?}", path.file_name().unwrap_or_default()),
        )),
    }
}

/// [`check_outputs`] for one path.
fn check_output(option: &str, path: &Path) -> Result<()> {
    let bad = |expected: &str, found: String| Err(output_error(option, path, expected, found));
    if path.file_name().is_none() || path.as_os_str().to_string_lossy().ends_with('/') {
        return bad("a file name", "a path without one".into());
    }
    if path.is_dir() {
        return bad("a file to write", "a directory".into());
    }
    // The nearest ancestor that exists: the directory to write in, or the one in which
    // the missing directories will be created.
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    let mut dir = parent.unwrap_or(Path::new("."));
    while !dir.exists() {
        match dir.parent().filter(|p| !p.as_os_str().is_empty()) {
            Some(p) => dir = p,
            None => {
                dir = Path::new(".");
                break;
            }
        }
    }
    if !dir.is_dir() {
        return bad(
            &format!("a directory at {}", dir.display()),
            "a file".into(),
        );
    }
    let probe = dir.join(format!(".stokes-probe.{}.tmp", std::process::id()));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        // Ours from an earlier check of this process: the directory took it then.
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
        Err(e) => bad(
            "a directory that takes new files",
            format!("{} refusing one: {e}", dir.display()),
        ),
    }
}

/// Whether two output paths name the same file (as far as can be told before either
/// exists: the same file name in the same existing directory, or equal paths).
fn same_file_name(a: &Path, b: &Path) -> bool {
    let key = |p: &Path| -> PathBuf {
        match (p.parent(), p.file_name()) {
            (Some(dir), Some(name)) => {
                let dir = if dir.as_os_str().is_empty() {
                    Path::new(".")
                } else {
                    dir
                };
                dir.canonicalize()
                    .map(|d| d.join(name))
                    .unwrap_or_else(|_| p.components().collect())
            }
            _ => p.components().collect(),
        }
    };
    key(a) == key(b)
}

/// `<dir>/<stem>.variance.exr` beside `<dir>/<stem>.exr`: where a render keeps the
/// variance of its pixel means.
pub fn variance_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}.variance.exr"))
}

/// A named channel beside R, G and B (a spectral bin, an alpha), pixel-major like the RGB.
#[derive(Debug, Clone, PartialEq)]
pub struct Plane {
    /// The channel name.
    pub name: String,
    /// One value per pixel, row by row.
    pub data: Vec<f32>,
}

/// Writes a float RGB EXR; `metadata` goes into the header as text attributes.
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    metadata: &[(String, String)],
) -> Result<()> {
    write_exr_planes(path, width, height, rgb, &[], metadata, &[])
}

/// Writes a float EXR of R, G, B and `planes`; `metadata` goes into the header as
/// `stokes:*` text attributes and `plain` as text attributes under their own names (the
/// spectral layout's `spectralLayoutVersion`, `emissiveUnits`).
pub fn write_exr_planes(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    planes: &[Plane],
    metadata: &[(String, String)],
    plain: &[(&str, &str)],
) -> Result<()> {
    use exr::meta::attribute::{AttributeValue, Text};
    use exr::prelude::*;
    let n = width as usize * height as usize;
    if let Some(bad) = std::iter::once(rgb.len())
        .chain(planes.iter().map(|p| p.data.len()))
        .find(|&len| len != n)
    {
        // `crate::Error`: exr's prelude has an `Error` of its own.
        return Err(crate::Error::file(
            path,
            None,
            format!("{bad} pixels given for a {width}x{height} image"),
        ));
    }
    let mut list: Vec<AnyChannel<FlatSamples>> = (0..3)
        .map(|c| {
            let data = rgb.iter().map(|p| p[c]).collect();
            AnyChannel::new(["R", "G", "B"][c], FlatSamples::F32(data))
        })
        .collect();
    list.extend(
        planes
            .iter()
            .map(|p| AnyChannel::new(p.name.as_str(), FlatSamples::F32(p.data.clone()))),
    );
    let mut attrs = LayerAttributes::named("");
    attrs.software_name = Some(Text::from("stokes"));
    let text = |v: &str| AttributeValue::Text(utf8_text(v));
    for (k, v) in metadata {
        attrs
            .other
            .insert(utf8_text(&format!("stokes:{k}")), text(v));
    }
    for (k, v) in plain {
        attrs.other.insert(utf8_text(k), text(v));
    }
    let layer = Layer::new(
        (width as usize, height as usize),
        attrs,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list.into()),
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .map_err(|e| format!("cannot write EXR: {e}").into())
    })
}

/// `text` as an EXR text attribute, in UTF-8 as OpenEXR and OpenImageIO read it (the
/// exr crate's own constructors take 8-bit characters only, and panic on others).
fn utf8_text(text: &str) -> exr::meta::attribute::Text {
    exr::meta::attribute::Text::from_slice_unchecked(text.as_bytes())
}

/// An EXR text attribute as a string: UTF-8, or else one character per byte (Latin-1).
fn attribute_string(text: &exr::meta::attribute::Text) -> String {
    match std::str::from_utf8(text.bytes()) {
        Ok(s) => s.to_string(),
        Err(_) => text.to_string(),
    }
}

/// Every channel of an EXR's first layer, in the file's (alphabetical) order.
#[derive(Debug, Clone)]
pub struct Channels {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// The channels, as 32-bit floats.
    pub planes: Vec<Plane>,
    /// The header's text attributes, by their full names.
    pub text: Vec<(String, String)>,
}

impl Channels {
    /// Reads every channel and text attribute of the first layer of `path`.
    pub fn read(path: &Path) -> Result<Channels> {
        let image = exr::prelude::read_first_flat_layer_from_file(path)
            .map_err(|e| crate::Error::file(path, None, format!("cannot read EXR: {e}")))?;
        let layer = image.layer_data;
        let planes = layer
            .channel_data
            .list
            .iter()
            .map(|c| Plane {
                name: c.name.to_string(),
                data: c.sample_data.values_as_f32().collect(),
            })
            .collect();
        let mut text = Vec::new();
        let all = layer.attributes.other.iter().chain(&image.attributes.other);
        for (k, v) in all {
            if let exr::meta::attribute::AttributeValue::Text(t) = v {
                text.push((attribute_string(k), attribute_string(t)));
            }
        }
        Ok(Channels {
            width: layer.size.width() as u32,
            height: layer.size.height() as u32,
            planes,
            text,
        })
    }

    /// The `stokes:*` attributes, without the prefix.
    pub fn stokes_attributes(&self) -> Vec<(String, String)> {
        self.text
            .iter()
            .filter_map(|(k, v)| Some((k.strip_prefix("stokes:")?.to_string(), v.clone())))
            .collect()
    }

    /// Splits off R, G and B as pixels, leaving the other channels; `None` if one of the
    /// three is missing.
    pub fn take_rgb(&mut self) -> Option<Vec<[f32; 3]>> {
        let mut take = |name: &str| {
            let i = self.planes.iter().position(|p| p.name == name)?;
            Some(self.planes.remove(i).data)
        };
        let (r, g, b) = (take("R")?, take("G")?, take("B")?);
        Some((0..r.len()).map(|i| [r[i], g[i], b[i]]).collect())
    }
}

/// An image read back: width, height, RGB pixels and `stokes:*` header attributes.
pub type ExrImage = (u32, u32, Vec<[f32; 3]>, Vec<(String, String)>);

/// Reads the RGB channels and the `stokes:*` text attributes of an EXR written by
/// [`write_exr`] (or any RGB(A) EXR).
pub fn read_exr(path: &Path) -> Result<ExrImage> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![[0f32; 3]; res.width() * res.height()]),
        |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .map_err(|e| crate::Error::file(path, None, format!("cannot read EXR: {e}")))?;
    let size = image.layer_data.size;
    let mut meta = Vec::new();
    for (k, v) in &image.layer_data.attributes.other {
        if let exr::meta::attribute::AttributeValue::Text(t) = v {
            let key = attribute_string(k);
            if let Some(stripped) = key.strip_prefix("stokes:") {
                meta.push((stripped.to_string(), attribute_string(t)));
            }
        }
    }
    Ok((
        size.width() as u32,
        size.height() as u32,
        image.layer_data.channel_data.pixels.1,
        meta,
    ))
}

/// Writes an 8-bit sRGB PNG preview (values clipped to [0, 1]).
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> Result<()> {
    let bytes: Vec<u8> = rgb
        .iter()
        .flat_map(|c| c.map(|v| (color::srgb_encode(v) * 255.0 + 0.5) as u8))
        .collect();
    write_atomically(path, |tmp| {
        let file = std::fs::File::create(tmp).map_err(|e| format!("cannot create PNG: {e}"))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut w = enc
            .write_header()
            .map_err(|e| format!("cannot write PNG: {e}"))?;
        w.write_image_data(&bytes)
            .map_err(|e| format!("cannot write PNG: {e}"))?;
        w.finish()
            .map_err(|e| format!("cannot write PNG: {e}").into())
    })
}

/// The files a render writes: the EXR of the pixel means and, if asked for, the variance
/// of each mean (`<stem>.variance.exr`), an sRGB PNG preview (`<stem>.png`) and
/// statistics as JSON.
#[derive(Debug, Clone)]
pub struct RenderFiles {
    /// The EXR.
    pub exr: PathBuf,
    /// Whether to write the variance image.
    pub variance: bool,
    /// Whether to write the PNG preview.
    pub png: bool,
    /// Where to write statistics, if anywhere.
    pub stats_json: Option<PathBuf>,
}

impl RenderFiles {
    /// Every file to be written, with the option that names it.
    pub fn paths(&self) -> Vec<(&'static str, PathBuf)> {
        let mut v = vec![("-o", self.exr.clone())];
        if self.variance {
            v.push(("--variance", variance_path(&self.exr)));
        }
        if self.png {
            v.push(("--png", self.exr.with_extension("png")));
        }
        if let Some(p) = &self.stats_json {
            v.push(("--stats-json", p.clone()));
        }
        v
    }

    /// Checks before any work that every file can be written ([`check_outputs`]).
    pub fn check(&self) -> Result<()> {
        // The image first (a directory, then a name that is not .exr), then all together.
        check_outputs(&[("-o", &self.exr)])?;
        check_exr_name("-o", &self.exr)?;
        let paths = self.paths();
        let named: Vec<(&str, &Path)> = paths.iter().map(|(o, p)| (*o, p.as_path())).collect();
        check_outputs(&named)
    }

    /// Writes the images of `film` with `header`'s attributes; a spectral film's bins go
    /// into both EXRs in the OpenEXR spectral layout, beside R, G and B.
    pub fn write_images(&self, film: &Film, header: &RenderHeader) -> Result<()> {
        let (w, h) = (film.width, film.height);
        let meta = header.attributes();
        let mean = film.mean();
        let planes = film.spectral_mean();
        let layout = spectral_exr::layout_attributes(&planes, false);
        write_exr_planes(&self.exr, w, h, &mean, &planes, &meta, layout)?;
        if self.png {
            write_png(&self.exr.with_extension("png"), w, h, &mean)?;
        }
        if self.variance {
            let layout = spectral_exr::layout_attributes(&planes, true);
            write_exr_planes(
                &variance_path(&self.exr),
                w,
                h,
                &film.variance_of_mean(),
                &film.spectral_variance_of_mean(),
                &meta,
                layout,
            )?;
        }
        Ok(())
    }
}

/// What `stokes render --stats-json` writes.
#[derive(Debug, Clone, Serialize)]
pub struct RenderStats {
    /// Seconds of rendering.
    pub seconds: f64,
    /// Samples per pixel rendered.
    pub spp: u32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Pixel samples per second.
    pub samples_per_second: f64,
    /// Rays traced (camera, bounce and shadow).
    pub rays: u64,
    /// Rays per second.
    pub rays_per_second: f64,
    /// `hwss` or `mono`.
    pub spectral: &'static str,
    /// `packet`, `packet8`, `lockstep` or `single`.
    pub ray_mode: &'static str,
    /// The share of packet lanes that carried a ray (packet modes).
    pub packet_lane_occupancy: Option<f64>,
    /// The share of busy lanes in the packet steps that started with a path inside a
    /// medium (packet modes, scenes with media).
    pub packet_medium_lane_occupancy: Option<f64>,
    /// The share of busy lanes in the packet steps that traced camera rays (packet modes).
    pub packet_camera_lane_occupancy: Option<f64>,
    /// `split` or `drop`.
    pub dispersion: &'static str,
    /// Samples dropped as NaN or infinite.
    pub nonfinite_samples: u64,
    /// The seed.
    pub seed: u64,
    /// The first sample index.
    pub seed_offset: u64,
    /// Passes rendered.
    pub passes: u32,
    /// Why the render ended.
    pub stopped: &'static str,
}

impl RenderStats {
    /// The statistics of a finished render with header `header`.
    pub fn new(done: &ProgressiveResult, header: &RenderHeader) -> RenderStats {
        use crate::method::Axis;
        let r = &done.render;
        let samples = r.film.width as f64 * r.film.height as f64 * r.film.spp as f64;
        let first = header.ranges.first();
        RenderStats {
            seconds: r.seconds,
            spp: r.film.spp,
            width: r.film.width,
            height: r.film.height,
            samples_per_second: samples / r.seconds,
            rays: r.stats.rays,
            rays_per_second: r.stats.rays as f64 / r.seconds,
            spectral: header.method.spectral.name(),
            ray_mode: header.method.rays.name(),
            packet_lane_occupancy: r.stats.occupancy(),
            packet_medium_lane_occupancy: r.stats.medium_occupancy(),
            packet_camera_lane_occupancy: r.stats.camera_occupancy(),
            dispersion: header.method.dispersion.name(),
            nonfinite_samples: r.stats.nonfinite,
            seed: first.map_or(0, |r| r.seed),
            seed_offset: first.map_or(0, |r| r.start),
            passes: done.passes,
            stopped: done.stopped.name(),
        }
    }

    /// Writes the statistics as pretty JSON.
    pub fn write(&self, path: &Path) -> Result<()> {
        // Plain numbers and names: serialising cannot fail, and has no place to blame.
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::Other(e.to_string()))?;
        write_atomically(path, |tmp| {
            std::fs::write(tmp, text + "\n").map_err(|e| format!("cannot write: {e}").into())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_keeps_the_old_file() {
        let dir = std::env::temp_dir().join(format!("stokes-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("img.exr");
        std::fs::write(&target, b"old").unwrap();
        let r = write_atomically(&target, |tmp| {
            std::fs::write(tmp, b"half").unwrap();
            Err("disk full".into())
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert!(
            std::fs::read_dir(&dir).unwrap().count() == 1,
            "temporary file left behind"
        );
    }

    #[test]
    fn output_checks_name_the_option_and_leave_nothing_behind() {
        let dir = std::env::temp_dir().join(format!("stokes-check-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(dir.join("file"), b"x").unwrap();
        let ok = dir.join("new/deeper/img.exr");
        assert_eq!(
            check_outputs(&[("-o", &ok), ("--png", &dir.join("a.png"))]).map_err(|e| e.to_string()),
            Ok(())
        );
        assert!(check_exr_name("-o", &dir.join("img.png"))
            .unwrap_err()
            .to_string()
            .contains("ending in .exr"));
        assert!(check_exr_name("-o", &dir.join("img.EXR")).is_ok());
        let bad: [(&[(&str, &Path)], &str); 5] = [
            (&[("-o", &dir.join("sub"))], "-o "),
            (&[("-o", &dir.join("file/img.exr"))], "found a file"),
            (&[("--png", &dir.join("file/new/img.png"))], "--png"),
            (&[("-o", &ok), ("--stats-json", &ok)], "the file -o writes"),
            (
                &[
                    ("-o", &dir.join("x.exr")),
                    ("--png", &dir.join("sub/../x.exr")),
                ],
                "--png",
            ),
        ];
        for (outputs, fragment) in bad {
            let e = check_outputs(outputs).unwrap_err().to_string();
            assert!(e.contains(fragment), "{outputs:?}: {e}");
        }
        // Nothing created: no directories, no probe files.
        let mut left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        left.sort();
        assert_eq!(left, ["file", "sub"]);
        assert_eq!(std::fs::read_dir(dir.join("sub")).unwrap().count(), 0);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn text_attributes_beyond_latin1_round_trip() {
        let dir = std::env::temp_dir().join(format!("stokes-utf8-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("ü.exr");
        let meta = vec![("scene".to_string(), "scènes/λ–note 雪.toml".to_string())];
        write_exr(&target, 1, 1, &[[1.0; 3]], &meta).unwrap();
        assert_eq!(read_exr(&target).unwrap().3, meta);
        let all = Channels::read(&target).unwrap().stokes_attributes();
        assert_eq!(all, meta);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn exr_round_trip_with_metadata() {
        let dir = std::env::temp_dir().join(format!("stokes-exr-{}", std::process::id()));
        let target = dir.join("rt.exr");
        let px: Vec<[f32; 3]> = (0..6).map(|i| [i as f32, 0.5, -1.0]).collect();
        write_exr(&target, 3, 2, &px, &[("spp".into(), "7".into())]).unwrap();
        let (w, h, back, meta) = read_exr(&target).unwrap();
        assert_eq!((w, h), (3, 2));
        assert_eq!(back, px);
        assert!(meta.contains(&("spp".to_string(), "7".to_string())));
    }
}
