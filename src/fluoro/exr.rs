//! Re-radiation matrices as bispectral OpenEXR images, in the spectral layout of Fichet,
//! Pacanowski and Wilkie ([`crate::spectral_exr`]), so that a matrix can be exchanged with
//! other spectral tools (colour-science, their reference renderer) rather than only as
//! the project's CSV.
//!
//! A matrix on `n` cells is one pixel with, at the cell centres λ₀ < … < λₙ₋₁:
//! - `T.<λk>nm`: the diagonal, the ordinary reflectance D(λk);
//! - `T.<λi>nm.<λo>nm` for every pair i < o: the re-radiated fraction m[i][o] = F·h (h
//!   the cell width), the numbers the CSV format writes above its diagonal;
//! - R, G, B: the diagonal's colour under D65, relative to D65's white (Y of a perfect
//!   white is 1), in linear sRGB, so that a viewer shows the surface's ordinary colour;
//! - the header attribute `spectralLayoutVersion`.
//!
//! Reading takes any number of pixels and averages each channel over them: a material
//! is uniform (bispectral textures do not exist yet). The diagonal channels must form an
//! evenly spaced grid (to 0.1% of a step, as for CSV; a non-uniform grid is rejected
//! rather than resampled, because the renderer's cells are uniform and resampling a
//! re-radiation matrix would change what was measured), every pair i < o of that grid
//! must be present, and no bispectral channel may use a wavelength off the grid or
//! re-radiate to a shorter or equal wavelength. Errors name the file and the first
//! channel at fault. Negative values are set to 0 and counted ([`ExrReport`]), as for CSV.

use super::import::{self, ImportReport};
use super::{Reradiation, MAX_CELLS};
use crate::color::xyz_to_linear_srgb;
use crate::error::{Detail, Error};
use crate::output::{write_exr_planes, Plane};
use crate::spectral_exr::{self, channel_name, SpectralChannel, LAYOUT_VERSION};
use crate::spectrum::{illuminant, reflectance_to_xyz, spectrum_to_xyz};
use crate::Result;
use std::fmt;
use std::path::Path;

/// The first bytes of every OpenEXR file.
pub const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Whether a file is OpenEXR: its magic number, or (for a file too short to tell) its
/// `.exr` extension.
pub fn is_exr(path: &Path, bytes: &[u8]) -> bool {
    bytes.starts_with(&MAGIC)
        || (bytes.len() < MAGIC.len()
            && path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("exr")))
}

/// What reading a bispectral EXR changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExrReport {
    /// How many pixels every channel was averaged over (1 for a matrix as written here).
    pub pixels: usize,
    /// Negative values set to 0 (no anti-Stokes entries can occur: such channels are
    /// errors).
    pub clamped: ImportReport,
}

impl ExrReport {
    /// Whether nothing was changed: one pixel, no negative values.
    pub fn is_clean(&self) -> bool {
        self.pixels == 1 && self.clamped.is_clean()
    }
}

impl fmt::Display for ExrReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if self.pixels != 1 {
            parts.push(format!(
                "averaged each channel over {} pixels (a uniform material: bispectral textures are not supported)",
                self.pixels
            ));
        }
        if !self.clamped.is_clean() {
            parts.push(format!(
                "set {} negative values to 0",
                self.clamped.clamped_negative
            ));
        }
        if parts.is_empty() {
            parts.push("imported as written".into());
        }
        f.write_str(&parts.join("; "))
    }
}

/// The channels of `rr` in the bispectral layout (module docs), R, G and B first; `None`
/// for a surface without a grid.
pub fn planes(rr: &Reradiation) -> Option<Vec<Plane>> {
    let n = rr.n;
    if n == 0 {
        return None;
    }
    let d65 = illuminant("D65").expect("D65 is built in");
    let white = spectrum_to_xyz(&d65).y;
    let rgb = xyz_to_linear_srgb(reflectance_to_xyz(&rr.diagonal, &d65) / white);
    let mut planes: Vec<Plane> = ["R", "G", "B"]
        .iter()
        .zip(rgb.to_array())
        .map(|(name, v)| Plane {
            name: name.to_string(),
            data: vec![v],
        })
        .collect();
    let centres: Vec<f32> = (0..n).map(|k| rr.cell_centre(k)).collect();
    for (i, &ci) in centres.iter().enumerate() {
        planes.push(Plane {
            name: channel_name(SpectralChannel::Reflective { nm: f64::from(ci) }),
            data: vec![rr.diagonal.eval(ci)],
        });
        for (o, &co) in centres.iter().enumerate().skip(i + 1) {
            planes.push(Plane {
                name: channel_name(SpectralChannel::Bispectral {
                    input: f64::from(ci),
                    output: f64::from(co),
                }),
                data: vec![rr.f[i * n + o] * rr.cell_nm],
            });
        }
    }
    Some(planes)
}

/// Writes `rr` to `path` as a one-pixel bispectral EXR (module docs), with `metadata` as
/// `stokes:*` header attributes. An error for a surface without a grid.
pub fn write(rr: &Reradiation, path: &Path, metadata: &[(String, String)]) -> Result<()> {
    let mut planes = planes(rr).ok_or_else(|| {
        Error::file(
            path,
            None,
            "no re-radiation grid to write (a diagonal-only surface)",
        )
    })?;
    let rgb: Vec<[f32; 3]> = vec![[planes[0].data[0], planes[1].data[0], planes[2].data[0]]];
    planes.drain(..3);
    write_exr_planes(path, 1, 1, &rgb, &planes, metadata, &[LAYOUT_VERSION])
}

/// A wavelength as a channel gives it, with the channel's name for errors.
struct At<'a> {
    name: &'a str,
    nm: f64,
}

/// Reads a bispectral EXR (module docs): the matrix and what the import changed.
pub fn read(path: &Path) -> Result<(Reradiation, ExrReport)> {
    let avg = spectral_exr::read_averaged(path)?;
    let fail = |detail: Detail| Error::file(path, None, detail);
    let mut diagonal: Vec<(At, f32)> = Vec::new();
    let mut pairs: Vec<(At, At, f32)> = Vec::new();
    for (name, c, v) in &avg.channels {
        match *c {
            SpectralChannel::Reflective { nm } => diagonal.push((At { name, nm }, *v)),
            SpectralChannel::Bispectral { input, output } => {
                if input >= output {
                    return Err(fail(Detail::expected(
                        format!("re-radiation to a longer wavelength in channel {name} (T.<λi>nm.<λo>nm with λi < λo; the diagonal is T.<λ>nm)"),
                        format!("{input} nm → {output} nm"),
                    )));
                }
                pairs.push((At { name, nm: input }, At { name, nm: output }, *v));
            }
            SpectralChannel::Emissive { .. } => {}
        }
    }
    if diagonal.is_empty() && pairs.is_empty() {
        let names: Vec<&str> = avg.channels.iter().map(|c| c.0.as_str()).collect();
        return Err(fail(Detail::expected(
            "a bispectral image: channels T.<λ>nm (the diagonal) and T.<λi>nm.<λo>nm (re-radiation)",
            if names.is_empty() {
                "no spectral channels".to_string()
            } else {
                format!("no T. channels (spectral channels: {})", names.join(", "))
            },
        )));
    }
    diagonal.sort_by(|a, b| a.0.nm.total_cmp(&b.0.nm));
    let n = diagonal.len();
    // Grid tolerance: 0.1% of a step (the CSV importer's), 0.001 nm for a single channel.
    let step = if n > 1 {
        (diagonal[n - 1].0.nm - diagonal[0].0.nm) / (n - 1) as f64
    } else {
        1.0
    };
    let tol = 1e-3 * step;
    let on_grid = |at: &At| -> Result<usize> {
        let k = diagonal.partition_point(|d| d.0.nm < at.nm - tol);
        match diagonal.get(k) {
            Some(d) if (d.0.nm - at.nm).abs() <= tol => Ok(k),
            _ => Err(fail(Detail::Text(format!(
                "channel {} uses {} nm, which has no diagonal channel T.{} (the diagonal \
                 channels' wavelengths are the matrix's grid)",
                at.name,
                at.nm,
                spectral_exr::format_nm(at.nm)
            )))),
        }
    };
    let mut m_pairs = Vec::with_capacity(pairs.len());
    for (i, o, v) in &pairs {
        m_pairs.push((on_grid(i)?, on_grid(o)?, *v, i.name));
    }
    if pairs.is_empty() {
        return Err(fail(Detail::expected(
            "a bispectral image: channels T.<λi>nm.<λo>nm beside the diagonal T.<λ>nm",
            format!(
                "only reflective channels ({} of them): a reflectance, not a re-radiation matrix (a scene can use it as {{ exr = \"...\" }})",
                n
            ),
        )));
    }
    if n > MAX_CELLS {
        return Err(fail(Detail::Text(format!(
            "{n} diagonal channels is more than the {MAX_CELLS} cells supported"
        ))));
    }
    for (k, (d, _)) in diagonal.iter().enumerate() {
        let expected = diagonal[0].0.nm + k as f64 * step;
        if k > 0 && d.nm == diagonal[k - 1].0.nm {
            return Err(fail(Detail::Text(format!(
                "channels {} and {} are the same wavelength, {} nm",
                diagonal[k - 1].0.name,
                d.name,
                d.nm
            ))));
        }
        if (d.nm - expected).abs() > tol {
            return Err(fail(Detail::Text(format!(
                "the diagonal channels must be evenly spaced (one per cell; a non-uniform grid \
                 is not resampled): channel {} is at {} nm where a uniform grid from {} to {} nm \
                 in steps of {} nm has {} nm",
                d.name,
                d.nm,
                diagonal[0].0.nm,
                diagonal[n - 1].0.nm,
                step as f32,
                expected as f32
            ))));
        }
    }
    let mut m: Vec<Vec<f32>> = vec![vec![0.0; n]; n];
    let mut seen = vec![None::<&str>; n * n];
    for (k, (_, v)) in diagonal.iter().enumerate() {
        m[k][k] = *v;
    }
    for &(i, o, v, name) in &m_pairs {
        if let Some(first) = seen[i * n + o] {
            return Err(fail(Detail::Text(format!(
                "channels {first} and {name} are the same pair of wavelengths"
            ))));
        }
        seen[i * n + o] = Some(name);
        m[i][o] = v;
    }
    for i in 0..n {
        for o in i + 1..n {
            if seen[i * n + o].is_none() {
                return Err(fail(Detail::Text(format!(
                    "missing channel {} (every pair λi < λo of the diagonal's {n} wavelengths \
                     must be present: expected {} bispectral channels, found {})",
                    channel_name(SpectralChannel::Bispectral {
                        input: diagonal[i].0.nm,
                        output: diagonal[o].0.nm
                    }),
                    n * (n - 1) / 2,
                    m_pairs.len()
                ))));
            }
        }
    }
    let centres: Vec<f32> = diagonal.iter().map(|d| d.0.nm as f32).collect();
    let (rr, clamped) = import::square(&centres, &m, &path.display().to_string(), false)?;
    Ok((
        rr,
        ExrReport {
            pixels: avg.pixels,
            clamped,
        },
    ))
}
