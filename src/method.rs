//! The rendering method: one value on each of five axes.
//!
//! | axis | values (default first) | what it chooses |
//! | --- | --- | --- |
//! | spectral | `hwss`, `mono` | four hero-driven wavelengths per path, or one |
//! | wavelengths | `visible`, `uniform` | the hero's pdf: by visible importance, or uniform |
//! | shifting | `independent`, `constant` | how the four lanes move at a fluorescent vertex |
//! | tracking | the scene's default, `classic`, `max`, `fluo-aware` | distance sampling in media |
//! | rays | `packet`, `packet8`, `lockstep`, `single` | how paths meet Embree |
//! | dispersion | `split`, `drop` | what a dispersive refraction does to the lanes |
//!
//! A method's name is its values joined by `-` in that order, for example
//! `hwss-visible-independent-fluo-aware-packet-split`: the command line (`stokes converge
//! --methods`), the EXR header (one attribute per axis) and the reports all use these
//! spellings ([`Axis::name`]). Every value belongs to exactly one axis, so a name may list
//! the values in any order and leave axes out; those keep the values of a base method
//! ([`Method::parse_with`]).
//!
//! The tracking default depends on the scene — classic where no medium fluoresces (it is
//! unbiased there and cheapest), fluorescence-aware where one does — so a method may leave
//! it open (`tracking: None`) until [`Method::resolve`] meets the scene.

use crate::error::Detail;
use crate::medium::tracking::Tracking;
use crate::scene::Scene;
pub use crate::spectrum::Wavelengths;
use std::fmt;
use std::str::FromStr;

/// One axis of a method: a closed set of named values.
pub trait Axis: Copy + Eq + fmt::Debug + 'static {
    /// The axis' name, as in the header and in `--<name>` options.
    const NAME: &'static str;
    /// Every value, default first where the axis has a fixed default.
    const VALUES: &'static [Self];
    /// The value's name.
    fn name(self) -> &'static str;
    /// A one-line description for help texts.
    fn about(self) -> &'static str;
    /// The value called `name`, if any.
    fn from_name(name: &str) -> Option<Self> {
        Self::VALUES.iter().copied().find(|v| v.name() == name)
    }
    /// `a, b or c`: the names of the values, for error messages.
    fn names() -> String {
        let names: Vec<&str> = Self::VALUES.iter().map(|v| v.name()).collect();
        names.join(", ")
    }
}

/// Implements [`Axis`], `Display` and `FromStr` for an enum from its table of names.
macro_rules! axis {
    ($ty:ty, $axis:literal, [$($variant:path => $name:literal: $about:literal),+ $(,)?]) => {
        impl Axis for $ty {
            const NAME: &'static str = $axis;
            const VALUES: &'static [Self] = &[$($variant),+];
            fn name(self) -> &'static str {
                match self {
                    $($variant => $name),+
                }
            }
            fn about(self) -> &'static str {
                match self {
                    $($variant => $about),+
                }
            }
        }

        impl fmt::Display for $ty {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }

        impl FromStr for $ty {
            type Err = Detail;
            fn from_str(s: &str) -> Result<Self, Detail> {
                <$ty as Axis>::from_name(s).ok_or_else(|| {
                    Detail::Text(format!(
                        "{}: expected one of {}, found {s:?}",
                        <$ty as Axis>::NAME,
                        <$ty as Axis>::names()
                    ))
                })
            }
        }
    };
}

/// How wavelengths are sampled per path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Spectral {
    /// Hero wavelength spectral sampling: four wavelengths per path.
    #[default]
    Hwss,
    /// One wavelength per path.
    Mono,
}

axis!(Spectral, "spectral", [
    Spectral::Hwss => "hwss": "four wavelengths per path, a hero and three a quarter of the range apart",
    Spectral::Mono => "mono": "one wavelength per path",
]);

axis!(Wavelengths, "wavelengths", [
    Wavelengths::Visible => "visible": "the hero by visible importance (linear-sRGB CMFs with a floor), the lanes a quarter of its CDF apart",
    Wavelengths::Uniform => "uniform": "the hero uniform over 360-830 nm, the lanes a quarter of the range apart",
]);

/// How the four lanes of a path move at a fluorescent vertex (HWSS only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shifting {
    /// Every lane samples its own shift with its own random numbers, weighted f_k/p_k.
    #[default]
    Independent,
    /// Every lane moves by the hero's shift Δλ; the shift pdfs enter the MIS weights.
    Constant,
}

axis!(Shifting, "shifting", [
    Shifting::Independent => "independent": "every lane samples its own wavelength shift",
    Shifting::Constant => "constant": "every lane moves by the hero's shift",
]);

axis!(Tracking, "tracking", [
    Tracking::Classic => "classic": "exponential in the extinction; biased in fluorescent media",
    Tracking::Max => "max": "exponential in max(scattering, extinction); unbiased",
    Tracking::FluoAware => "fluo-aware": "the paper's fluorescence-aware tracking; unbiased",
]);

/// How the rays of a render are traced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Rays {
    /// Four paths travel together through Embree's 4-wide queries, the estimator running
    /// on all four at once; a lane whose path ends takes the next pixel sample at once.
    /// The default: it measures faster (README, "Packets against single rays").
    #[default]
    Packet,
    /// Like `packet`, with eight paths per Embree query (`rtcIntersect8`).
    Packet8,
    /// Like `packet`, but a packet's lanes take new pixel samples only once all four
    /// paths have ended (as Mitsuba 3 runs its lanes; to measure what refilling buys).
    Lockstep,
    /// One path at a time, depth first, through single-ray queries.
    Single,
}

impl Rays {
    /// Paths per Embree query.
    pub fn width(self) -> usize {
        match self {
            Rays::Packet | Rays::Lockstep => 4,
            Rays::Packet8 => 8,
            Rays::Single => 1,
        }
    }
}

axis!(Rays, "rays", [
    Rays::Packet => "packet": "four paths per Embree query, a lane refilled as soon as its path ends",
    Rays::Packet8 => "packet8": "eight paths per Embree query, a lane refilled as soon as its path ends",
    Rays::Lockstep => "lockstep": "four paths per Embree query, refilled only when all have ended",
    Rays::Single => "single": "one path at a time through single-ray queries",
]);

/// Which pixel samples start together in the lanes of a packet: not an axis of the
/// method (the image does not depend on it: lanes are refilled as their paths end and
/// every sample keeps its own random streams), a scheduling choice like the thread count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Layout {
    /// The four pixels of a 2×2 quad, one sample index at a time.
    #[default]
    Quad,
    /// Consecutive samples of one pixel (up to 16 per pass and pixel), as Mitsuba 3 does.
    Pixel,
}

axis!(Layout, "layout", [
    Layout::Quad => "quad": "a packet starts with the four pixels of a 2x2 quad",
    Layout::Pixel => "pixel": "a packet starts with consecutive samples of one pixel",
]);

/// What a path does at a dispersive refraction, where its four wavelengths leave in four
/// directions (HWSS only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Dispersion {
    /// Split the path into four single-wavelength paths that share the prefix's MIS
    /// weights; in packet mode they travel on as one packet. The default: less colour
    /// noise at equal time.
    #[default]
    Split,
    /// Keep the hero, drop the three secondary lanes (pbrt-v4 and Mitsuba 3 do this).
    Drop,
}

axis!(Dispersion, "dispersion", [
    Dispersion::Split => "split": "continue all four wavelengths as single-wavelength paths",
    Dispersion::Drop => "drop": "keep the hero wavelength only",
]);

/// A rendering method: a value on each axis. `T` is the tracking: `Option<Tracking>`
/// (the default type) where `None` leaves it to the scene, or [`Tracking`] itself once
/// [`Method::resolve`] has met the scene ([`Resolved`]), which is what the renderer runs.
/// `Method::default()` is what `stokes render` does without flags.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Method<T = Option<Tracking>> {
    /// Wavelengths per path.
    pub spectral: Spectral,
    /// The hero wavelength's pdf.
    pub wavelengths: Wavelengths,
    /// Lane shifting at fluorescent events (HWSS).
    pub shifting: Shifting,
    /// Distance sampling in media.
    pub tracking: T,
    /// Packets of four paths or single rays.
    pub rays: Rays,
    /// Dispersive refraction: split the path or drop the secondary lanes.
    pub dispersion: Dispersion,
}

impl Default for Method {
    /// What `stokes render` does without flags: `hwss-visible-independent-packet-split` with the
    /// scene's default tracking.
    fn default() -> Method {
        Method {
            spectral: Spectral::default(),
            wavelengths: Wavelengths::default(),
            shifting: Shifting::default(),
            tracking: None,
            rays: Rays::default(),
            dispersion: Dispersion::default(),
        }
    }
}

/// A method with its tracking chosen: what a render runs, what headers and reports name.
pub type Resolved = Method<Tracking>;

/// The tracking a scene uses when none is asked for, and why: classic where no medium
/// fluoresces, fluorescence-aware where one does.
pub fn default_tracking(scene: &Scene) -> (Tracking, &'static str) {
    if scene.has_fluorescent_media() {
        (
            Tracking::FluoAware,
            "a medium fluoresces: classic tracking would miss re-emission where σ̂_t is small",
        )
    } else {
        (
            Tracking::Classic,
            "no medium fluoresces: classic tracking is unbiased and cheapest",
        )
    }
}

impl Method {
    /// This method with the scene's default tracking where none was asked for.
    pub fn resolve(self, scene: &Scene) -> Resolved {
        self.with_tracking(self.tracking.unwrap_or_else(|| default_tracking(scene).0))
    }
}

impl<T> Method<T> {
    /// This method with another tracking.
    pub fn with_tracking<U>(self, tracking: U) -> Method<U> {
        Method {
            spectral: self.spectral,
            wavelengths: self.wavelengths,
            shifting: self.shifting,
            tracking,
            rays: self.rays,
            dispersion: self.dispersion,
        }
    }
}

impl Resolved {
    /// The values' names in axis order.
    pub fn parts(&self) -> [&'static str; 6] {
        [
            self.spectral.name(),
            self.wavelengths.name(),
            self.shifting.name(),
            self.tracking.name(),
            self.rays.name(),
            self.dispersion.name(),
        ]
    }
}

impl<T: Copy + From<Tracking>> Method<T> {
    /// Parses a name: values of the axes joined by `-`, in any order, each axis at most
    /// once; the axes left out keep `base`'s values.
    pub fn parse_with(text: &str, base: &Self) -> Result<Self, Detail> {
        let text = text.trim();
        if text.is_empty() {
            return Err(Detail::expected(
                "a method name such as hwss-independent-fluo-aware-packet",
                "an empty one",
            ));
        }
        let mut m = *base;
        let mut seen: Vec<&str> = Vec::new();
        let tokens: Vec<&str> = text.split('-').collect();
        let mut i = 0;
        while i < tokens.len() {
            // Values may hold a dash themselves (`fluo-aware`): take the longest match.
            let found = AxisValue::all()
                .filter_map(|v| {
                    let k = v.name().split('-').count();
                    (i + k <= tokens.len() && tokens[i..i + k].join("-") == v.name())
                        .then_some((k, v))
                })
                .max_by_key(|(k, _)| *k);
            let Some((k, value)) = found else {
                return Err(Detail::Text(format!(
                    "unknown component `{}` in method `{text}`: expected values of {}, joined by `-`",
                    tokens[i],
                    describe_axes()
                )));
            };
            i += k;
            if seen.contains(&value.axis()) {
                return Err(Detail::Text(format!(
                    "method `{text}` gives the {} axis twice (at `{}`): name one value per axis",
                    value.axis(),
                    value.name()
                )));
            }
            seen.push(value.axis());
            value.set(&mut m);
        }
        Ok(m)
    }

    /// Parses a comma-separated list of names (see [`Method::parse_with`]); two names of
    /// the same method are an error.
    pub fn parse_list(text: &str, base: &Self) -> Result<Vec<Self>, Detail>
    where
        Self: fmt::Display + PartialEq,
    {
        let mut out: Vec<(Self, &str)> = Vec::new();
        for item in text.split(',') {
            let m = Self::parse_with(item, base)?;
            if let Some((_, first)) = out.iter().find(|(o, _)| *o == m) {
                return Err(Detail::Text(format!(
                    "`{}` and `{}` name the same method ({m})",
                    first.trim(),
                    item.trim(),
                )));
            }
            out.push((m, item));
        }
        Ok(out.into_iter().map(|(m, _)| m).collect())
    }
}

/// The name: the values joined by `-` in axis order, the tracking left out where the
/// scene chooses it (`hwss-visible-independent-packet-split`).
impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self.with_tracking(Tracking::Classic);
        let mut parts: Vec<&str> = r.parts().to_vec();
        match self.tracking {
            Some(t) => parts[TRACKING] = t.name(),
            None => {
                parts.remove(TRACKING);
            }
        }
        f.write_str(&parts.join("-"))
    }
}

/// Where the tracking stands in [`Resolved::parts`].
const TRACKING: usize = 3;

/// The full name, `hwss-visible-independent-fluo-aware-packet-split`.
impl fmt::Display for Resolved {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.parts().join("-"))
    }
}

/// Parses a name relative to [`Method::default`].
impl FromStr for Method {
    type Err = Detail;
    fn from_str(s: &str) -> Result<Method, Detail> {
        Method::parse_with(s, &Method::default())
    }
}

/// A value of any axis.
#[derive(Debug, Clone, Copy)]
enum AxisValue {
    Spectral(Spectral),
    Wavelengths(Wavelengths),
    Shifting(Shifting),
    Tracking(Tracking),
    Rays(Rays),
    Dispersion(Dispersion),
}

impl AxisValue {
    /// Every value of every axis.
    fn all() -> impl Iterator<Item = AxisValue> {
        let s = Spectral::VALUES.iter().map(|&v| AxisValue::Spectral(v));
        let w = Wavelengths::VALUES
            .iter()
            .map(|&v| AxisValue::Wavelengths(v));
        let h = Shifting::VALUES.iter().map(|&v| AxisValue::Shifting(v));
        let t = Tracking::VALUES.iter().map(|&v| AxisValue::Tracking(v));
        let r = Rays::VALUES.iter().map(|&v| AxisValue::Rays(v));
        let d = Dispersion::VALUES.iter().map(|&v| AxisValue::Dispersion(v));
        s.chain(w).chain(h).chain(t).chain(r).chain(d)
    }

    fn axis(self) -> &'static str {
        match self {
            AxisValue::Spectral(_) => Spectral::NAME,
            AxisValue::Wavelengths(_) => Wavelengths::NAME,
            AxisValue::Shifting(_) => Shifting::NAME,
            AxisValue::Tracking(_) => Tracking::NAME,
            AxisValue::Rays(_) => Rays::NAME,
            AxisValue::Dispersion(_) => Dispersion::NAME,
        }
    }

    fn name(self) -> &'static str {
        match self {
            AxisValue::Spectral(v) => v.name(),
            AxisValue::Wavelengths(v) => v.name(),
            AxisValue::Shifting(v) => v.name(),
            AxisValue::Tracking(v) => v.name(),
            AxisValue::Rays(v) => v.name(),
            AxisValue::Dispersion(v) => v.name(),
        }
    }

    fn set<T: From<Tracking>>(self, m: &mut Method<T>) {
        match self {
            AxisValue::Spectral(v) => m.spectral = v,
            AxisValue::Wavelengths(v) => m.wavelengths = v,
            AxisValue::Shifting(v) => m.shifting = v,
            AxisValue::Tracking(v) => m.tracking = v.into(),
            AxisValue::Rays(v) => m.rays = v,
            AxisValue::Dispersion(v) => m.dispersion = v,
        }
    }
}

/// `spectral (hwss, mono), shifting (…), …`: every axis with its values.
pub fn describe_axes() -> String {
    fn one<A: Axis>() -> String {
        format!("{} ({})", A::NAME, A::names())
    }
    [
        one::<Spectral>(),
        one::<Wavelengths>(),
        one::<Shifting>(),
        one::<Tracking>(),
        one::<Rays>(),
        one::<Dispersion>(),
    ]
    .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip<A: Axis + FromStr + fmt::Display>() {
        for &v in A::VALUES {
            assert_eq!(A::from_name(v.name()), Some(v));
            assert_eq!(v.to_string(), v.name());
            assert!(v.name().parse::<A>().is_ok_and(|p| p == v));
        }
        assert!(A::from_name("bogus").is_none());
    }

    #[test]
    fn axes_round_trip() {
        round_trip::<Spectral>();
        round_trip::<Wavelengths>();
        round_trip::<Shifting>();
        round_trip::<Tracking>();
        round_trip::<Rays>();
        round_trip::<Dispersion>();
        assert_eq!(Tracking::names(), "classic, max, fluo-aware");
        let e = "lanes".parse::<Rays>().unwrap_err().to_string();
        assert_eq!(
            e,
            "rays: expected one of packet, packet8, lockstep, single, found \"lanes\""
        );
    }

    #[test]
    fn the_default_is_what_render_does_without_flags() {
        let m = Method::default();
        assert_eq!(m.to_string(), "hwss-visible-independent-packet-split");
        assert_eq!(m.tracking, None);
        assert!("".parse::<Method>().is_err());
        let fixed: Method = "mono-max".parse().unwrap();
        assert_eq!(
            fixed.to_string(),
            "mono-visible-independent-max-packet-split"
        );
    }

    #[test]
    fn names_round_trip_and_parse_in_any_order() {
        let base = Resolved {
            rays: Rays::Single,
            dispersion: Dispersion::Drop,
            ..Method::default().with_tracking(Tracking::Classic)
        };
        let m = Method::parse_with("hwss-independent-fluo-aware-packet", &base).unwrap();
        assert_eq!(m.tracking, Tracking::FluoAware);
        assert_eq!(m.rays, Rays::Packet);
        assert_eq!(
            m.to_string(),
            "hwss-visible-independent-fluo-aware-packet-drop"
        );
        assert_eq!(Method::parse_with(&m.to_string(), &base).unwrap(), m);
        let open: Method = m.to_string().parse().unwrap();
        assert_eq!(open.tracking, Some(Tracking::FluoAware));
        assert_eq!(open.with_tracking(Tracking::FluoAware), m);
        let n = Method::parse_with("packet-fluo-aware-split-mono-uniform", &base).unwrap();
        assert_eq!(n.wavelengths, Wavelengths::Uniform);
        assert_eq!(
            n.to_string(),
            "mono-uniform-independent-fluo-aware-packet-split"
        );
        assert_eq!(
            Method::parse_with("max", &base).unwrap().tracking,
            Tracking::Max
        );
        for bad in [
            "hwss-fluo",
            "aware",
            "hwss-mono",
            "uniform-visible",
            "",
            "hwss--single",
            "HWSS",
        ] {
            assert!(Method::parse_with(bad, &base).is_err(), "{bad:?} parsed");
        }
        let e = Method::parse_with("hwss-bogus", &base)
            .unwrap_err()
            .to_string();
        assert!(e.contains("`bogus`"), "{e}");
        assert!(e.contains("tracking (classic, max, fluo-aware)"), "{e}");
        assert!(Method::parse_list("hwss,hwss-single", &base).is_err());
        assert_eq!(Method::parse_list("hwss, mono", &base).unwrap().len(), 2);
    }
}
