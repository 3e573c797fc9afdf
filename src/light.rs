//! Lights: emissive triangles (area lights), point, spot and directional lights
//! ([`delta`]) and a constant environment ([`environment`]), chosen for next-event
//! estimation in proportion to their power.
//!
//! Each emissive shape becomes an [`Emitter`] (spectral radiance × scale, one- or
//! two-sided); its triangles enter one selection table, each with weight area × scale ×
//! mean radiance (its power ÷ π), and a chosen triangle is sampled uniformly by area.
//! The other lights enter the same table after the triangles with their power ÷ π
//! ([`desc`] has their scene syntax).
//!
//! ```toml
//! [[shapes]]                    # any shape with an `emission` is an area light
//! type = "quad"
//! origin = [-0.5, 2.99, -0.5]
//! edge_u = [1, 0, 0]
//! edge_v = [0, 0, 1]
//! emission = { radiance = "D65", scale = 0.3, two_sided = false }
//! ```
//! `radiance` is any spectrum (W·sr⁻¹·m⁻²·nm⁻¹); `radiance × scale` may not exceed
//! [`MAX_RADIANCE`].

pub mod delta;
pub mod desc;
pub mod environment;
pub mod envmap;
pub mod piecewise;

pub use delta::{DeltaKind, DeltaLight};
pub use desc::LightDesc;
pub use environment::Environment;
pub use envmap::EnvMap;

use crate::error::{Detail, Key, KeyError};
use crate::scene::Context;
use crate::simd::{Float, Lanes, Mask, V3};
use crate::spectrum::{self, Range, Spectrum, SpectrumDesc, LAMBDA_MAX, LAMBDA_MIN};
use glam::{Vec3, Vec4};
use serde::Deserialize;

/// Emission of an area light: radiance (W·sr⁻¹·m⁻²·nm⁻¹) × scale, from the front side or
/// both.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmissionDesc {
    /// Spectral radiance.
    pub radiance: SpectrumDesc,
    /// Multiplier (default 1).
    pub scale: Option<f32>,
    /// Emit from both sides (default false: only the front).
    #[serde(default)]
    pub two_sided: bool,
}

/// The largest spectral radiance × scale of an emitter (W·sr⁻¹·m⁻²·nm⁻¹): some 25 orders
/// of magnitude above the Sun's (about 2·10⁴) and 8 below `f32::MAX`, the headroom a
/// path's estimate needs (radiance over the wavelength pdf, times colour matching and
/// throughput) to stay finite in 32-bit floats.
pub const MAX_RADIANCE: f32 = 1e30;

/// The emission of one shape.
#[derive(Debug, Clone)]
pub struct Emitter {
    /// Spectral radiance.
    pub radiance: Spectrum,
    /// Multiplier on the radiance.
    pub scale: f32,
    /// Emits from the back side too.
    pub two_sided: bool,
}

impl Emitter {
    /// The emission `e` of the shape at `shape` (its key). Warns of a light that emits
    /// nothing, and of a band too narrow to be found by wavelength samples.
    pub fn from_desc(
        e: &EmissionDesc,
        shape: &Key,
        ctx: &mut Context,
    ) -> Result<Emitter, KeyError> {
        let key = shape.field("emission");
        let units = ("spectral radiance", "W·sr⁻¹·m⁻²·nm⁻¹");
        let radiance = Emitter::checked(&e.radiance, e.scale, &key, "radiance", units, ctx)?;
        Ok(Emitter {
            two_sided: e.two_sided,
            ..radiance
        })
    }

    /// The one-sided emitter whose spectrum `spectrum` (the quantity and unit `units`, such
    /// as spectral radiance in W·sr⁻¹·m⁻²·nm⁻¹) is given at `key.field` and multiplied by
    /// `scale` (default 1): both checked so that a path's estimate stays finite, with a
    /// warning for a black light or a band too narrow to be found by wavelength samples.
    pub fn checked(
        spectrum: &SpectrumDesc,
        scale: Option<f32>,
        key: &Key,
        field: &str,
        (quantity, unit): (&str, &str),
        ctx: &mut Context,
    ) -> Result<Emitter, KeyError> {
        let scale = scale.unwrap_or(1.0);
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(key.field("scale").expected("a non-negative number", scale));
        }
        let radiance_key = key.field(field);
        let radiance = Spectrum::from_desc(spectrum, &radiance_key, ctx, Some(Range::Radiance))?;
        let peak = radiance.max_value();
        let headroom = "(larger ones overflow 32-bit floats in a path's estimate)";
        if peak.is_nan() || peak > MAX_RADIANCE {
            return Err(radiance_key.expected(
                format!("a {quantity} ≤ {MAX_RADIANCE:e} {unit} {headroom}"),
                format!("a maximum of {peak:e}"),
            ));
        }
        // In f32, as the renderer multiplies (the limit itself, 1e20 × 1e10, passes).
        let scaled = peak * scale;
        if scaled > MAX_RADIANCE {
            let exact = f64::from(peak) * f64::from(scale);
            return Err(key.field("scale").expected(
                format!("{field} × scale ≤ {MAX_RADIANCE:e} {unit} {headroom}"),
                format!("{peak:e} × {scale:e} = {exact:.3e}"),
            ));
        }
        if scaled == 0.0 {
            let (lo, hi) = (spectrum::LAMBDA_MIN, spectrum::LAMBDA_MAX);
            ctx.warn(
                key,
                format!("{field} × scale is 0 over {lo}–{hi} nm: the light is black"),
            );
        } else if let Some(fwhm) = narrowest_band(&radiance).filter(|&w| w < 1.0) {
            ctx.warn(
                &radiance_key,
                format!("a band {fwhm:e} nm wide (fwhm) is rarely hit by the sampled wavelengths and is weighed on a 1 nm grid when lights are chosen: expect a noisy image (a band of a few nm has nearly the same colour)"),
            );
        }
        Ok(Emitter {
            radiance,
            scale,
            two_sided: false,
        })
    }

    /// The power of the emitter of the shape at `shape` over a total `area` (π × sides ×
    /// area × radiance integrated over the rendered range), which must be finite in
    /// 32-bit floats: the light selection table holds it (divided by π × sides × 470 nm)
    /// in them.
    pub fn checked_power(&self, shape: &Key, area: f64) -> Result<f64, KeyError> {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        let power = std::f64::consts::PI
            * sides
            * area
            * f64::from(self.mean_radiance())
            * f64::from(spectrum::LAMBDA_RANGE);
        if power > f64::from(f32::MAX) {
            return Err(shape.field("emission").expected(
                format!(
                    "a light whose power (π × area × radiance over {}–{} nm) is finite in 32-bit floats",
                    spectrum::LAMBDA_MIN,
                    spectrum::LAMBDA_MAX
                ),
                format!("{power:.3e} (area {area:.3e})"),
            ));
        }
        Ok(power)
    }

    /// Whether it emits towards a direction whose cosine with the front normal is `cos`.
    #[inline]
    pub fn emits_towards(&self, cos: f32) -> bool {
        cos > 0.0 || (self.two_sided && cos < 0.0)
    }

    /// The spectral radiance (× scale) at four wavelengths, ignoring direction.
    #[inline]
    pub fn spectral_radiance(&self, lambda: Vec4) -> Vec4 {
        self.radiance.eval4(lambda) * self.scale
    }

    /// Mean radiance (× scale) over the renderer's wavelength range, on a 1 nm grid (for
    /// power-based selection).
    pub fn mean_radiance(&self) -> f32 {
        let n = 470;
        let sum: f32 = (0..n)
            .map(|i| {
                let l = LAMBDA_MIN + (i as f32 + 0.5) * (LAMBDA_MAX - LAMBDA_MIN) / n as f32;
                self.radiance.eval(l)
            })
            .sum();
        self.scale * sum / n as f32
    }
}

/// The smallest fwhm (nm) of a narrow band in `s`, if it is one (possibly scaled).
fn narrowest_band(s: &Spectrum) -> Option<f32> {
    match s {
        Spectrum::NarrowBand { fwhm, .. } => Some(*fwhm),
        Spectrum::Scaled(inner, _) => narrowest_band(inner),
        _ => None,
    }
}

/// One emissive triangle.
#[derive(Debug, Clone, Copy)]
pub struct LightTriangle {
    /// First vertex.
    pub p0: Vec3,
    /// Edge p1 − p0.
    pub e1: Vec3,
    /// Edge p2 − p0.
    pub e2: Vec3,
    /// Unit front normal (e1 × e2).
    pub n: Vec3,
    /// Area.
    pub area: f32,
    /// Index into [`Lights::emitters`].
    pub emitter: u32,
}

/// A point sampled on a light.
#[derive(Debug, Clone, Copy)]
pub struct LightSample {
    /// The point.
    pub p: Vec3,
    /// Unit front normal there.
    pub n: Vec3,
    /// Which emitter.
    pub emitter: u32,
    /// Probability density per unit area (including the choice of triangle).
    pub pdf_area: f32,
}

/// Points sampled on lights for W shading points ([`Lights::sample_towards_w`]).
#[derive(Debug, Clone, Copy)]
pub struct LightSamples<F: Float> {
    /// The paths with a usable sample (a light was chosen, the point differs from the
    /// shading point, and the light emits towards it).
    pub valid: F::Mask,
    /// The points (for a light infinitely far, a point beyond the scene along `wi`).
    pub p: V3<F>,
    /// The unit front normals there (0 for lights that are not surfaces).
    pub n: V3<F>,
    /// The emitters.
    pub emitter: F::Arr<u32>,
    /// The area densities (including the choice of triangle; 0 for other lights).
    pub pdf_area: F,
    /// The unit directions from the shading points.
    pub wi: V3<F>,
    /// The solid-angle densities at the shading points; for a delta light its selection
    /// probability × squared distance (× 1 for a directional light), so that the
    /// emitter's spectrum over it is what arrives.
    pub pdf: F,
    /// The paths whose light is a delta light, which no direction sampling can find.
    pub delta: F::Mask,
    /// What multiplies the emitter's spectrum: a spot's falloff, else 1.
    pub falloff: F,
    /// For the paths that sampled an environment map, the texel whose radiance arrives
    /// (instead of the emitter's); [`NO_TEXEL`] elsewhere.
    pub texel: F::Arr<u32>,
}

/// "Not an environment map's texel" in [`LightSamples::texel`].
pub const NO_TEXEL: u32 = u32::MAX;

/// All lights of a scene.
#[derive(Debug, Clone)]
pub struct Lights {
    /// Emitters, one per emissive shape or light, in the order they were added.
    pub emitters: Vec<Emitter>,
    /// Emissive triangles.
    pub triangles: Vec<LightTriangle>,
    /// Point, spot and directional lights.
    pub delta: Vec<DeltaLight>,
    /// The environment, if the scene has one.
    pub environment: Option<Environment>,
    /// Cumulative selection probabilities of the triangles, then the delta lights, then
    /// the environment.
    cdf: Vec<f32>,
    /// Selection probability of each, in the same order.
    pmf: Vec<f32>,
    /// Each triangle as next-event estimation reads it ([`NeeRows`]).
    nee_rows: Vec<NeeRows>,
    /// For each geometry id, the index of its first light triangle.
    first_triangle: Vec<Option<u32>>,
    /// The scene's bounding sphere: centre and radius (directional and environment light
    /// come from beyond it).
    bound: (Vec3, f32),
}

impl Default for Lights {
    fn default() -> Lights {
        Lights {
            emitters: Vec::new(),
            triangles: Vec::new(),
            delta: Vec::new(),
            environment: None,
            cdf: Vec::new(),
            pmf: Vec::new(),
            nee_rows: Vec::new(),
            first_triangle: Vec::new(),
            bound: (Vec3::ZERO, 1.0),
        }
    }
}

/// A light triangle as next-event estimation reads it, four rows of four so that the
/// triangles of W paths gather as whole vectors: (p0, pdf_area), (e1, 1 if two-sided
/// else 0), (e2, the emitter index's bits: only moved, never computed with, so exact for
/// every index), (n, 1); [`NO_TRIANGLE`] for one that cannot be sampled (no power or no
/// area).
type NeeRows = [Vec4; 4];

/// The rows of a path that samples no triangle: what [`Lights::sample_triangles`] leaves
/// in its lane.
const NO_TRIANGLE: NeeRows = [Vec4::ZERO, Vec4::ZERO, Vec4::ZERO, Vec4::Z];

/// One entry of the selection table.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Entry {
    Triangle(usize),
    Delta(usize),
    Environment,
}

impl Lights {
    /// Adds an emitter with its triangles; `geom_id` is the Embree id of the mesh. Returns
    /// their total area (in f64: the sum may exceed f32). Fails, adding nothing, if a
    /// triangle's area is not finite in 32-bit floats (its density 1/area would be 0 and
    /// its selection weight infinite).
    pub fn add(
        &mut self,
        geom_id: u32,
        emitter: Emitter,
        positions: &[[f32; 3]],
        indices: &[[u32; 3]],
    ) -> Result<f64, Detail> {
        let e = self.emitters.len() as u32;
        let mut triangles = Vec::with_capacity(indices.len());
        for (k, t) in indices.iter().enumerate() {
            let [p0, p1, p2] = t.map(|i| Vec3::from(positions[i as usize]));
            let (e1, e2) = (p1 - p0, p2 - p0);
            let c = e1.cross(e2);
            let area = 0.5 * c.length();
            if !area.is_finite() {
                return Err(Detail::Expected {
                    expected: "emitting triangles whose area is finite in 32-bit floats".into(),
                    found: format!(
                        "triangle {k} of area {area} (edges {:.3e} and {:.3e} long)",
                        e1.as_dvec3().length(),
                        e2.as_dvec3().length()
                    ),
                });
            }
            triangles.push(LightTriangle {
                p0,
                e1,
                e2,
                n: c.normalize_or_zero(),
                area,
                emitter: e,
            });
        }
        self.emitters.push(emitter);
        let g = geom_id as usize;
        if self.first_triangle.len() <= g {
            self.first_triangle.resize(g + 1, None);
        }
        self.first_triangle[g] = Some(self.triangles.len() as u32);
        let area = triangles.iter().map(|t| f64::from(t.area)).sum();
        self.triangles.extend(triangles);
        Ok(area)
    }

    /// Adds a point, spot or directional light emitting `emitter`.
    pub fn add_delta(&mut self, kind: DeltaKind, emitter: Emitter) {
        let e = self.emitters.len() as u32;
        self.emitters.push(emitter);
        self.delta.push(DeltaLight { kind, emitter: e });
    }

    /// Sets the environment (a scene has at most one): a constant sky of `emitter`'s
    /// radiance, or `map` with `emitter` weighing its power.
    pub fn set_environment(&mut self, emitter: Emitter, map: Option<EnvMap>) {
        let e = self.emitters.len() as u32;
        self.emitters.push(emitter);
        self.environment = Some(Environment {
            emitter: e,
            map: map.map(std::sync::Arc::new),
        });
    }

    /// Sets the box `lo`–`hi` that holds the scene: directional and environment light
    /// come from beyond its bounding sphere, and their power is what crosses it.
    pub fn set_bounds(&mut self, lo: Vec3, hi: Vec3) {
        let centre = 0.5 * (lo + hi);
        let radius = 0.5 * (hi - lo).length();
        if centre.is_finite() && radius.is_finite() && radius > 0.0 {
            self.bound = (centre, radius);
        }
    }

    /// The selection weight (power ÷ π) of each entry, in table order.
    fn weights(&self) -> Vec<f32> {
        let mean = |e: u32| self.emitters[e as usize].mean_radiance().max(0.0);
        let r = self.bound.1;
        let tri = self.triangles.iter().map(|t| t.area * mean(t.emitter));
        let delta = self
            .delta
            .iter()
            .map(|d| d.power_over_pi(r) * mean(d.emitter));
        let env = self
            .environment
            .iter()
            .map(|e| e.power_over_pi(r) * mean(e.emitter));
        tri.chain(delta).chain(env).collect()
    }

    /// Builds the selection table; call once after the last light is added.
    pub fn finish(&mut self) {
        let weights = self.weights();
        let total: f32 = weights.iter().sum();
        self.pmf = if total > 0.0 {
            weights.iter().map(|w| w / total).collect()
        } else {
            vec![1.0 / weights.len().max(1) as f32; weights.len()]
        };
        let mut acc = 0.0;
        self.cdf = self
            .pmf
            .iter()
            .map(|p| {
                acc += p;
                acc
            })
            .collect();
        if let Some(last) = self.cdf.last_mut() {
            *last = 1.0;
        }
        self.nee_rows = (self.triangles.iter().enumerate())
            .map(|(k, t)| {
                if !(self.pmf[k] > 0.0 && t.area > 0.0) {
                    return NO_TRIANGLE;
                }
                let two_sided = self.emitters[t.emitter as usize].two_sided;
                [
                    t.p0.extend(self.pmf[k] / t.area),
                    t.e1.extend(f32::from(u8::from(two_sided))),
                    t.e2.extend(f32::from_bits(t.emitter)),
                    t.n.extend(1.0),
                ]
            })
            .collect();
    }

    /// Whether the scene has any light.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty() && self.delta.is_empty() && self.environment.is_none()
    }

    /// Samples a point on a light for next-event estimation at `p`: the point, the unit
    /// direction `wi` to it and the sample's pdf in solid angle at `p`; `None` if no
    /// light is sampled, the point is `p` itself or the light faces away (one path's
    /// [`Lights::sample_towards_w`]).
    #[inline]
    pub fn sample_towards(&self, p: Vec3, u: [f32; 3]) -> Option<(LightSample, Vec3, f32)> {
        let s = self.sample_towards_w(true, V3::from(p), u);
        s.valid.then(|| {
            let ls = LightSample {
                p: s.p.into(),
                n: s.n.into(),
                emitter: s.emitter[0],
                pdf_area: s.pdf_area,
            };
            (ls, s.wi.into(), s.pdf)
        })
    }

    /// [`Lights::sample_towards`] for the W shading points `p` of the paths in `active`:
    /// the light (chosen by power, a triangle by area) is picked path by path, the point,
    /// direction and solid-angle pdf are computed for all paths at once (one path at a
    /// time for the lights that are not triangles).
    #[inline(always)]
    pub fn sample_towards_w<F: Float>(
        &self,
        active: F::Mask,
        p: V3<F>,
        u: [F; 3],
    ) -> LightSamples<F> {
        let mut s = LightSamples {
            valid: F::Mask::splat(false),
            p: V3::splat(Vec3::ZERO),
            n: V3::splat(Vec3::Z),
            emitter: Lanes::splat(0),
            pdf_area: F::splat(0.0),
            wi: V3::splat(Vec3::Z),
            pdf: F::splat(0.0),
            delta: F::Mask::splat(false),
            falloff: F::splat(1.0),
            texel: Lanes::splat(NO_TEXEL),
        };
        if self.pmf.is_empty() {
            return s;
        }
        // Every lane picks, and a lane's row is chosen by index rather than by a branch on
        // the mask (fewer instructions and branches than lane by lane under the mask).
        let pick: F::Arr<usize> = Lanes::from_fn(|i| self.pick(u[0].get(i)));
        if !self.triangles.is_empty() {
            // Per path: the triangle (by power), if it picked one.
            let rows: F::Arr<NeeRows> = Lanes::from_fn(|i| {
                let row = self.nee_rows.get(pick[i]).unwrap_or(&NO_TRIANGLE);
                *[&NO_TRIANGLE, row][active.get(i) as usize]
            });
            self.sample_triangles(&mut s, &rows, p, u);
        }
        if self.triangles.len() < self.pmf.len() {
            for i in active.iter() {
                if let Some(o) = self.sample_other(pick[i], p.path(i), [u[1].get(i), u[2].get(i)]) {
                    s.valid = s.valid.with(i, true);
                    s.p.set_path(i, o.p);
                    s.n.set_path(i, Vec3::ZERO);
                    s.wi.set_path(i, o.wi);
                    s.emitter[i] = o.emitter;
                    s.pdf_area.set(i, 0.0);
                    s.pdf.set(i, o.pdf);
                    s.delta = s.delta.with(i, o.delta);
                    s.falloff.set(i, o.falloff);
                    s.texel[i] = o.texel;
                }
            }
        }
        s
    }

    /// The triangle samples of [`Lights::sample_towards_w`], for the paths whose `rows`
    /// hold a triangle that can be sampled.
    #[inline(always)]
    fn sample_triangles<F: Float>(
        &self,
        s: &mut LightSamples<F>,
        rows: &F::Arr<NeeRows>,
        p: V3<F>,
        u: [F; 3],
    ) {
        let column = |k: usize| F::columns(&Lanes::from_fn(|i| rows[i][k]));
        let ([p0x, p0y, p0z, pdf_area], [e1x, e1y, e1z, two_sided]) = (column(0), column(1));
        let ([e2x, e2y, e2z, emitter], [nx, ny, nz, samplable]) = (column(2), column(3));
        let (p0, e1, e2) = (
            V3::new(p0x, p0y, p0z),
            V3::new(e1x, e1y, e1z),
            V3::new(e2x, e2y, e2z),
        );
        let half = F::splat(0.5);
        let chosen = samplable.gt(half);
        let two_sided = two_sided.gt(half);
        s.n = V3::new(nx, ny, nz);
        s.emitter = Lanes::from_fn(|i| emitter.get(i).to_bits());
        s.pdf_area = pdf_area;
        // Uniform on the triangle (square-root parametrisation).
        let su = u[1].sqrt();
        let (b1, b2) = (F::splat(1.0) - su, u[2] * su);
        s.p = p0 + e1 * b1 + e2 * b2;
        let to = s.p - p;
        let d2 = to.length_squared();
        let d = d2.sqrt();
        s.wi = to / d;
        let cos_l = s.n.dot(-s.wi);
        let zero = F::splat(0.0);
        let emits = cos_l.gt(zero) | (two_sided & cos_l.lt(zero));
        s.valid = chosen & d.gt(zero) & emits;
        s.pdf = s.pdf_area * d2 / cos_l.abs();
    }

    /// A sample of entry `k` of the table seen from `p` if it is a delta light or the
    /// environment and reaches `p`, from the uniforms `u`.
    fn sample_other(&self, k: usize, p: Vec3, u: [f32; 2]) -> Option<OtherSample> {
        let pmf = self.pmf[k];
        if pmf <= 0.0 {
            return None;
        }
        match self.entry(k) {
            Entry::Triangle(_) => None,
            Entry::Delta(d) => {
                let light = &self.delta[d];
                let seen = light.towards(p)?;
                Some(OtherSample {
                    p: seen.position.unwrap_or_else(|| self.beyond(p, seen.wi)),
                    wi: seen.wi,
                    pdf: pmf * seen.dist2,
                    emitter: light.emitter,
                    delta: true,
                    falloff: seen.falloff,
                    texel: NO_TEXEL,
                })
            }
            Entry::Environment => {
                let env = self.environment.as_ref()?;
                let (wi, pdf, texel) = env.sample(u)?;
                Some(OtherSample {
                    p: self.beyond(p, wi),
                    wi,
                    pdf: pmf * pdf,
                    emitter: env.emitter,
                    delta: false,
                    falloff: 1.0,
                    texel: texel.unwrap_or(NO_TEXEL),
                })
            }
        }
    }

    /// A point along `wi` from `p` (inside the scene) that lies beyond the scene's
    /// bounding sphere: where a shadow ray towards an infinitely distant light may stop.
    fn beyond(&self, p: Vec3, wi: Vec3) -> Vec3 {
        let (c, r) = self.bound;
        p + wi * (2.0 * ((p - c).length() + r) + 1.0)
    }

    /// The entry of the table at index `k`.
    fn entry(&self, k: usize) -> Entry {
        let t = self.triangles.len();
        if k < t {
            Entry::Triangle(k)
        } else if k - t < self.delta.len() {
            Entry::Delta(k - t)
        } else {
            Entry::Environment
        }
    }

    /// The entry index that selection sample `u` picks.
    #[inline(always)]
    fn pick(&self, u: f32) -> usize {
        self.cdf
            .partition_point(|&c| c <= u)
            .min(self.pmf.len() - 1)
    }

    /// The density in solid angle with which next-event estimation samples direction
    /// `dir` of the environment (0 without one): how a ray that leaves the scene is
    /// weighed against light sampling.
    #[inline]
    pub fn pdf_environment(&self, dir: Vec3) -> f32 {
        match &self.environment {
            Some(env) => self.pmf[self.pmf.len() - 1] * env.pdf(dir),
            None => 0.0,
        }
    }

    /// The environment's map, if it has one.
    #[inline]
    pub fn environment_map(&self) -> Option<&EnvMap> {
        self.environment.as_ref().and_then(|e| e.map.as_deref())
    }

    /// The probability that next-event estimation picks delta light `d`.
    pub fn pmf_delta(&self, d: usize) -> f32 {
        self.pmf[self.triangles.len() + d]
    }

    /// Samples a point on an area light from three uniforms; `None` if the uniforms
    /// pick another kind of light.
    #[inline]
    pub fn sample(&self, u: [f32; 3]) -> Option<LightSample> {
        if self.triangles.is_empty() {
            return None;
        }
        let i = self.pick(u[0]);
        let t = self.triangles.get(i)?;
        if self.pmf[i] <= 0.0 || t.area <= 0.0 {
            return None;
        }
        // Uniform on the triangle (square-root parametrisation), as sample_towards_w.
        let su = u[1].sqrt();
        let (b1, b2) = (1.0 - su, u[2] * su);
        let p = V3::<f32>::from(t.p0) + V3::from(t.e1) * b1 + V3::from(t.e2) * b2;
        Some(LightSample {
            p: p.into(),
            n: t.n,
            emitter: t.emitter,
            pdf_area: self.pmf[i] / t.area,
        })
    }

    /// The area density with which [`Lights::sample`] picks a point on triangle `prim` of
    /// geometry `geom`.
    #[inline]
    pub fn pdf_area(&self, geom: u32, prim: u32) -> f32 {
        match self.first_triangle.get(geom as usize).copied().flatten() {
            Some(first) => {
                let i = (first + prim) as usize;
                self.pmf[i] / self.triangles[i].area
            }
            None => 0.0,
        }
    }

    /// The index (into [`Lights::emitters`]) of geometry `geom`'s emitter, if it emits.
    #[inline]
    pub fn emitter_index_of(&self, geom: u32) -> Option<u32> {
        self.first_triangle
            .get(geom as usize)
            .copied()
            .flatten()
            .map(|first| self.triangles[first as usize].emitter)
    }
}

/// A sample of a light that is not a triangle ([`Lights::sample_other`]).
struct OtherSample {
    p: Vec3,
    wi: Vec3,
    pdf: f32,
    emitter: u32,
    delta: bool,
    falloff: f32,
    texel: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn emitter() -> Emitter {
        Emitter {
            radiance: Spectrum::Constant(1.0),
            scale: 1.0,
            two_sided: false,
        }
    }

    /// The mean over 360–830 nm, not a value at one end: a 550 nm line of unit integral
    /// averages 1/470 per nm (light selection by power depends on it).
    #[test]
    fn mean_radiance_averages_over_the_range() {
        let line = Emitter {
            radiance: Spectrum::narrow_band(550.0, 10.0).unwrap(),
            scale: 2.0,
            two_sided: false,
        };
        let want = 2.0 / (LAMBDA_MAX - LAMBDA_MIN);
        let got = line.mean_radiance();
        assert!((got - want).abs() < 1e-3 * want, "{got} vs {want}");
        assert_eq!(emitter().mean_radiance(), 1.0);
    }

    #[test]
    fn an_emitting_triangle_of_infinite_area_is_refused_and_nothing_added() {
        let mut lights = Lights::default();
        let quad = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]];
        let area = lights.add(0, emitter(), &quad, &[[0, 1, 2]]).unwrap();
        assert_eq!(area, 2.0);
        let huge = [[0.0, 0.0, 0.0], [1e20, 0.0, 0.0], [0.0, 0.0, 1e20]];
        let err = lights.add(1, emitter(), &huge, &[[0, 1, 2]]).unwrap_err();
        let err = err.to_string();
        assert!(err.contains("triangle 0 of area inf"), "{err}");
        assert_eq!((lights.emitters.len(), lights.triangles.len()), (1, 1));
        assert_eq!(lights.emitter_index_of(1), None);
        lights.finish();
        assert_eq!(lights.pdf_area(0, 0), 0.5);
    }
}
