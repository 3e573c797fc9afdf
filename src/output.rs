//! Image output: OpenEXR float RGB (linear sRGB) with render metadata in the header, and an
//! 8-bit sRGB PNG preview.
//!
//! Files are written whole or not at all: the data goes to a temporary file beside the
//! target, which is renamed over it only when the write succeeded, so an interrupted or
//! failed write leaves any previous file intact.

use crate::color;
use std::path::{Path, PathBuf};

/// A temporary path beside `target` (same directory, so the rename is atomic).
fn temp_beside(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "image".into());
    target.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Runs `write` on a temporary file and renames it over `target` if it succeeded.
pub fn write_atomically(
    target: &Path,
    write: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), String> {
    if let Some(dir) = target.parent() {
        if !dir.as_os_str().is_empty() && !dir.is_dir() {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("{}: cannot create directory: {e}", dir.display()))?;
        }
    }
    let tmp = temp_beside(target);
    match write(&tmp) {
        Ok(()) => std::fs::rename(&tmp, target).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            format!(
                "{}: cannot move the finished image into place: {e}",
                target.display()
            )
        }),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(format!("{}: {e}", target.display()))
        }
    }
}

/// Writes a float RGB EXR; `metadata` goes into the header as text attributes.
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    metadata: &[(String, String)],
) -> Result<(), String> {
    use exr::meta::attribute::{AttributeValue, Text};
    use exr::prelude::*;
    if rgb.len() != width as usize * height as usize {
        return Err(format!(
            "{}: {} pixels given for a {width}x{height} image",
            path.display(),
            rgb.len()
        ));
    }
    let w = width as usize;
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let c = rgb[p.y() * w + p.x()];
        (c[0], c[1], c[2])
    });
    let mut attrs = LayerAttributes::named("");
    attrs.software_name = Some(Text::from("stokes"));
    for (k, v) in metadata {
        attrs.other.insert(
            Text::from(format!("stokes:{k}").as_str()),
            AttributeValue::Text(Text::from(v.as_str())),
        );
    }
    let layer = Layer::new(
        (w, height as usize),
        attrs,
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .map_err(|e| format!("cannot write EXR: {e}"))
    })
}

/// An image read back: width, height, RGB pixels and `stokes:*` header attributes.
pub type ExrImage = (u32, u32, Vec<[f32; 3]>, Vec<(String, String)>);

/// Reads the RGB channels and the `stokes:*` text attributes of an EXR written by
/// [`write_exr`] (or any RGB(A) EXR).
pub fn read_exr(path: &Path) -> Result<ExrImage, String> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![[0f32; 3]; res.width() * res.height()]),
        |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .map_err(|e| format!("{}: cannot read EXR: {e}", path.display()))?;
    let size = image.layer_data.size;
    let mut meta = Vec::new();
    for (k, v) in &image.layer_data.attributes.other {
        if let exr::meta::attribute::AttributeValue::Text(t) = v {
            let key = k.to_string();
            if let Some(stripped) = key.strip_prefix("stokes:") {
                meta.push((stripped.to_string(), t.to_string()));
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
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> Result<(), String> {
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
        w.finish().map_err(|e| format!("cannot write PNG: {e}"))
    })
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
