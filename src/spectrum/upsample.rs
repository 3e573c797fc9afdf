//! RGB → spectrum: the sigmoid-polynomial model of Jakob and Hanika (2019) and its
//! coefficient table for linear sRGB (D65 white).
//!
//! **Model.** A reflectance is s(λ) = ½ + x / (2√(1 + x²)) with x = c₀t² + c₁t + c₂, where
//! t = (λ − 360 nm) / 470 nm ∈ [0, 1] is the wavelength normalised to the rendered range.
//! The coefficients are stored and evaluated in t (not in nm): in f32, a quadratic in
//! λ ≈ 800 nm loses most of its digits to cancellation, a quadratic in t ∈ [0, 1] does not.
//! Three numbers give smooth, bounded spectra (always in [0, 1]) for every colour that a
//! reflectance can have; x is clamped to ±[`X_MAX`], where s is 0 or 1 to f32 precision.
//!
//! **Table.** For an RGB, let l be the index of its largest channel and b = rgb\[l\]; the
//! colour is then (b, rgb\[l+1\]/b, rgb\[l+2\]/b) (indices mod 3) in [0, 1]³. The table holds
//! three blocks (one per l) of [`RES`]³ nodes of three coefficients, laid out as
//! `[l][k][j][i][c]`: k indexes b at smoothstep(smoothstep(k/63)) (dense near black and
//! white, where Lab changes fastest), j and i the two ratios at j/63 and i/63. A lookup
//! ([`coefficients`]) finds k by binary search and interpolates trilinearly, the weight
//! along k linear in the node index ([`scale_coordinate`]) rather than in b; black and
//! exact greys are answered in closed form instead (a constant spectrum is x = c₂ with
//! c₀ = c₁ = 0; black is x = −[`X_MAX`], exactly 0 in f32). Bright colours (smallest
//! channel above [`COMPLEMENT_FROM`]) are looked up through their complement: as
//! s(−x) = 1 − s(x), the negated coefficients of 1 − rgb are a reflectance of colour rgb,
//! and 1 − rgb is dark, where the table is accurate (see [`Table::coefficients`]).
//!
//! **Fit.** Each node's coefficients minimise the CIELAB difference between the node's
//! colour and the reflectance's colour under D65 seen by the CIE 1931 observer (Lab
//! white: sRGB's white), by Levenberg–Marquardt with an analytic Jacobian, in f64. The
//! reflectance is integrated on a [`GRID_NM`] grid as a piecewise-linear curve against
//! weights ∫ hat(λ) D65(λ) x̄ȳz̄(λ) dλ computed exactly from the embedded 1 nm tables
//! ([`super::cie_xyz`], [`super::illuminant`]). Along each scale column the walk starts at
//! k = [`START`] from the constant ½ (c = 0) and moves outwards both ways, each node
//! starting from its neighbour's answer; the 3 · 64² columns run in parallel (rayon) and
//! each is computed serially, so the table is the same bytes on every run.
//!
//! **Cache.** The table (2.4 M coefficients, a 9.4 MB file) is computed on first use, in
//! a few seconds (see `docs/design.md`), and kept in memory, and on disk as
//! `rgb_srgb_<hash>.bin` under `$STOKES_CACHE_DIR`, else `$XDG_CACHE_HOME/stokes`, else
//! `$HOME/.cache/stokes`; the hash covers the fit's settings and a version number (bump
//! `VERSION` when the fit's code changes, or an old file would be read). Files are written to a temporary name and renamed, so
//! parallel processes are safe; a file of the wrong size, a bad checksum or non-finite
//! values is recomputed, and a directory that cannot be written just leaves the table in
//! memory.
//!
//! **Accuracy** (`tests/upsample.rs`: CIEDE2000 between the RGB and the exact integral of
//! the evaluated f32 spectrum under D65): mean 0.03, max 0.26 (in the dark corner) inside
//! the RGB cube, near white included (max 0.06 over [0.95, 0.9999]³); max 0.18 on its
//! faces (primaries 0.04–0.07). Just inside the faces, with a minor channel under 1 % of
//! the largest, a few colours reach 0.53 (see `docs/design.md`).

use super::{illuminant, spectrum_to_xyz, Spectrum, Tabulated, LAMBDA_MIN, LAMBDA_RANGE};
use crate::color::linear_srgb_to_xyz;
use crate::simd::{Float, Mask, Spec, F4};
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Nodes per axis of the table.
pub const RES: usize = 64;
/// Coefficients in the whole table: 3 blocks × RES³ nodes × 3.
pub const TABLE_LEN: usize = 3 * RES * RES * RES * 3;
/// |x| is clamped to this: s(±X_MAX) rounds to 1 and 0 in f32, and it keeps x² finite.
pub const X_MAX: f32 = 1e4;
/// The fit's wavelength grid spacing (nm).
pub const GRID_NM: f64 = 5.0;
/// The scale node each column's walk starts from.
pub const START: usize = 12;
/// The fit stops once the Lab residual's length is below this.
const TOL: f64 = 1e-2;
/// The fit's iteration limit per node.
const MAX_ITERATIONS: usize = 200;
/// A colour whose smallest channel is above this is looked up partly through its
/// complement (see [`Table::coefficients`]) ...
pub const COMPLEMENT_FROM: f32 = 0.4;
/// ... and from this on wholly.
pub const COMPLEMENT_TO: f32 = 0.6;
/// Bumped whenever the fit or the file format changes (part of the cache file's hash).
const VERSION: u32 = 2;
/// First bytes of a cache file.
const MAGIC: &[u8; 8] = b"STKRGB01";

/// A spectrum made from an RGB: `scale` × s(λ) (× the normalised D65 when `illuminant`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbSpectrum {
    /// c₀, c₁, c₂ of the sigmoid polynomial, in normalised wavelength t ∈ [0, 1].
    pub coeffs: [f32; 3],
    /// Multiplies the sigmoid.
    pub scale: f32,
    /// Multiply by [`d65_unit_luminance`] too (an emitter's colour).
    pub illuminant: bool,
}

impl RgbSpectrum {
    /// A reflectance: `rgb` clamped to [0, 1] (NaN to 0), its values always in [0, 1].
    pub fn albedo(rgb: [f32; 3]) -> RgbSpectrum {
        RgbSpectrum {
            coeffs: coefficients(rgb),
            scale: 1.0,
            illuminant: false,
        }
    }

    /// Any non-negative RGB: with m the largest channel, 2m × the reflectance of rgb/(2m),
    /// so the sigmoid fits a colour of brightness ½, which every chroma can reach.
    pub fn unbounded(rgb: [f32; 3]) -> RgbSpectrum {
        let rgb = rgb.map(|v| if v > 0.0 { v } else { 0.0 });
        let m = rgb[0].max(rgb[1]).max(rgb[2]);
        if !(m > 0.0 && m.is_finite()) {
            return RgbSpectrum {
                coeffs: coefficients([0.0; 3]),
                scale: 0.0,
                illuminant: false,
            };
        }
        let scale = 2.0 * m;
        RgbSpectrum {
            coeffs: coefficients(rgb.map(|v| v / scale)),
            scale,
            illuminant: false,
        }
    }

    /// An emitter's colour: [`RgbSpectrum::unbounded`] times D65 scaled to luminance 1
    /// ([`d65_unit_luminance`]), so `rgb = [1, 1, 1]` is D65 with Y = 1, the white of
    /// linear sRGB, as bright as a constant radiance of 1.
    pub fn illuminant(rgb: [f32; 3]) -> RgbSpectrum {
        RgbSpectrum {
            illuminant: true,
            ..RgbSpectrum::unbounded(rgb)
        }
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        let v = self.scale * sigmoid_poly(self.coeffs, lambda);
        if self.illuminant {
            v * d65_unit_luminance().eval(lambda)
        } else {
            v
        }
    }

    /// The values at four wavelengths (the same arithmetic as [`RgbSpectrum::eval`]).
    pub fn eval4(&self, lambda: Vec4) -> Vec4 {
        let l = F4::from_fn(|i| lambda[i]);
        let v = F4::splat(self.scale) * sigmoid_poly(self.coeffs, l);
        let v = if self.illuminant {
            v * d65_unit_luminance().eval_w(l, <F4 as Float>::Mask::splat(true))
        } else {
            v
        };
        Vec4::from_array(std::array::from_fn(|i| v.get(i)))
    }

    /// The values at the four wavelengths of the W paths of `m` (0 elsewhere), all paths
    /// at once; bit for bit what [`RgbSpectrum::eval`] gives lane by lane.
    #[inline(always)]
    pub fn eval_w<F: Float>(&self, lambda: &Spec<F>, m: F::Mask) -> Spec<F> {
        Spec(std::array::from_fn(|k| {
            let v = F::splat(self.scale) * sigmoid_poly(self.coeffs, lambda[k]);
            let v = if self.illuminant {
                v * d65_unit_luminance().eval_w(lambda[k], m)
            } else {
                v
            };
            v.masked(m)
        }))
    }

    /// The largest value over the rendered range: exact without the illuminant (x is a
    /// quadratic in t, s increases with x), an upper bound with it.
    pub fn max_value(&self) -> f32 {
        let [c0, c1, _] = self.coeffs;
        let mut at = vec![LAMBDA_MIN, LAMBDA_MIN + LAMBDA_RANGE];
        if c0 < 0.0 {
            let t = -c1 / (2.0 * c0);
            if t > 0.0 && t < 1.0 {
                at.push(LAMBDA_MIN + t * LAMBDA_RANGE);
            }
        }
        let s = at
            .iter()
            .map(|&l| sigmoid_poly(self.coeffs, l))
            .fold(0.0f32, f32::max);
        let v = self.scale * s;
        if self.illuminant {
            v * d65_unit_luminance().max_over(LAMBDA_MIN, LAMBDA_MIN + LAMBDA_RANGE)
        } else {
            v
        }
    }
}

/// s(λ) for coefficients in normalised wavelength. Written once over `F` so that every
/// width rounds the same way. No clamp is needed: for every f32 |x| ≤ [`X_MAX`] the
/// rounded result is in [0, 1] (a unit test checks them all).
#[inline(always)]
fn sigmoid_poly<F: Float>(c: [f32; 3], lambda: F) -> F {
    let t = (lambda - F::splat(LAMBDA_MIN)) * F::splat(1.0 / LAMBDA_RANGE);
    let x = (F::splat(c[0]) * t + F::splat(c[1])) * t + F::splat(c[2]);
    let x = x.clamp(-X_MAX, X_MAX);
    F::splat(0.5) + F::splat(0.5) * x / (F::splat(1.0) + x * x).sqrt()
}

/// CIE D65 divided by its luminance (Y = 1 in the renderer's normalisation, where a
/// constant 1 has Y = 1): the illuminant RGB spectra are multiplied by it.
pub fn d65_unit_luminance() -> &'static Tabulated {
    static D65: OnceLock<Tabulated> = OnceLock::new();
    D65.get_or_init(|| {
        let d65 = illuminant("D65").expect("D65 is embedded");
        let y = spectrum_to_xyz(&d65).y;
        match d65 {
            Spectrum::Tabulated(t) => t.scaled(1.0 / y),
            _ => unreachable!("illuminants are tabulated"),
        }
    })
}

/// Sigmoid-polynomial coefficients (normalised wavelength) whose reflectance under D65
/// has the colour of linear sRGB `rgb` (channels in [0, 1]; others are clamped).
pub fn coefficients(rgb: [f32; 3]) -> [f32; 3] {
    table().coefficients(rgb)
}

/// The coefficient table ([`RES`]³ nodes × 3 blocks × 3 coefficients).
#[derive(Clone, PartialEq)]
pub struct Table {
    data: Vec<f32>,
}

impl std::fmt::Debug for Table {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Table({} coefficients)", self.data.len())
    }
}

/// Position of the scale node k: smoothstep(smoothstep(k/63)).
pub fn scale_node(k: usize) -> f64 {
    let s = |x: f64| x * x * (3.0 - 2.0 * x);
    s(s(k as f64 / (RES - 1) as f64))
}

/// The inverse of [`scale_node`] as a continuous node index in [0, 63]: smoothstep
/// y = 3u² − 2u³ is inverted on [0, 1] by u = ½ − sin(asin(1 − 2y) / 3).
pub fn scale_coordinate(b: f32) -> f64 {
    let inv = |y: f64| 0.5 - ((1.0 - 2.0 * y.clamp(0.0, 1.0)).asin() / 3.0).sin();
    inv(inv(f64::from(b))) * (RES - 1) as f64
}

fn scale_nodes() -> &'static [f32; RES] {
    static NODES: OnceLock<[f32; RES]> = OnceLock::new();
    NODES.get_or_init(|| std::array::from_fn(|k| scale_node(k) as f32))
}

/// Index of node (l, k, j, i)'s first coefficient.
fn index(l: usize, k: usize, j: usize, i: usize) -> usize {
    (((l * RES + k) * RES + j) * RES + i) * 3
}

/// The colour of node (l, k, j, i): the largest channel l at the k-th scale, the next two
/// (cyclically) at j/63 and i/63 of it.
fn node_rgb(l: usize, k: usize, j: usize, i: usize) -> [f64; 3] {
    let b = scale_node(k);
    let mut rgb = [0.0; 3];
    rgb[l] = b;
    rgb[(l + 1) % 3] = b * j as f64 / (RES - 1) as f64;
    rgb[(l + 2) % 3] = b * i as f64 / (RES - 1) as f64;
    rgb
}

/// c₂ of the constant spectrum `v` (c₀ = c₁ = 0): the inverse of the sigmoid,
/// x = (2v − 1) / (2√(v(1 − v))), clamped to ±[`X_MAX`] (so 0 and 1 are reached).
pub fn constant_c2(v: f32) -> f32 {
    let v = f64::from(v.clamp(0.0, 1.0));
    let d = 2.0 * (v * (1.0 - v)).sqrt();
    let x = if d > 0.0 {
        (2.0 * v - 1.0) / d
    } else if v > 0.5 {
        f64::INFINITY
    } else {
        f64::NEG_INFINITY
    };
    x.clamp(-f64::from(X_MAX), f64::from(X_MAX)) as f32
}

impl Table {
    /// The coefficients at `rgb` (channels clamped to [0, 1], NaN to 0): black and exact
    /// greys in closed form, else trilinear in the table, bright colours through their
    /// complement. The negated coefficients of 1 − rgb give the reflectance 1 − s, whose
    /// colour is white − (1 − rgb) = rgb. Near white the direct lookup fails (up to
    /// ΔE 1.1): at b ≈ 1 a cell along a ratio axis runs from a node 1 − b short of white
    /// in that channel (ratio 1) to one more than a per cent short (62/63), x ≈ ±1/(2√d)
    /// for a shortfall d, and a blend of the two nodes' coefficients falls far less short
    /// than the blend of their colours, whichever solutions the nodes hold. The complement
    /// of a bright colour is dark, where the ratios scale with the colour. The smallest
    /// channel chooses: up to [`COMPLEMENT_FROM`] the direct lookup, from
    /// [`COMPLEMENT_TO`] the complement, between them a smoothstep blend of the two (the
    /// same kind of spectrum there, within about 0.01), so the result stays continuous.
    pub fn coefficients(&self, rgb: [f32; 3]) -> [f32; 3] {
        // Not `clamp`, which keeps NaN.
        let rgb = rgb.map(|v| if v > 0.0 { v.min(1.0) } else { 0.0 });
        let lo = rgb[0].min(rgb[1]).min(rgb[2]);
        if lo <= COMPLEMENT_FROM || (rgb[0] == rgb[1] && rgb[1] == rgb[2]) {
            return self.trilinear(rgb);
        }
        let complement = self.trilinear(rgb.map(|v| 1.0 - v)).map(|c| -c);
        if lo >= COMPLEMENT_TO {
            return complement;
        }
        let u = (lo - COMPLEMENT_FROM) / (COMPLEMENT_TO - COMPLEMENT_FROM);
        let w = u * u * (3.0 - 2.0 * u);
        let direct = self.trilinear(rgb);
        std::array::from_fn(|c| direct[c] + w * (complement[c] - direct[c]))
    }

    /// The table's own answer at `rgb` (channels in [0, 1]): trilinear in the nodes, black
    /// and exact greys in closed form.
    fn trilinear(&self, rgb: [f32; 3]) -> [f32; 3] {
        if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
            return [0.0, 0.0, constant_c2(rgb[0])];
        }
        let l = if rgb[0] >= rgb[1] && rgb[0] >= rgb[2] {
            0
        } else if rgb[1] >= rgb[2] {
            1
        } else {
            2
        };
        let b = rgb[l];
        let n = (RES - 1) as f32;
        let x = rgb[(l + 1) % 3] / b * n;
        let y = rgb[(l + 2) % 3] / b * n;
        let nodes = scale_nodes();
        // The last node ≤ b (b > 0 here: a zero maximum is black, handled above).
        let k = (nodes.partition_point(|&z| z <= b) - 1).min(RES - 2);
        // The weight is linear in the node index rather than in b: the fitted
        // coefficients vary evenly from node to node, not with b (this halves the error
        // between the dark nodes, where b grows by half from one node to the next).
        let wk = ((scale_coordinate(b) - k as f64) as f32).clamp(0.0, 1.0);
        let j = (x as usize).min(RES - 2);
        let i = (y as usize).min(RES - 2);
        let (wj, wi) = (x - j as f32, y - i as f32);
        let mut out = [0.0f32; 3];
        for (dk, fk) in [(0, 1.0 - wk), (1, wk)] {
            for (dj, fj) in [(0, 1.0 - wj), (1, wj)] {
                for (di, fi) in [(0, 1.0 - wi), (1, wi)] {
                    let at = index(l, k + dk, j + dj, i + di);
                    let w = fk * fj * fi;
                    for (c, o) in out.iter_mut().enumerate() {
                        *o += w * self.data[at + c];
                    }
                }
            }
        }
        out
    }

    /// The coefficients of node (l, k, j, i), as fitted.
    pub fn node(&self, l: usize, k: usize, j: usize, i: usize) -> [f32; 3] {
        let at = index(l, k, j, i);
        [self.data[at], self.data[at + 1], self.data[at + 2]]
    }

    /// The table as a cache file: a magic number, the coefficients as little-endian f32, and
    /// an FNV-1a checksum of them.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(MAGIC.len() + 4 * TABLE_LEN + 8);
        out.extend_from_slice(MAGIC);
        for v in &self.data {
            out.extend_from_slice(&v.to_le_bytes());
        }
        let sum = fnv1a(&out[MAGIC.len()..]);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// The inverse of [`Table::to_bytes`]; `None` for anything else (wrong size, magic or
    /// checksum, a non-finite coefficient).
    pub fn from_bytes(bytes: &[u8]) -> Option<Table> {
        let body = bytes.strip_prefix(MAGIC.as_slice())?;
        if body.len() != 4 * TABLE_LEN + 8 {
            return None;
        }
        let (values, sum) = body.split_at(4 * TABLE_LEN);
        if fnv1a(values).to_le_bytes() != sum {
            return None;
        }
        let data: Vec<f32> = values
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        data.iter().all(|v| v.is_finite()).then_some(Table { data })
    }

    /// Writes the table to `path` through a temporary file in the same directory renamed
    /// into place (creating the directory), so a reader never sees half a file.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let dir = path.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir)?;
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.subsec_nanos())
            .unwrap_or(0);
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("table");
        let tmp = dir.join(format!(".{name}.{}.{nanos}.tmp", std::process::id()));
        let result =
            std::fs::write(&tmp, self.to_bytes()).and_then(|_| std::fs::rename(&tmp, path));
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result
    }

    /// The table in `path`, if it holds a valid one.
    pub fn read(path: &Path) -> Option<Table> {
        Table::from_bytes(&std::fs::read(path).ok()?)
    }
}

/// 64-bit FNV-1a.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Where the table is cached on disk: `rgb_srgb_<hash of the fit's settings>.bin` in
/// `$STOKES_CACHE_DIR`, else `$XDG_CACHE_HOME/stokes`, else `$HOME/.cache/stokes` (empty
/// variables count as unset); `None` when none is set.
pub fn cache_path() -> Option<PathBuf> {
    let var = |n: &str| {
        std::env::var_os(n)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    let dir = var("STOKES_CACHE_DIR")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("stokes")))
        .or_else(|| var("HOME").map(|d| d.join(".cache/stokes")))?;
    let settings = format!(
        "v{VERSION} res {RES} grid {GRID_NM} start {START} tol {TOL} it {MAX_ITERATIONS} xmax {X_MAX}"
    );
    Some(dir.join(format!("rgb_srgb_{:016x}.bin", fnv1a(settings.as_bytes()))))
}

/// The table: from memory, else from the disk cache, else computed (and cached).
pub fn table() -> &'static Table {
    static TABLE: OnceLock<Table> = OnceLock::new();
    TABLE.get_or_init(|| {
        let path = cache_path();
        if let Some(t) = path.as_deref().and_then(Table::read) {
            return t;
        }
        let t = compute_table();
        if let Some(p) = path {
            // Not writable: the table stays in memory only.
            let _ = t.write(&p);
        }
        t
    })
}

/// Fits every node (bypassing the caches): the same bytes on every run.
pub fn compute_table() -> Table {
    let fit = Fit::new();
    let columns: Vec<(usize, usize, usize)> = (0..3)
        .flat_map(|l| (0..RES).flat_map(move |j| (0..RES).map(move |i| (l, j, i))))
        .collect();
    let solved: Vec<[[f32; 3]; RES]> = columns
        .par_iter()
        .map(|&(l, j, i)| fit.column(l, j, i))
        .collect();
    let mut data = vec![0.0f32; TABLE_LEN];
    for (&(l, j, i), col) in columns.iter().zip(&solved) {
        for (k, c) in col.iter().enumerate() {
            data[index(l, k, j, i)..][..3].copy_from_slice(c);
        }
    }
    Table { data }
}

/// The fit's fixed data: the wavelength grid and its colour weights.
struct Fit {
    /// Normalised wavelength of each grid point.
    t: Vec<f64>,
    /// XYZ weight of each grid point: XYZ(r) = Σ wᵢ r(tᵢ) for a reflectance that is
    /// linear between grid points, seen under D65 with Y(white) = 1.
    w: Vec<[f64; 3]>,
    /// The Lab reference white: linear sRGB (1, 1, 1).
    white: [f64; 3],
}

/// 3-point Gauss–Legendre on [0, 1]: exact for the product of three linear factors.
const GL3: [(f64, f64); 3] = [
    (0.112_701_665_379_258_3, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.887_298_334_620_741_7, 5.0 / 18.0),
];

impl Fit {
    fn new() -> Fit {
        let d65 = illuminant("D65").expect("D65 is embedded");
        let range = f64::from(LAMBDA_RANGE);
        let n = (range / GRID_NM).round() as usize;
        let h = range / n as f64;
        let mut w = vec![[0.0f64; 3]; n + 1];
        let mut y_white = 0.0;
        // Each 1 nm cell: the CMFs and D65 (5 nm) are linear in it, and so is each hat as
        // long as GRID_NM is a whole number of nm.
        for cell in 0..LAMBDA_RANGE as usize {
            for &(node, weight) in &GL3 {
                let nm = cell as f64 + node;
                let lambda = f64::from(LAMBDA_MIN) + nm;
                let cmf = super::cie_xyz(lambda as f32);
                let e = f64::from(d65.eval(lambda as f32)) * weight;
                let cmf = [cmf.x, cmf.y, cmf.z].map(|v| e * f64::from(v));
                y_white += cmf[1];
                let g = (nm / h).min(n as f64 - 1e-12);
                let p = g.floor() as usize;
                let f = g - p as f64;
                for c in 0..3 {
                    w[p][c] += (1.0 - f) * cmf[c];
                    w[p + 1][c] += f * cmf[c];
                }
            }
        }
        for wi in &mut w {
            for v in wi.iter_mut() {
                *v /= y_white;
            }
        }
        let white = linear_srgb_to_xyz(Vec3::ONE);
        Fit {
            t: (0..=n).map(|i| i as f64 * h / range).collect(),
            w,
            white: [white.x, white.y, white.z].map(f64::from),
        }
    }

    /// The Lab of linear sRGB `rgb` (white: sRGB's).
    fn target(&self, rgb: [f64; 3]) -> [f64; 3] {
        let xyz = linear_srgb_to_xyz(Vec3::from_array(rgb.map(|v| v as f32)));
        lab(&[xyz.x, xyz.y, xyz.z].map(f64::from), &self.white).0
    }

    /// Lab of the reflectance with coefficients `c`, and its Jacobian ∂Lab/∂c.
    fn lab_and_jacobian(&self, c: &[f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let mut xyz = [0.0; 3];
        let mut dxyz = [[0.0; 3]; 3]; // [xyz][coefficient]
        for (&t, w) in self.t.iter().zip(&self.w) {
            let x = (c[0] * t + c[1]) * t + c[2];
            let q = 1.0 + x * x;
            let r = q.sqrt();
            let s = 0.5 + 0.5 * x / r;
            let ds = 0.5 / (q * r);
            let basis = [t * t, t, 1.0];
            for a in 0..3 {
                xyz[a] += w[a] * s;
                for (b, &bb) in basis.iter().enumerate() {
                    dxyz[a][b] += w[a] * ds * bb;
                }
            }
        }
        let (lab, dlab_dxyz) = lab(&xyz, &self.white);
        let mut jac = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                jac[a][b] = (0..3).map(|m| dlab_dxyz[a][m] * dxyz[m][b]).sum();
            }
        }
        (lab, jac)
    }

    /// Levenberg–Marquardt from `c` towards `target`; returns the best coefficients and
    /// the length of their Lab residual.
    fn solve(&self, target: &[f64; 3], mut c: [f64; 3]) -> ([f64; 3], f64) {
        let residual = |lab: &[f64; 3]| -> [f64; 3] { std::array::from_fn(|a| lab[a] - target[a]) };
        let norm2 = |r: &[f64; 3]| r.iter().map(|v| v * v).sum::<f64>();
        let (lab, mut jac) = self.lab_and_jacobian(&c);
        let mut r = residual(&lab);
        let mut cost = norm2(&r);
        let mut mu = 1e-3;
        for _ in 0..MAX_ITERATIONS {
            if cost < TOL * TOL || !cost.is_finite() {
                break;
            }
            // (JᵀJ + μ diag JᵀJ) δ = −Jᵀr
            let mut a = [[0.0; 3]; 3];
            let mut g = [0.0; 3];
            for p in 0..3 {
                for q in 0..3 {
                    a[p][q] = (0..3).map(|m| jac[m][p] * jac[m][q]).sum();
                }
                g[p] = -(0..3).map(|m| jac[m][p] * r[m]).sum::<f64>();
            }
            for (p, row) in a.iter_mut().enumerate() {
                row[p] += mu * row[p] + 1e-12;
            }
            let Some(delta) = solve3(&a, &g) else {
                mu *= 10.0;
                continue;
            };
            let trial: [f64; 3] = std::array::from_fn(|p| c[p] + delta[p]);
            let (lab_t, jac_t) = self.lab_and_jacobian(&trial);
            let r_t = residual(&lab_t);
            let cost_t = norm2(&r_t);
            if cost_t < cost {
                (c, jac, r, cost) = (trial, jac_t, r_t, cost_t);
                mu = (mu * 0.3).max(1e-9);
            } else {
                mu *= 10.0;
                if mu > 1e12 {
                    break;
                }
            }
        }
        (c, cost.sqrt())
    }

    /// One scale column (l, j, i): from [`START`] (from c = 0, the constant ½) up to 1,
    /// then from [`START`] down to 0, each node starting from its neighbour's coefficients.
    fn column(&self, l: usize, j: usize, i: usize) -> [[f32; 3]; RES] {
        let mut out = [[0.0f32; 3]; RES];
        let mut fit_from = |k: usize, c: [f64; 3]| -> [f64; 3] {
            let (c, _) = self.solve(&self.target(node_rgb(l, k, j, i)), c);
            out[k] = c.map(|v| v as f32);
            c
        };
        let start = fit_from(START, [0.0; 3]);
        let mut c = start;
        for k in START + 1..RES {
            c = fit_from(k, c);
        }
        let mut c = start;
        for k in (1..START).rev() {
            c = fit_from(k, c);
        }
        // Black has no finite fit; its node takes the next one's chroma (a lookup this
        // dark is black to f32 precision anyway, and exact black is answered in closed
        // form).
        out[0] = out[1];
        out
    }
}

/// CIELAB of `xyz` against `white` (CIE ε and κ), and ∂Lab/∂XYZ.
fn lab(xyz: &[f64; 3], white: &[f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    const EPSILON: f64 = 216.0 / 24389.0;
    const KAPPA: f64 = 24389.0 / 27.0;
    let mut f = [0.0; 3];
    let mut df = [0.0; 3];
    for a in 0..3 {
        let q = xyz[a] / white[a];
        if q > EPSILON {
            f[a] = q.cbrt();
            df[a] = 1.0 / (3.0 * f[a] * f[a] * white[a]);
        } else {
            f[a] = (KAPPA * q + 16.0) / 116.0;
            df[a] = KAPPA / (116.0 * white[a]);
        }
    }
    let lab = [
        116.0 * f[1] - 16.0,
        500.0 * (f[0] - f[1]),
        200.0 * (f[1] - f[2]),
    ];
    let d = [
        [0.0, 116.0 * df[1], 0.0],
        [500.0 * df[0], -500.0 * df[1], 0.0],
        [0.0, 200.0 * df[1], -200.0 * df[2]],
    ];
    (lab, d)
}

/// Solves the 3×3 system `a x = b` by Cramer's rule; `None` when it is (nearly) singular.
fn solve3(a: &[[f64; 3]; 3], b: &[f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if !(d.is_finite() && d.abs() > 1e-300) {
        return None;
    }
    let x: [f64; 3] = std::array::from_fn(|col| {
        let mut m = *a;
        for (row, &bv) in m.iter_mut().zip(b) {
            row[col] = bv;
        }
        det(&m) / d
    });
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_c2_inverts_the_sigmoid() {
        for v in [0.01f32, 0.2, 0.5, 0.7, 0.99] {
            let s = sigmoid_poly([0.0, 0.0, constant_c2(v)], 500.0f32);
            assert!((s - v).abs() < 1e-6, "{v}: {s}");
        }
        assert_eq!(sigmoid_poly([0.0, 0.0, constant_c2(0.0)], 500.0f32), 0.0);
        assert_eq!(sigmoid_poly([0.0, 0.0, constant_c2(1.0)], 500.0f32), 1.0);
    }

    #[test]
    fn the_sigmoid_stays_in_the_unit_interval_for_every_f32() {
        // Every f32 in [1, X_MAX] and its negative (x·x cannot overflow there). Below 1,
        // |x| / √(1 + x²) < 0.71 leaves far more than rounding's room.
        let mut x = 1.0f32;
        while x <= X_MAX {
            let up = sigmoid_poly([0.0, 0.0, x], 500.0f32);
            let down = sigmoid_poly([0.0, 0.0, -x], 500.0f32);
            assert!(up <= 1.0 && down >= 0.0, "{x}: {up} {down}");
            x = f32::from_bits(x.to_bits() + 1);
        }
    }

    #[test]
    fn scale_nodes_run_from_zero_to_one() {
        assert_eq!(scale_node(0), 0.0);
        assert_eq!(scale_node(RES - 1), 1.0);
        assert!((1..RES).all(|k| scale_node(k) > scale_node(k - 1)));
        for k in 0..RES {
            let u = scale_coordinate(scale_node(k) as f32);
            assert!((u - k as f64).abs() < 1e-3 * (1.0 + k as f64), "{k}: {u}");
        }
        assert!((scale_coordinate(1.0) - 63.0).abs() < 1e-9);
    }

    #[test]
    fn analytic_jacobian_matches_finite_differences() {
        let fit = Fit::new();
        let c = [-3.0, 2.5, -0.4];
        let (_, jac) = fit.lab_and_jacobian(&c);
        for b in 0..3 {
            let h = 1e-6;
            let mut up = c;
            up[b] += h;
            let mut down = c;
            down[b] -= h;
            let (lu, _) = fit.lab_and_jacobian(&up);
            let (ld, _) = fit.lab_and_jacobian(&down);
            for a in 0..3 {
                let fd = (lu[a] - ld[a]) / (2.0 * h);
                assert!(
                    (fd - jac[a][b]).abs() < 1e-5 * (1.0 + fd.abs()),
                    "{a} {b}: {fd} vs {}",
                    jac[a][b]
                );
            }
        }
    }

    #[test]
    fn weights_of_a_constant_one_are_the_d65_white() {
        let fit = Fit::new();
        let sum: [f64; 3] = std::array::from_fn(|c| fit.w.iter().map(|w| w[c]).sum());
        assert!((sum[1] - 1.0).abs() < 1e-12);
        for c in 0..3 {
            assert!(
                (sum[c] - fit.white[c]).abs() < 2e-3,
                "{sum:?} vs {:?}",
                fit.white
            );
        }
    }
}
