//! The OpenEXR spectral layout (Fichet, Pacanowski and Wilkie, JCGT 10(3), 2021): how
//! spectral and bispectral values are named as EXR channels, and the wavelength bins a
//! spectral film accumulates.
//!
//! A channel is `S0.<λ>nm` (emitted radiance; S1–S3 only for polarised light),
//! `T.<λ>nm` (reflectance) or `T.<λi>nm.<λo>nm` (re-radiation from λi into λo > λi; the
//! diagonal λi = λo is the plain `T.<λ>nm`). The number uses a **comma** as its decimal
//! separator because a dot separates OpenEXR layers, and may carry an exponent, an SI
//! prefix and the unit `m` or `Hz`. Writers differ in how many decimals they print, so
//! channels are recognised by parsing, never by comparing strings.

use crate::error::{Detail, Error};
use crate::output::{Channels, Plane};
use crate::spectrum::{Tabulated, LAMBDA_MAX, LAMBDA_MIN};
use crate::Result;
use std::fmt;
use std::path::Path;

/// The header attribute every spectral EXR carries, and its value.
pub const LAYOUT_VERSION: (&str, &str) = ("spectralLayoutVersion", "1.0");

/// The units of an emissive spectral EXR's values (spectral radiance per nm is written as
/// the layout asks: W·m⁻²·sr⁻¹ per channel).
pub const EMISSIVE_UNITS: (&str, &str) = ("emissiveUnits", "W.m^-2.sr^-1");

/// The layout's header attributes for an image with channels `planes` (none if no
/// channel is spectral); a variance image gets the version but no radiance units.
pub fn layout_attributes(
    planes: &[Plane],
    variance: bool,
) -> &'static [(&'static str, &'static str)] {
    if !planes.iter().any(|p| parse_channel(&p.name).is_some()) {
        &[]
    } else if variance {
        &[LAYOUT_VERSION]
    } else {
        &[LAYOUT_VERSION, EMISSIVE_UNITS]
    }
}

/// What a channel of the spectral layout holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SpectralChannel {
    /// Stokes component `stokes` (0 for unpolarised) of emitted radiance at `nm`.
    Emissive { stokes: u8, nm: f64 },
    /// Reflectance (or the diagonal of a bispectral matrix) at `nm`.
    Reflective { nm: f64 },
    /// Re-radiation from `input` nm into `output` nm.
    Bispectral { input: f64, output: f64 },
}

/// A wavelength written as the layout writes it: `550,000000nm`.
pub fn format_nm(nm: f64) -> String {
    format!("{nm:.6}nm").replace('.', ",")
}

/// The channel name of `c`.
pub fn channel_name(c: SpectralChannel) -> String {
    match c {
        SpectralChannel::Emissive { stokes, nm } => format!("S{stokes}.{}", format_nm(nm)),
        SpectralChannel::Reflective { nm } => format!("T.{}", format_nm(nm)),
        SpectralChannel::Bispectral { input, output } => {
            format!("T.{}.{}", format_nm(input), format_nm(output))
        }
    }
}

/// The channel `name` denotes, or `None` if it is not in the layout (`R`, `G`, `B`, …).
pub fn parse_channel(name: &str) -> Option<SpectralChannel> {
    let (head, rest) = name.split_once('.')?;
    match head {
        "T" => match rest.split_once('.') {
            Some((a, b)) => Some(SpectralChannel::Bispectral {
                input: parse_quantity(a)?,
                output: parse_quantity(b)?,
            }),
            None => Some(SpectralChannel::Reflective {
                nm: parse_quantity(rest)?,
            }),
        },
        "S0" | "S1" | "S2" | "S3" => Some(SpectralChannel::Emissive {
            stokes: head.as_bytes()[1] - b'0',
            nm: parse_quantity(rest)?,
        }),
        _ => None,
    }
}

/// SI prefixes the layout allows, longest first (`da` before `d`), as powers of ten
/// (exponents, so that `550nm` is exactly 550 rather than 550·10⁻⁹·10⁹).
const PREFIXES: [(&str, i32); 16] = [
    ("da", 1),
    ("Y", 24),
    ("Z", 21),
    ("E", 18),
    ("P", 15),
    ("T", 12),
    ("G", 9),
    ("M", 6),
    ("k", 3),
    ("h", 2),
    ("d", -1),
    ("c", -2),
    ("m", -3),
    ("u", -6),
    ("n", -9),
    ("p", -12),
];

/// Speed of light in m/s, to read wavelengths given as frequencies.
const LIGHT_SPEED: f64 = 299_792_458.0;

/// A wavelength in nm from the layout's `<number>[prefix](m|Hz)`, e.g. `550,5nm`,
/// `5,505E2nm`, `0,55um`, `545,077THz`. The number is digits with at most one comma and
/// an optional exponent.
pub fn parse_quantity(text: &str) -> Option<f64> {
    let (body, hertz) = match text.strip_suffix("Hz") {
        Some(b) => (b, true),
        None => (text.strip_suffix('m')?, false),
    };
    // The number ends where the prefix starts: at the last digit.
    let end = body.rfind(|c: char| c.is_ascii_digit())? + 1;
    let (number, prefix) = body.split_at(end);
    let exponent = if prefix.is_empty() {
        0
    } else {
        PREFIXES.iter().find(|(p, _)| *p == prefix)?.1
    };
    let number = parse_number(number)?;
    let nm = if hertz {
        LIGHT_SPEED / (number * 10f64.powi(exponent)) * 1e9
    } else if exponent >= -9 {
        number * 10f64.powi(exponent + 9)
    } else {
        number / 10f64.powi(-9 - exponent)
    };
    (nm.is_finite() && nm > 0.0).then_some(nm)
}

/// `\d*,?\d*([Ee][+-]?\d+)?` with a comma for the decimal point.
fn parse_number(text: &str) -> Option<f64> {
    let (mantissa, exponent) = match text.find(['e', 'E']) {
        Some(i) => (&text[..i], Some(&text[i + 1..])),
        None => (text, None),
    };
    let (int, frac) = mantissa.split_once(',').unwrap_or((mantissa, ""));
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    if !digits(int) || !digits(frac) || (int.is_empty() && frac.is_empty()) {
        return None;
    }
    if let Some(e) = exponent {
        let e = e.strip_prefix(['+', '-']).unwrap_or(e);
        if e.is_empty() || !digits(e) {
            return None;
        }
    }
    let plain = format!(
        "{int}.{frac}{}",
        exponent.map_or(String::new(), |e| format!("e{e}"))
    );
    plain.parse().ok()
}

/// Equal-width wavelength bins over `[lo, hi)` nm: what a spectral film accumulates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bins {
    /// Lower edge of the first bin, nm.
    pub lo: f32,
    /// Upper edge of the last bin, nm.
    pub hi: f32,
    /// How many bins.
    pub count: u32,
}

/// At most this many bins (1 nm over the renderer's whole range).
pub const MAX_BINS: u32 = 470;

impl Bins {
    /// `count` bins over `[lo, hi)`, or what is wrong with them: the range must lie in the
    /// renderer's [`LAMBDA_MIN`]–[`LAMBDA_MAX`] (outside it nothing is sampled, so a bin
    /// there would read zero, not the radiance), and there must be 1–[`MAX_BINS`] bins of
    /// at least 1 nm.
    pub fn new(count: u32, lo: f32, hi: f32) -> Result<Bins, String> {
        if !((LAMBDA_MIN..LAMBDA_MAX).contains(&lo) && lo < hi && hi <= LAMBDA_MAX) {
            return Err(format!(
                "a range inside {LAMBDA_MIN}:{LAMBDA_MAX} nm with lower < upper (the renderer samples no other wavelengths), found {lo}:{hi}"
            ));
        }
        if count == 0 || count > MAX_BINS || (hi - lo) / (count as f32) < 1.0 {
            return Err(format!(
                "1 to {MAX_BINS} bins at least 1 nm wide, found {count} bins over {lo}:{hi} nm"
            ));
        }
        Ok(Bins { lo, hi, count })
    }

    /// Width of a bin, nm.
    pub fn width(&self) -> f32 {
        (self.hi - self.lo) / self.count as f32
    }

    /// Centre of bin `b`, nm (what its channel is named after).
    pub fn centre(&self, b: u32) -> f64 {
        self.lo as f64 + (b as f64 + 0.5) * (self.hi - self.lo) as f64 / self.count as f64
    }

    /// The bin holding `lambda`, if any.
    #[inline]
    pub fn index(&self, lambda: f32) -> Option<usize> {
        if !(self.lo..self.hi).contains(&lambda) {
            return None;
        }
        let b = ((lambda - self.lo) / self.width()) as usize;
        Some(b.min(self.count as usize - 1))
    }

    /// The bins whose [`Bins::channel_names`] are `names`, if there are such bins.
    pub fn from_channel_names(names: &[&str]) -> Option<Bins> {
        let centres: Vec<f64> = names
            .iter()
            .map(|n| match parse_channel(n)? {
                SpectralChannel::Emissive { stokes: 0, nm } => Some(nm),
                _ => None,
            })
            .collect::<Option<_>>()?;
        let (first, last) = (*centres.first()?, *centres.last()?);
        let width = match centres.len() {
            1 => return None,
            n => (last - first) / (n - 1) as f64,
        };
        let (lo, hi) = (first - width / 2.0, last + width / 2.0);
        let bins = Bins::new(centres.len() as u32, lo as f32, hi as f32).ok()?;
        (bins.channel_names() == names).then_some(bins)
    }

    /// The emissive channel names, bin by bin.
    pub fn channel_names(&self) -> Vec<String> {
        (0..self.count)
            .map(|b| {
                channel_name(SpectralChannel::Emissive {
                    stokes: 0,
                    nm: self.centre(b),
                })
            })
            .collect()
    }
}

impl fmt::Display for Bins {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} bins over {}:{} nm", self.count, self.lo, self.hi)
    }
}

/// Parses `--spectral-range`'s `LO:HI` (nm).
pub fn parse_range(text: &str) -> Result<(f32, f32), String> {
    let bad = || format!("LO:HI in nm (e.g. 360:830), found {text:?}");
    let (a, b) = text.split_once(':').ok_or_else(bad)?;
    let lo: f32 = a.trim().parse().map_err(|_| bad())?;
    let hi: f32 = b.trim().parse().map_err(|_| bad())?;
    Ok((lo, hi))
}

/// The spectral channels of an EXR, each averaged over all its pixels: a material is
/// uniform (spectral and bispectral textures do not exist yet), so an image of it is
/// reduced to one value per channel.
#[derive(Debug, Clone)]
pub struct Averaged {
    /// How many pixels each mean is over.
    pub pixels: usize,
    /// The channels of the layout, in the file's order: name, meaning, mean.
    pub channels: Vec<(String, SpectralChannel, f32)>,
}

/// Reads the first layer of the EXR `path` and averages every channel of the spectral
/// layout over its pixels (in f64). Other channels (R, G, B, A) are ignored. A mean that
/// is not finite is an error naming the file and the channel.
pub fn read_averaged(path: &Path) -> Result<Averaged> {
    let image = Channels::read(path)?;
    let pixels = image.width as usize * image.height as usize;
    let mut channels = Vec::new();
    for plane in &image.planes {
        let Some(c) = parse_channel(&plane.name) else {
            continue;
        };
        let sum: f64 = plane.data.iter().map(|&v| f64::from(v)).sum();
        let mean = (sum / plane.data.len().max(1) as f64) as f32;
        if !mean.is_finite() {
            return Err(Error::file(
                path,
                None,
                Detail::expected(
                    format!("finite values in channel {}", plane.name),
                    format!("a mean of {mean} over {pixels} pixel(s)"),
                ),
            ));
        }
        channels.push((plane.name.clone(), c, mean));
    }
    Ok(Averaged { pixels, channels })
}

/// A spectrum from a spectral EXR, for a scene's `{ exr = "file.exr" }`: the reflective
/// channels `T.<λ>nm` if there are any, else the unpolarised emissive ones `S0.<λ>nm`,
/// each averaged over the pixels, as a table through their wavelengths (linear between,
/// zero outside, like `{ wavelengths, values }`). The value is taken as written: a
/// reflectance, or a radiance in the file's units (`scale` converts). Bispectral
/// channels and S1–S3 are ignored. Errors name the file and the channel.
pub fn spectrum(path: &Path) -> Result<Tabulated> {
    let avg = read_averaged(path)?;
    let reflective: Vec<(&str, f64, f32)> = avg
        .channels
        .iter()
        .filter_map(|(name, c, v)| match c {
            SpectralChannel::Reflective { nm } => Some((name.as_str(), *nm, *v)),
            _ => None,
        })
        .collect();
    let samples = if reflective.is_empty() {
        avg.channels
            .iter()
            .filter_map(|(name, c, v)| match c {
                SpectralChannel::Emissive { stokes: 0, nm } => Some((name.as_str(), *nm, *v)),
                _ => None,
            })
            .collect()
    } else {
        reflective
    };
    if samples.is_empty() {
        return Err(Error::file(
            path,
            None,
            Detail::expected(
                "spectral channels T.<λ>nm (reflective) or S0.<λ>nm (emissive), e.g. T.550,000000nm",
                "none",
            ),
        ));
    }
    let mut samples = samples;
    samples.sort_by(|a, b| a.1.total_cmp(&b.1));
    for pair in samples.windows(2) {
        if pair[0].1 as f32 == pair[1].1 as f32 {
            return Err(Error::file(
                path,
                None,
                format!(
                    "channels {} and {} are the same wavelength ({} nm)",
                    pair[0].0, pair[1].0, pair[1].1
                ),
            ));
        }
    }
    let (w, v) = samples.iter().map(|s| (s.1 as f32, s.2)).unzip();
    Tabulated::new(w, v).map_err(|e| Error::file(path, None, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_use_a_comma() {
        let c = SpectralChannel::Emissive {
            stokes: 0,
            nm: 550.0,
        };
        assert_eq!(channel_name(c), "S0.550,000000nm");
        assert_eq!(parse_channel("S0.550,000000nm"), Some(c));
        let b = SpectralChannel::Bispectral {
            input: 400.5,
            output: 620.0,
        };
        assert_eq!(channel_name(b), "T.400,500000nm.620,000000nm");
        assert_eq!(parse_channel(&channel_name(b)), Some(b));
        assert_eq!(
            parse_channel("T.550nm"),
            Some(SpectralChannel::Reflective { nm: 550.0 })
        );
    }

    #[test]
    fn quantities_other_writers_use() {
        let close = |t: &str, nm: f64| {
            let v = parse_quantity(t).unwrap_or_else(|| panic!("{t} did not parse"));
            assert!((v - nm).abs() < 1e-6 * nm, "{t}: {v} vs {nm}");
        };
        close("550nm", 550.0);
        close("550,25nm", 550.25);
        close("5,5025E2nm", 550.25);
        close("0,55um", 550.0);
        close("5,5e-7m", 550.0);
        close("545,0771Hz", LIGHT_SPEED / 545.0771 * 1e9);
        close("545,0771THz", LIGHT_SPEED / 545.0771e12 * 1e9);
        // Nanometres exactly as written (the writer's numbers are the grid).
        assert_eq!(parse_quantity("400,000000nm"), Some(400.0));
        assert_eq!(parse_quantity("361,500000nm"), Some(361.5));
        for bad in [
            "550", "550.0nm", "nm", "5,5,0nm", "550xm", "R", "-550nm", "5e+nm",
        ] {
            assert_eq!(parse_quantity(bad), None, "{bad} should not parse");
        }
        for other in ["R", "G", "B", "A", "S4.550nm", "T", "Y.550nm"] {
            assert_eq!(parse_channel(other), None, "{other}");
        }
    }

    #[test]
    fn bins_cover_their_range() {
        let b = Bins::new(47, 360.0, 830.0).unwrap();
        assert_eq!(b.width(), 10.0);
        assert_eq!(b.centre(0), 365.0);
        assert_eq!(b.index(360.0), Some(0));
        assert_eq!(b.index(549.9), Some(18));
        assert_eq!(b.index(550.0), Some(19));
        assert_eq!(b.index(829.999), Some(46));
        assert_eq!(b.index(830.0), None);
        assert_eq!(b.index(359.0), None);
        assert_eq!(b.channel_names()[19], "S0.555,000000nm");
        let names = b.channel_names();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        assert_eq!(Bins::from_channel_names(&names), Some(b));
        let odd = Bins::new(7, 401.5, 688.0).unwrap().channel_names();
        let odd: Vec<&str> = odd.iter().map(String::as_str).collect();
        assert_eq!(Bins::from_channel_names(&odd).map(|b| b.count), Some(7));
        assert_eq!(Bins::from_channel_names(&names[..1]), None);
        assert_eq!(
            Bins::from_channel_names(&[names[1], names[3]]),
            Some(Bins::new(2, 365.0, 405.0).unwrap())
        );
        assert_eq!(
            Bins::from_channel_names(&[names[0], names[1], names[3]]),
            None
        );
        assert_eq!(
            Bins::from_channel_names(&["T.365,000000nm", "T.375,000000nm"]),
            None
        );
        assert!(Bins::new(10, 300.0, 830.0).is_err());
        assert!(Bins::new(10, 400.0, 900.0).is_err());
        assert!(Bins::new(0, 400.0, 700.0).is_err());
        assert!(Bins::new(400, 400.0, 700.0).is_err());
        assert!(Bins::new(1, 700.0, 400.0).is_err());
        assert_eq!(parse_range("400:700"), Ok((400.0, 700.0)));
        assert!(parse_range("400-700").is_err());
    }
}
