//! Scalar maps: one number that varies over a surface, such as a fluorescent dye's
//! strength (a **fluorescence map**: where the ink is and how much of it).
//!
//! ```toml
//! fluorescence = 0.5
//! fluorescence = { texture = "logo.png", wrap = "clamp" }        # a grey PNG
//! fluorescence = { texture = "mask.exr", channel = "g", scale = 0.8 }
//! fluorescence = { checkerboard = [0, 1], checks = [4, 4] }
//! ```
//!
//! Image values are data, not colour: a PNG's 8- or 16-bit values are read linearly
//! (v / 255 or v / 65535), without sRGB decoding, and bilinearly filtered. A grey PNG needs
//! no `channel`; an RGB(A) PNG or an OpenEXR image names the one to read.

use super::{checker, extension, read_exr, read_png, Image, Wrap};
use crate::error::{Key, KeyError};
use crate::scene::Context;
use glam::Vec2;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use std::fmt;
use std::ops::RangeInclusive;
use std::path::Path;
use std::sync::Arc;

/// An image of one channel.
pub type ScalarImage = Image<1>;

/// A number over a surface.
#[derive(Debug, Clone)]
pub enum ScalarTexture {
    /// The same everywhere.
    Constant(f32),
    /// One channel of an image, filtered bilinearly.
    Image(Arc<ScalarImage>),
    /// Two values in alternating squares, `checks` per unit of u and v.
    Checkerboard {
        /// The two values; (0, 0) starts with the first.
        values: [f32; 2],
        /// Squares per unit of u and v.
        checks: [f32; 2],
    },
}

impl ScalarTexture {
    /// The value at texture coordinates `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> f32 {
        match self {
            ScalarTexture::Constant(v) => *v,
            ScalarTexture::Image(img) => img.sample(uv)[0],
            ScalarTexture::Checkerboard { values, checks } => values[checker(uv, *checks)],
        }
    }

    /// Whether it varies over the surface (needs texture coordinates).
    pub fn varies(&self) -> bool {
        !matches!(self, ScalarTexture::Constant(_))
    }

    /// The image, if it is one.
    pub fn image(&self) -> Option<&ScalarImage> {
        match self {
            ScalarTexture::Image(img) => Some(img),
            _ => None,
        }
    }

    /// The map `desc` given at `key`, each value in `range` (`what` names the values in
    /// messages, e.g. "dye strength").
    pub fn from_desc(
        desc: &ScalarDesc,
        key: &Key,
        ctx: &Context,
        range: RangeInclusive<f32>,
        what: &str,
    ) -> Result<ScalarTexture, KeyError> {
        let expect = |v: f64, k: &Key| {
            let f = v as f32;
            match range.contains(&f) {
                true => Ok(f),
                false => {
                    Err(k.expected(format!("{what} in [{}, {}]", range.start(), range.end()), v))
                }
            }
        };
        let t = match desc {
            ScalarDesc::Number(v) => return Ok(ScalarTexture::Constant(expect(*v, key)?)),
            ScalarDesc::Table(t) => t,
        };
        let scale = t.scale.unwrap_or(1.0);
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(key.field("scale").expected("a finite number ≥ 0", scale));
        }
        let only_with = |k: &str, present: bool, with: &str| match present {
            true => Err(key
                .field(k)
                .error(format!("only allowed together with `{with}`"))),
            false => Ok(()),
        };
        match (&t.texture, &t.checkerboard) {
            (Some(file), None) => {
                only_with("checks", t.checks.is_some(), "checkerboard")?;
                let wrap = Wrap::from_desc(t.wrap.as_deref(), &key.field("wrap"))?;
                let path = ctx.resolve(file);
                let channel = t.channel.as_deref();
                let image = load(&path, channel, wrap, scale, range.clone(), what)
                    .map_err(|e| key.field("texture").error(format!("{}: {e}", path.display())))?;
                Ok(ScalarTexture::Image(Arc::new(image)))
            }
            (None, Some(pair)) => {
                only_with("wrap", t.wrap.is_some(), "texture")?;
                only_with("channel", t.channel.is_some(), "texture")?;
                let ck = key.field("checkerboard");
                let values = [
                    expect(pair[0] * f64::from(scale), &ck.index(0))?,
                    expect(pair[1] * f64::from(scale), &ck.index(1))?,
                ];
                let checks = t.checks.unwrap_or([8.0, 8.0]);
                if !checks.iter().all(|c| c.is_finite() && *c > 0.0) {
                    return Err(key.field("checks").expected(
                        "two positive numbers of squares per unit of u and v",
                        format!("{checks:?}"),
                    ));
                }
                Ok(ScalarTexture::Checkerboard { values, checks })
            }
            (Some(_), Some(_)) => {
                Err(key.error("expected one of `texture` and `checkerboard`, found both"))
            }
            (None, None) => Err(key.error(format!(
                "expected a number or {{ texture = \"map.png\" }} or {{ checkerboard = [a, b] }} for the {what}"
            ))),
        }
    }
}

/// Reads channel `channel` ("r", "g" or "b"; none for a grey PNG) of an image as data,
/// times `scale`.
fn load(
    path: &Path,
    channel: Option<&str>,
    wrap: Wrap,
    scale: f32,
    range: RangeInclusive<f32>,
    what: &str,
) -> Result<ScalarImage, String> {
    let pick = |name: Option<&str>, grey: bool| -> Result<usize, String> {
        match (name, grey) {
            (None, true) => Ok(0),
            (Some(c), true) => Err(format!(
                "`channel = {c:?}` given for a grey image (it has one channel: leave `channel` out)"
            )),
            (Some("r"), false) => Ok(0),
            (Some("g"), false) => Ok(1),
            (Some("b"), false) => Ok(2),
            (None, false) => Err(
                "a colour image needs `channel = \"r\"`, \"g\" or \"b\" (the one that holds the map)"
                    .into(),
            ),
            (Some(c), false) => Err(format!(
                "expected `channel` to be \"r\", \"g\" or \"b\", found {c:?}"
            )),
        }
    };
    let (w, h, values): (usize, usize, Vec<f32>) = match extension(path).as_deref() {
        Some("png") => {
            let png = read_png(path)?;
            let c = pick(channel, png.channels <= 2)?;
            let values = (0..png.width * png.height)
                .map(|p| png.values[p * png.channels + c])
                .collect();
            (png.width, png.height, values)
        }
        Some("exr") => {
            let (w, h, rgb) = read_exr(path)?;
            let c = pick(channel, false)?;
            (w, h, rgb.iter().map(|t| t[c]).collect())
        }
        _ => return Err("expected a .png or .exr image".into()),
    };
    let texels = values.into_iter().map(|v| [v * scale]).collect();
    let file = path.display().to_string();
    Image::with_range(w, h, texels, wrap, file, range, what)
}

/// A scalar map as a scene file writes it: a number or a table.
#[derive(Debug, Clone)]
pub enum ScalarDesc {
    /// `0.5`
    Number(f64),
    /// `{ texture = ... }` or `{ checkerboard = ... }`
    Table(Box<ScalarTable>),
}

/// The table form of a scalar map.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScalarTable {
    /// An image file (PNG or OpenEXR), relative to the scene file.
    pub texture: Option<String>,
    /// With `texture`: "r", "g" or "b" for a colour image.
    pub channel: Option<String>,
    /// With `texture`: "repeat" (default), "clamp" or "mirror".
    pub wrap: Option<String>,
    /// Two values in alternating squares.
    pub checkerboard: Option<[f64; 2]>,
    /// With `checkerboard`: squares per unit of u and v (default [8, 8]).
    pub checks: Option<[f32; 2]>,
    /// Multiplies the values (default 1).
    pub scale: Option<f32>,
}

impl<'de> Deserialize<'de> for ScalarDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ScalarDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number, or a table such as { texture = \"map.png\" }")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<ScalarDesc, E> {
                Ok(ScalarDesc::Number(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<ScalarDesc, E> {
                Ok(ScalarDesc::Number(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<ScalarDesc, E> {
                Ok(ScalarDesc::Number(v as f64))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ScalarDesc, A::Error> {
                let t = ScalarTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(ScalarDesc::Table(Box::new(t)))
            }
        }
        d.deserialize_any(V)
    }
}
