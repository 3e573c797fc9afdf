//! The estimator: the state of W camera paths ([`Paths`]) and the step that advances all
//! of them by one ray query at once. A driver ([`super::trace`]) traces the paths' rays,
//! hands the hits to [`Paths::step`], traces the shadow rays the step asked for, and
//! repeats; a path that ends leaves its lane to the next pixel sample.
//!
//! Every path decides for itself (a collision in a medium or a surface, a light that
//! faces it or not, which lobe it hits, Russian roulette), so the step works on masks: it
//! computes each part for every path it concerns at once and keeps the result where that
//! part applies. Random numbers are drawn path by path, only for the paths the part
//! concerns, so a path draws the same numbers in the same order at every width — and
//! computes the same bits, since every operation is lane-wise ([`crate::simd`]).
//!
//! A shadow ray is deferred, not traced inside the step: its contribution depends on
//! nothing the step computes afterwards and the step draws no random numbers for it.

use super::census::{self, Part};
use super::shadow::Shadows;
use super::trace::Hits;
use super::{
    medium_after_crossing, offset, shadow_ray, shift_path, PathOptions, PathStats, NO_MEDIUM,
};
use crate::accel::Ray;
use crate::bsdf::{CoatChoice, Lobe, Lobes, Material, Normals};
use crate::light::{Lights, NO_TEXEL};
use crate::medium::phase::Hg;
use crate::medium::tracking;
use crate::method::{Dispersion, Shifting, Spectral};
use crate::sampler::{mix64, LazyStream, Streams};
use crate::scene::Scene;
use crate::simd::{map4, Float, Lanes, Mask, Spec, V3};
use glam::{Vec2, Vec3, Vec4};

/// The lane layout of a path's result: all four camera wavelengths, or, for a path split
/// off at a dispersive refraction, the one camera lane its lane 0 continues.
pub const ALL_LANES: u8 = 4;

/// "No emitter" in the emission cache.
const NO_EMITTER: u32 = u32::MAX;

/// The vertices that BSDF or phase sampling left, remembered for MIS when the
/// continuation lands on a light.
#[derive(Clone, Copy, Debug)]
struct Prev<F: Float> {
    /// The paths that have such a vertex (not after a specular event or at the camera).
    has: F::Mask,
    /// Per-lane pdf (solid angle) of the sampled direction.
    pdf_dir: Spec<F>,
    /// The prefix ratios before that sample.
    ratio: Spec<F>,
    /// The vertex.
    p: V3<F>,
    /// Per-lane probability that tracking passed every medium segment since (kept in
    /// scenes with media only; without, it would be 1 and is neither read nor written).
    pass: Spec<F>,
}

/// The state of W camera paths between two ray queries. A lane whose path is not
/// `alive` is free for the next pixel sample.
#[derive(Clone, Copy, Debug)]
pub struct Paths<F: Float> {
    /// The lanes whose path goes on (its next ray in `org`, `dir`).
    pub alive: F::Mask,
    /// The lanes whose next query is their camera ray.
    pub at_camera: F::Mask,
    /// Origins of the rays to trace next.
    pub org: V3<F>,
    /// Directions of the rays to trace next (over `[0, ∞)`).
    pub dir: V3<F>,
    /// The radiance gathered so far (lanes as given by `out_lane`).
    pub l: Spec<F>,
    /// The wavelengths.
    lambda: Spec<F>,
    /// f_k / p_0 over the prefix.
    beta: Spec<F>,
    /// p_j / p_0 over the prefix.
    ratio: Spec<F>,
    prev: Prev<F>,
    /// The paths that shift their lanes by the hero's shift (else independently).
    constant: F::Mask,
    /// Path segments so far.
    depth: F::Arr<i32>,
    /// The medium each path is in ([`NO_MEDIUM`] for none).
    medium: F::Arr<u32>,
    /// Index-matched boundaries crossed.
    crossings: F::Arr<u32>,
    /// The last emitter evaluated and its radiance at the path's wavelengths: a path meets
    /// the same light again and again, and its wavelengths change only at fluorescent
    /// events.
    le_emitter: F::Arr<u32>,
    le_value: Spec<F>,
    rng: Streams<F>,
    shift_rng: F::Arr<LazyStream>,
    /// [`ALL_LANES`], or the camera lane a split-off path's lane 0 stands for.
    pub out_lane: F::Arr<u8>,
    /// The driver's index of the pixel sample each path belongs to.
    pub slot: F::Arr<u32>,
}

/// The paths in `m`'s count of set lanes.
#[inline(always)]
fn count<M: Mask>(m: M) -> u64 {
    m.bits().count_ones() as u64
}

impl<F: Float> Paths<F> {
    /// W free lanes.
    pub fn empty() -> Paths<F> {
        let zero = Spec::zero();
        Paths {
            alive: F::Mask::splat(false),
            at_camera: F::Mask::splat(false),
            org: V3::splat(Vec3::ZERO),
            dir: V3::splat(Vec3::Z),
            l: zero,
            lambda: Spec::splat(500.0),
            beta: zero,
            ratio: zero,
            prev: Prev {
                has: F::Mask::splat(false),
                pdf_dir: zero,
                ratio: zero,
                p: V3::splat(Vec3::ZERO),
                pass: zero,
            },
            constant: F::Mask::splat(false),
            depth: Lanes::splat(0),
            medium: Lanes::splat(NO_MEDIUM),
            crossings: Lanes::splat(0),
            le_emitter: Lanes::splat(NO_EMITTER),
            le_value: zero,
            rng: Streams::idle(),
            shift_rng: Lanes::splat(LazyStream::new(0, 0, 0)),
            out_lane: Lanes::splat(ALL_LANES),
            slot: Lanes::splat(0),
        }
    }

    /// The wavelengths of every path.
    pub fn lambda(&self) -> &Spec<F> {
        &self.lambda
    }

    /// Starts camera paths in the lanes of `m`: path i traces the ray `org`, `dirs[i]` at
    /// wavelengths `lambda[i]`, drawing its decisions from `rng[i]` and its wavelength
    /// shifts from `shift_rng[i]`, for pixel sample `slot[i]`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn start(
        &mut self,
        scene: &Scene,
        opts: &PathOptions,
        m: F::Mask,
        org: V3<F>,
        dirs: V3<F>,
        lambda: Spec<F>,
        rng: &Streams<F>,
        shift_rng: &F::Arr<LazyStream>,
        slot: &F::Arr<u32>,
    ) {
        let beta = match opts.method.spectral {
            Spectral::Hwss => Vec4::ONE,
            Spectral::Mono => Vec4::X,
        };
        let constant =
            opts.method.spectral == Spectral::Hwss && opts.method.shifting == Shifting::Constant;
        self.org.set_where(m, org);
        self.dir.set_where(m, dirs);
        self.lambda.set_where(m, lambda);
        self.l.set_where(m, Spec::zero());
        self.beta.set_where(m, Spec::splat4(beta));
        self.ratio.set_where(m, Spec::splat4(beta));
        self.prev.has &= !m;
        self.alive |= m;
        self.at_camera |= m;
        self.constant = (self.constant & !m) | (m & F::Mask::splat(constant));
        let medium = scene.camera_medium.unwrap_or(NO_MEDIUM);
        for i in m.iter() {
            self.depth[i] = 0;
            self.medium[i] = medium;
            self.crossings[i] = 0;
            self.le_emitter[i] = NO_EMITTER;
            self.rng.set_lane(i, rng.lane(i));
            self.shift_rng[i] = shift_rng[i];
            self.out_lane[i] = ALL_LANES;
            self.slot[i] = slot[i];
        }
    }

    /// Adds path `i`'s radiance to `acc`, the pixel sample's value at the camera
    /// wavelengths.
    #[inline]
    pub fn add_to(&self, i: usize, acc: &mut Vec4) {
        let l = self.l.path(i);
        match self.out_lane[i] {
            ALL_LANES => *acc += l,
            k => acc[k as usize] += l.x,
        }
    }

    /// Path `i` alone.
    pub fn path(&self, i: usize) -> Paths<f32> {
        Paths {
            alive: self.alive.get(i),
            at_camera: self.at_camera.get(i),
            org: self.org.path(i).into(),
            dir: self.dir.path(i).into(),
            l: self.l.path(i).into(),
            lambda: self.lambda.path(i).into(),
            beta: self.beta.path(i).into(),
            ratio: self.ratio.path(i).into(),
            prev: Prev {
                has: self.prev.has.get(i),
                pdf_dir: self.prev.pdf_dir.path(i).into(),
                ratio: self.prev.ratio.path(i).into(),
                p: self.prev.p.path(i).into(),
                pass: self.prev.pass.path(i).into(),
            },
            constant: self.constant.get(i),
            depth: [self.depth[i]],
            medium: [self.medium[i]],
            crossings: [self.crossings[i]],
            le_emitter: [self.le_emitter[i]],
            le_value: self.le_value.path(i).into(),
            rng: self.rng.lane(i),
            shift_rng: [self.shift_rng[i]],
            out_lane: [self.out_lane[i]],
            slot: [self.slot[i]],
        }
    }

    /// Puts the path `p` into lane `i`.
    pub fn set_path(&mut self, i: usize, p: &Paths<f32>) {
        self.alive = self.alive.with(i, p.alive);
        self.at_camera = self.at_camera.with(i, p.at_camera);
        self.org.set_path(i, p.org.into());
        self.dir.set_path(i, p.dir.into());
        self.l.set_path(i, p.l.into());
        self.lambda.set_path(i, p.lambda.into());
        self.beta.set_path(i, p.beta.into());
        self.ratio.set_path(i, p.ratio.into());
        self.prev.has = self.prev.has.with(i, p.prev.has);
        self.prev.pdf_dir.set_path(i, p.prev.pdf_dir.into());
        self.prev.ratio.set_path(i, p.prev.ratio.into());
        self.prev.p.set_path(i, p.prev.p.into());
        self.prev.pass.set_path(i, p.prev.pass.into());
        self.constant = self.constant.with(i, p.constant);
        self.depth[i] = p.depth[0];
        self.medium[i] = p.medium[0];
        self.crossings[i] = p.crossings[0];
        self.le_emitter[i] = p.le_emitter[0];
        self.le_value.set_path(i, p.le_value.into());
        self.rng.set_lane(i, p.rng);
        self.shift_rng[i] = p.shift_rng[0];
        self.out_lane[i] = p.out_lane[0];
        self.slot[i] = p.slot[0];
    }

    /// Moves the path in lane `i` of `src` into lane `j`, field by field (no one-path
    /// record in between: the driver's gathering moves many paths), and frees lane `i`.
    /// The same result as `set_path(j, &src.path(i))` and `src.alive.with(i, false)`.
    #[inline(always)]
    pub fn take_lane(&mut self, j: usize, src: &mut Paths<F>, i: usize) {
        fn spec<F: Float>(d: &mut Spec<F>, j: usize, s: &Spec<F>, i: usize) {
            for k in 0..4 {
                d.0[k].set(j, s.0[k].get(i));
            }
        }
        fn v3<F: Float>(d: &mut V3<F>, j: usize, s: &V3<F>, i: usize) {
            d.set_path(j, s.path(i));
        }
        self.alive = self.alive.with(j, src.alive.get(i));
        self.at_camera = self.at_camera.with(j, src.at_camera.get(i));
        v3(&mut self.org, j, &src.org, i);
        v3(&mut self.dir, j, &src.dir, i);
        spec(&mut self.l, j, &src.l, i);
        spec(&mut self.lambda, j, &src.lambda, i);
        spec(&mut self.beta, j, &src.beta, i);
        spec(&mut self.ratio, j, &src.ratio, i);
        self.prev.has = self.prev.has.with(j, src.prev.has.get(i));
        spec(&mut self.prev.pdf_dir, j, &src.prev.pdf_dir, i);
        spec(&mut self.prev.ratio, j, &src.prev.ratio, i);
        v3(&mut self.prev.p, j, &src.prev.p, i);
        spec(&mut self.prev.pass, j, &src.prev.pass, i);
        self.constant = self.constant.with(j, src.constant.get(i));
        self.depth[j] = src.depth[i];
        self.medium[j] = src.medium[i];
        self.crossings[j] = src.crossings[i];
        self.le_emitter[j] = src.le_emitter[i];
        spec(&mut self.le_value, j, &src.le_value, i);
        self.rng.set_lane(j, src.rng.lane(i));
        self.shift_rng[j] = src.shift_rng[i];
        self.out_lane[j] = src.out_lane[i];
        self.slot[j] = src.slot[i];
        src.alive = src.alive.with(i, false);
    }

    /// Whether path `i` is inside a medium.
    pub fn in_medium(&self, i: usize) -> bool {
        self.medium[i] != NO_MEDIUM
    }

    /// Ends the paths in `m`.
    #[inline(always)]
    fn kill(&mut self, m: F::Mask) {
        self.alive &= !m;
    }

    /// The radiance of emitter `e[i]` at path i's wavelengths, for the paths in `m`
    /// (cached per path; other lanes hold whatever they held).
    #[inline(always)]
    fn emission(&mut self, m: F::Mask, e: &F::Arr<u32>, lights: &Lights) -> Spec<F> {
        for i in m.iter() {
            if self.le_emitter[i] != e[i] {
                self.le_emitter[i] = e[i];
                let le = lights.emitters[e[i] as usize].spectral_radiance(self.lambda.path(i));
                self.le_value.set_path(i, le);
            }
        }
        self.le_value
    }

    /// A wavelength-shifting event for path `i` (fluorescent surface or medium
    /// scattering): samples its lanes' input wavelengths and forgets the cached emission,
    /// whose wavelengths are gone. `false` ends the path.
    #[inline]
    fn shift(&mut self, i: usize, model: &(impl super::ShiftModel + ?Sized)) -> bool {
        let mode = if self.constant.get(i) {
            Shifting::Constant
        } else {
            Shifting::Independent
        };
        self.le_emitter[i] = NO_EMITTER;
        let rng = self.shift_rng[i].get();
        shift_path(
            model,
            mode,
            i,
            &mut self.lambda,
            &mut self.beta,
            &mut self.ratio,
            rng,
        )
    }

    /// Russian roulette from the third bounce for the paths in `m`: a path survives with
    /// probability min(max_k beta[k], 0.95) and is divided by it. Returns the survivors.
    #[inline(always)]
    fn roulette(&mut self, m: F::Mask) -> F::Mask {
        let deep = m & F::Mask::from_fn(|i| self.depth[i] >= 3);
        if deep.none() {
            return m;
        }
        census::record(Part::Roulette, deep);
        let q = self.beta.max_wavelength().min(F::splat(0.95));
        let u = self.rng.draw(deep);
        let die = deep & u.ge(q);
        self.kill(die);
        let live = deep & !die;
        self.beta.set_where(live, self.beta / q);
        m & !die
    }

    /// Advances the live paths by the results `hit` of tracing their rays: gathers
    /// emission and light, samples the next directions. Paths that go on keep their lane
    /// (`alive`, next ray in `org`, `dir`); next-event shadow rays to trace are left in
    /// `shadow`; a path split at a dispersive refraction ends, and its single-wavelength
    /// continuations are pushed to `children`.
    #[inline(always)]
    pub fn step<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        opts: &PathOptions,
        hit: &Hits<F>,
        stats: &mut PathStats,
        shadow: &mut Shadows<F>,
        children: &mut Vec<Paths<f32>>,
    ) {
        let active = self.alive;
        census::record(Part::Step, active);
        stats.rays += count(active);
        self.at_camera = F::Mask::splat(false);
        let mut s = active;
        if MEDIA {
            let inside = active & F::Mask::from_fn(|i| self.medium[i] != NO_MEDIUM);
            if inside.any() {
                census::record(Part::Track, inside);
                s = (active & !inside) | self.track(scene, opts, hit, inside, stats, shadow);
            }
        }
        let escaped = s & !hit.valid;
        if escaped.any() && scene.lights.environment.is_some() {
            census::record(Part::Escaped, escaped);
            self.escaped::<MEDIA>(scene, escaped);
        }
        self.kill(escaped);
        s &= hit.valid;
        if s.none() {
            return;
        }
        let p = self.org + self.dir * hit.t;
        let ng = hit.ng.normalize();
        // Lane i's geometry; a lane outside `s` (a miss) reads the last one, whatever it
        // is, so that the per-lane tests below need no branch on the mask.
        let last_geometry = scene.geometries.len() - 1;
        let geometry = |i: usize| &scene.geometries[(hit.geom[i] as usize).min(last_geometry)];

        // An index-matched medium boundary: cross it without scattering.
        if MEDIA {
            let null = s & F::Mask::from_fn(|i| geometry(i).is_null_interface());
            if null.any() {
                census::record(Part::Cross, null);
                self.cross(scene, hit, null, p, ng);
                s &= !null;
                if s.none() {
                    return;
                }
            }
        }
        for i in 0..F::WIDTH {
            self.depth[i] += s.get(i) as i32;
        }
        let wo = -self.dir;
        self.emitted::<MEDIA>(scene, hit, s, p, ng, wo);

        // Paths at their last segment, or on a surface without a material, end here.
        let mut mat = <F::Arr<u32> as Lanes<u32>>::splat(0);
        let ends = F::Mask::from_fn(|i| {
            let last = opts.max_depth >= 0 && self.depth[i] >= opts.max_depth;
            let material = geometry(i).material;
            let shades = s.get(i) & !last & material.is_some();
            mat[i] = material.unwrap_or(0) * shades as u32;
            s.get(i) & !shades
        });
        self.kill(ends);
        s &= !ends;
        let nrm = shading_normals(scene, hit, s, ng, wo);
        let uv = texture_coords(scene, hit, s, &mat);
        let coat = self.choose_coat(scene, &mat, s, &nrm, wo, &uv);
        let shifts = match scene.features.fluorescent_surfaces {
            true => s,
            false => F::Mask::splat(false),
        };
        for i in shifts.iter() {
            let shifted = match &scene.materials[mat[i] as usize] {
                Material::FluorescentDiffuse {
                    reradiation,
                    map: None,
                } => self.shift(i, reradiation.as_ref()),
                Material::FluorescentDiffuse {
                    reradiation,
                    map: Some(map),
                } => self.shift(i, &map.at(reradiation, uv[i])),
                Material::Coated(c) if !coat.mirror.get(i) && c.fluoresces() => {
                    match (c.reradiation(), c.map()) {
                        (Some(b), Some(map)) => self.shift(i, &map.at(b, uv[i])),
                        (b, _) => b.is_none_or(|b| self.shift(i, b.as_ref())),
                    }
                }
                _ => true,
            };
            if !shifted {
                s = s.with(i, false);
                self.alive = self.alive.with(i, false);
            }
        }
        if s.none() {
            return;
        }
        census::record(Part::Surface, s);
        let mut lobes = Lobes::none();
        lobes.fill(&scene.materials, &mat, s, &self.lambda, &coat, &uv);
        if census::ENABLED {
            for kind in lobes.kinds() {
                census::record(Part::LobeKinds, kind);
            }
        }
        self.light_sample::<MEDIA>(scene, hit, s, &lobes, p, &nrm, wo, stats, shadow);
        self.scatter_surface::<MEDIA>(scene, opts, hit, s, &lobes, &mat, p, &nrm, wo, children);
    }

    /// The paths in `m` that are on coated surfaces choose between the coat's reflection
    /// (probability P, the same for every lane; a rough coat's paths take 1/P here, a
    /// smooth coat's with its mirror's weight) and the base; the base's paths take what
    /// the coat does to light leaving towards `wo` at their current wavelengths (λo,
    /// before any shift), over 1 − P, and the base's albedo when it does not fluoresce
    /// (a fluorescent base's re-radiation comes with the shift); a textured base's albedo
    /// at the paths' texture coordinates `uv`. [`crate::bsdf::coated`].
    #[inline(always)]
    fn choose_coat(
        &mut self,
        scene: &Scene,
        mat: &F::Arr<u32>,
        m: F::Mask,
        nrm: &Normals<F>,
        wo: V3<F>,
        uv: &F::Arr<Vec2>,
    ) -> CoatChoice<F> {
        if !scene.features.coated {
            return CoatChoice::none();
        }
        let on_coat = |i: usize| matches!(scene.materials[mat[i] as usize], Material::Coated(_));
        let coated = m & F::Mask::from_fn(|i| m.get(i) && on_coat(i));
        if coated.none() {
            return CoatChoice::none();
        }
        let u = self.rng.draw(coated);
        let cos_o = nrm.ns.dot(wo).abs();
        let mut mirror = F::Mask::splat(false);
        let mut p_mirror = F::splat(1.0);
        let mut left = coated;
        while let Some(first) = left.iter().next() {
            let id = mat[first];
            let same = left & F::Mask::from_fn(|i| mat[i] == id);
            left &= !same;
            let Material::Coated(c) = &scene.materials[id as usize] else {
                continue;
            };
            let p = c.p_coat(cos_o);
            p_mirror = F::select(same, p, p_mirror);
            mirror |= same & u.lt(p);
            if c.is_rough() {
                let m = same & u.lt(p);
                self.beta.set_where(m, self.beta / p);
            }
            let base = same & !u.lt(p);
            if base.any() {
                let w = match (c.reradiation(), c.map()) {
                    (Some(b), Some(map)) => {
                        let rho = Spec::from_fn(|i| match base.get(i) {
                            true => {
                                let at = map.at(b, uv[i]);
                                map4(self.lambda.path(i), |l| at.d(l))
                            }
                            false => Vec4::ZERO,
                        });
                        let w =
                            c.exit_textured(cos_o, &self.lambda, base, &rho) / (F::splat(1.0) - p);
                        match b.is_fluorescent() {
                            true => w,
                            false => w * rho,
                        }
                    }
                    _ => {
                        let mut w = c.exit(cos_o, &self.lambda, base) / (F::splat(1.0) - p);
                        if let Some(b) = c.reradiation().filter(|b| !b.is_fluorescent()) {
                            w *= b.diagonal().eval_w(&self.lambda, base);
                        }
                        w
                    }
                };
                self.beta.set_where(base, self.beta * w);
            }
        }
        CoatChoice {
            mirror,
            cos_o,
            p: p_mirror,
        }
    }

    /// Crosses index-matched boundaries at `p` (normals `ng`) for the paths in `m`.
    #[inline]
    fn cross(&mut self, scene: &Scene, hit: &Hits<F>, m: F::Mask, p: V3<F>, ng: V3<F>) {
        for i in m.iter() {
            self.crossings[i] += 1;
            if self.crossings[i] > 256 {
                self.alive = self.alive.with(i, false);
                continue;
            }
            self.medium[i] =
                medium_after_crossing(scene, hit.geom[i], ng.path(i), self.dir.path(i));
        }
        self.org.set_where(m, offset(p, ng, self.dir));
    }

    /// Emission seen by the paths in `m`, which hit the surfaces at `p`: weighted against
    /// light sampling at the previous vertex where there is one.
    #[inline(always)]
    fn emitted<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        hit: &Hits<F>,
        m: F::Mask,
        p: V3<F>,
        ng: V3<F>,
        wo: V3<F>,
    ) {
        let lights = &scene.lights;
        let cos = ng.dot(wo);
        let mut e = <F::Arr<u32> as Lanes<u32>>::splat(0);
        let facing = F::Mask::from_fn(|i| {
            m.get(i)
                && match lights.emitter_index_of(hit.geom[i]) {
                    Some(k) => {
                        e[i] = k;
                        lights.emitters[k as usize].emits_towards(cos.get(i))
                    }
                    None => false,
                }
        });
        if facing.none() {
            return;
        }
        census::record(Part::Emitted, facing);
        let le = self.emission(facing, &e, lights);
        let p_light = |after: F::Mask, pv: &Prev<F>| {
            let d2 = (p - pv.p).length_squared();
            let cos_l = cos.abs();
            let area = F::from_fn(|i| {
                if after.get(i) {
                    lights.pdf_area(hit.geom[i], hit.prim[i])
                } else {
                    0.0
                }
            });
            area * d2 / cos_l.max(F::splat(1e-12))
        };
        self.add_emission::<MEDIA>(facing, le, p_light);
    }

    /// The environment's radiance seen by the paths in `m`, whose rays left the scene:
    /// weighted against light sampling at the previous vertex where there is one.
    #[inline(never)]
    fn escaped<const MEDIA: bool>(&mut self, scene: &Scene, m: F::Mask) {
        let lights = &scene.lights;
        let Some(env) = &lights.environment else {
            return;
        };
        let dir = self.dir;
        let le = match &env.map {
            Some(map) => Spec::from_fn(|i| match m.get(i) {
                true => map.radiance(map.texel(dir.path(i).normalize()), self.lambda.path(i)),
                false => Vec4::ZERO,
            }),
            None => self.emission(m, &Lanes::splat(env.emitter), lights),
        };
        let p_light = |after: F::Mask, _: &Prev<F>| {
            F::from_fn(|i| match after.get(i) {
                true => lights.pdf_environment(dir.path(i).normalize()),
                false => 0.0,
            })
        };
        self.add_emission::<MEDIA>(m, le, p_light);
    }

    /// Adds the emitted radiance `le` that the paths in `m` see: in full for a camera
    /// ray or after a specular event, else with the balance heuristic against light
    /// sampling at the previous vertex, where `p_light` (of the paths it concerns and that
    /// vertex) gives the solid-angle density of light sampling. Without media no pass
    /// probability is kept (it would be 1): `prev.pass` is neither read nor written.
    #[inline(always)]
    fn add_emission<const MEDIA: bool>(
        &mut self,
        m: F::Mask,
        le: Spec<F>,
        p_light: impl FnOnce(F::Mask, &Prev<F>) -> F,
    ) {
        let lit = m & !le.is_zero();
        let direct = lit & !self.prev.has;
        if direct.any() {
            self.l
                .set_where(direct, self.l + self.beta * le / self.ratio.sum());
        }
        let after = lit & self.prev.has;
        if after.any() {
            let pv = &self.prev;
            let p_light = p_light(after, pv);
            let p_dir = match MEDIA {
                true => pv.pdf_dir * pv.pass,
                false => pv.pdf_dir,
            };
            let denom = (pv.ratio * (p_dir + Spec::broadcast(p_light))).sum();
            // beta already holds f/p_dir,0 (and the passes' T/P_0): put the hero's pdf back.
            let add = self.beta * le * (p_dir.hero() / denom);
            self.l.set_where(after, self.l + add);
        }
    }

    /// Next-event estimation at the non-specular surface vertices of the paths in `m`: one
    /// point on a light each, MIS against BSDF sampling; the shadow rays go to `shadow`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn light_sample<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        hit: &Hits<F>,
        m: F::Mask,
        lobes: &Lobes<F>,
        p: V3<F>,
        nrm: &Normals<F>,
        wo: V3<F>,
        stats: &mut PathStats,
        shadow: &mut Shadows<F>,
    ) {
        let ng = nrm.ng;
        let u = self.rng.draws::<3>(m);
        let m = m & !lobes.is_specular();
        if m.none() {
            return;
        }
        let geom = &hit.geom;
        let medium_of = |q: F::Mask, wi: &V3<F>, paths: &Self| {
            // Leaving the surface towards wi: which medium is the shadow ray in?
            let same_side = (ng.dot(*wi) * ng.dot(wo)).gt(F::splat(0.0));
            let mut medium = paths.medium;
            for i in (q & !same_side).iter() {
                medium[i] = medium_after_crossing(scene, geom[i], ng.path(i), wi.path(i));
            }
            medium
        };
        let eval = |wi: &V3<F>| lobes.eval(nrm, wo, *wi);
        self.next_event::<MEDIA>(scene, m, u, (p, ng), eval, medium_of, stats, shadow);
    }

    /// Next-event estimation for the paths in `m` at the points `p` (pushed off the
    /// surfaces of normals `n` by shadow rays; `n = 0` in a medium): one point on a light
    /// each from `u`, weighed against direction sampling with `f_pdf(wi)` (value·|cos| or
    /// phase, and the per-lane pdf of sampling wi); the shadow rays, leaving in the media
    /// `medium_of` says, go to `shadow`. One estimator for surfaces and media.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn next_event<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        m: F::Mask,
        u: [F; 3],
        (p, n): (V3<F>, V3<F>),
        f_pdf: impl FnOnce(&V3<F>) -> (Spec<F>, Spec<F>),
        medium_of: impl FnOnce(F::Mask, &V3<F>, &Self) -> F::Arr<u32>,
        stats: &mut PathStats,
        shadow: &mut Shadows<F>,
    ) {
        census::record(Part::LightSample, m);
        let ls = scene.lights.sample_towards_w(m, p, u);
        let q = m & ls.valid;
        if q.none() {
            return;
        }
        let (f, pdf_dir) = f_pdf(&ls.wi);
        let q = q & !f.is_zero();
        if q.none() {
            return;
        }
        let mut le = self.emission(q, &ls.emitter, &scene.lights) * Spec::broadcast(ls.falloff);
        if let Some(map) = scene.lights.environment_map() {
            for i in q.iter().filter(|&i| ls.texel[i] != NO_TEXEL) {
                le.set_path(i, map.radiance(ls.texel[i], self.lambda.path(i)));
            }
        }
        // No direction sampling finds a delta light: the light sample takes it all.
        let pdf_dir = Spec::select(ls.delta, Spec::zero(), pdf_dir);
        let ray = shadow_ray(p, n, ls.p, ls.n, ls.wi);
        census::record(Part::ShadowRay, q);
        stats.rays += count(q);
        let base = self.beta * f * le;
        if MEDIA {
            let medium = medium_of(q, &ls.wi, self);
            let (lambda, ratio) = (&self.lambda, &self.ratio);
            shadow.push_media(q, ray, base, &medium, lambda, ratio, ls.pdf, pdf_dir);
        } else {
            let denom = (self.ratio * (Spec::broadcast(ls.pdf) + pdf_dir)).sum();
            shadow.push(q, ray, base / denom);
        }
    }

    /// Continues the paths in `m` with their hero's BSDF sample (splitting those whose
    /// lanes refract apart at a dispersive interface).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn scatter_surface<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        opts: &PathOptions,
        hit: &Hits<F>,
        m: F::Mask,
        lobes: &Lobes<F>,
        mat: &F::Arr<u32>,
        p: V3<F>,
        nrm: &Normals<F>,
        wo: V3<F>,
        children: &mut Vec<Paths<f32>>,
    ) {
        census::record(Part::Scatter, m);
        let zero = F::splat(0.0);
        let ng = nrm.ng;
        let [uc, u0, u1] = self.rng.draws::<3>(m);
        let u = [u0, u1];
        let bs = lobes.sample(nrm, wo, uc, u);
        let p0 = bs.pdf.hero();
        let mut s = m & bs.valid & p0.gt(zero);
        self.kill(m & !s);
        if s.none() {
            return;
        }
        let refracts = (ng.dot(bs.wi) * ng.dot(wo)).lt(zero);
        if opts.method.dispersion == Dispersion::Split {
            let refracted = s & bs.specular & refracts;
            let apart = match refracted.any() {
                false => refracted,
                true => {
                    refracted
                        & F::Mask::from_fn(|i| {
                            (1..4).any(|k| self.ratio[k].get(i) != 0.0 && bs.pdf[k].get(i) == 0.0)
                        })
                }
            };
            for i in apart.iter() {
                let uv = uv_at(scene, hit, i);
                let lobe = scene.materials[mat[i] as usize].at_uv(uv, self.lambda.path(i));
                let geom = hit.geom[i];
                let mut one = self.path(i);
                one.split::<MEDIA>(
                    scene,
                    &lobe,
                    p.path(i),
                    &nrm.path(i),
                    wo.path(i),
                    geom,
                    children,
                );
            }
            self.kill(apart);
            s &= !apart;
        }
        let ratio_prev = self.ratio;
        self.beta.set_where(s, self.beta * (bs.f_cos / p0));
        self.ratio.set_where(s, self.ratio * (bs.pdf / p0));
        let pv = &mut self.prev;
        pv.has = (pv.has & !s) | (s & !bs.specular);
        pv.pdf_dir.set_where(s, bs.pdf);
        pv.ratio.set_where(s, ratio_prev);
        pv.p.set_where(s, p);
        if MEDIA {
            pv.pass.set_where(s, Spec::splat(1.0));
        }
        let black = s & self.beta.is_zero();
        self.kill(black);
        s &= !black;
        // Crossing the surface (refraction) changes the medium.
        if MEDIA {
            for i in (s & refracts).iter() {
                self.medium[i] =
                    medium_after_crossing(scene, hit.geom[i], ng.path(i), bs.wi.path(i));
            }
        }
        let s = self.roulette(s);
        self.org.set_where(s, offset(p, ng, bs.wi));
        self.dir.set_where(s, bs.wi);
    }

    /// Distance sampling for the paths in `m`, which are inside a medium: hero-driven with
    /// per-lane pdfs. Paths that collide scatter there (or end); returns those that reach
    /// the surface `hit`.
    #[inline(always)]
    fn track(
        &mut self,
        scene: &Scene,
        opts: &PathOptions,
        hit: &Hits<F>,
        m: F::Mask,
        stats: &mut PathStats,
        shadow: &mut Shadows<F>,
    ) -> F::Mask {
        // Left a medium that is not closed.
        self.kill(m & !hit.valid);
        let m = m & hit.valid;
        if m.none() {
            return m;
        }
        let tracking = opts.method.tracking;
        let (st, ss) = super::shadow::coefficients(scene, m, &self.medium, &self.lambda);
        let g = F::from_fn(|i| match m.get(i) {
            true => scene.media[self.medium[i] as usize].phase().g,
            false => 0.0,
        });
        let d = hit.t * self.dir.length();
        let u = self.rng.draw(m);
        let (collide, t) = tracking::sample_distance(tracking, st.hero(), ss.hero(), d, u);
        let c = m & collide;
        let reach = m & !collide;
        let mut surface = reach;
        if reach.any() {
            let ps = tracking::prob_surface(tracking, st, ss, d);
            let ok = reach & ps.hero().gt(F::splat(0.0));
            self.kill(reach & !ok);
            self.beta
                .set_where(ok, self.beta * (tracking::transmittance(st, d) / ps.hero()));
            self.ratio.set_where(ok, self.ratio * (ps / ps.hero()));
            let pass = ok & self.prev.has;
            self.prev.pass.set_where(pass, self.prev.pass * ps);
            surface = ok;
        }
        if c.any() {
            census::record(Part::MediumScatter, c);
            self.scatter_medium(scene, opts, c, st, ss, Hg::new(g), d, t, stats, shadow);
        }
        surface
    }

    /// A real collision at distance `t` for the paths in `m`: the tracking weights, the
    /// wavelength shift of the medium's scattering (its value over pdf supplies σ̂_s),
    /// next-event estimation MIS against phase sampling, and the phase sample.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn scatter_medium(
        &mut self,
        scene: &Scene,
        opts: &PathOptions,
        m: F::Mask,
        st: Spec<F>,
        ss: Spec<F>,
        phase: Hg<F>,
        d: F,
        t: F,
        stats: &mut PathStats,
        shadow: &mut Shadows<F>,
    ) {
        let zero = F::splat(0.0);
        let pdf = tracking::pdf_collision(opts.method.tracking, st, ss, d, t);
        let ok = m & pdf.hero().gt(zero);
        self.kill(m & !ok);
        let mut m = ok;
        self.beta
            .set_where(m, self.beta * (tracking::transmittance(st, t) / pdf.hero()));
        self.ratio.set_where(m, self.ratio * (pdf / pdf.hero()));
        for i in m.iter() {
            self.depth[i] += 1;
            let last = opts.max_depth >= 0 && self.depth[i] >= opts.max_depth;
            let alive = !last && {
                let med = &scene.media[self.medium[i] as usize];
                self.shift(i, med)
            };
            if !alive {
                m = m.with(i, false);
                self.alive = self.alive.with(i, false);
            }
        }
        let dir = self.dir.normalize();
        let p = self.org + dir * t;
        let wo = -dir;
        // Three for the light sample, two for the phase sample.
        let [u0, u1, u2, u3, u4] = self.rng.draws::<5>(m);
        let u = [u0, u1, u2];
        let f_pdf = |wi: &V3<F>| {
            let f = Spec::broadcast(phase.eval_dirs(wo, *wi));
            (f, f)
        };
        let medium_of = |_: F::Mask, _: &V3<F>, paths: &Self| paths.medium;
        let at = (p, V3::splat(Vec3::ZERO));
        self.next_event::<true>(scene, m, u, at, f_pdf, medium_of, stats, shadow);
        let (wi, pdf_dir) = phase.sample(wo, [u3, u4]);
        let ok = m & pdf_dir.gt(zero);
        self.kill(m & !ok);
        let m = ok;
        // Phase sampling is exact (f = pdf) and the same for every lane.
        let pv = &mut self.prev;
        pv.has |= m;
        pv.pdf_dir.set_where(m, Spec::broadcast(pdf_dir));
        pv.ratio.set_where(m, self.ratio);
        pv.p.set_where(m, p);
        pv.pass.set_where(m, Spec::splat(1.0));
        let m = self.roulette(m);
        self.org.set_where(m, p);
        self.dir.set_where(m, wi);
    }
}

/// The texture coordinates of the surface hits of the paths in `m`, where their material
/// is textured (zero elsewhere: nothing reads them).
#[inline(always)]
fn texture_coords<F: Float>(
    scene: &Scene,
    hit: &Hits<F>,
    m: F::Mask,
    mat: &F::Arr<u32>,
) -> F::Arr<Vec2> {
    if !scene.features.textured {
        return Lanes::from_fn(|_| Vec2::ZERO);
    }
    let textured = |i: usize| scene.materials[mat[i] as usize].is_textured();
    Lanes::from_fn(|i| match m.get(i) && textured(i) {
        true => uv_at(scene, hit, i),
        false => Vec2::ZERO,
    })
}

/// The texture coordinates of path `i`'s hit (zero on a mesh without them: the scene
/// loader gives every textured shape coordinates).
#[inline]
fn uv_at<F: Float>(scene: &Scene, hit: &Hits<F>, i: usize) -> Vec2 {
    let g = &scene.geometries[hit.geom[i] as usize];
    g.uv(hit.prim[i], hit.u.get(i), hit.v.get(i))
        .unwrap_or(Vec2::ZERO)
}

/// The normals at the surface hits of the paths in `m` (geometric normals `ng`, unit):
/// the meshes' interpolated shading normals where they have them ([`Normals::new`]),
/// turned to the geometric normal's side (a file whose normals point inwards still shades),
/// and their ∂p/∂u tangents where they have texture coordinates.
#[inline(always)]
fn shading_normals<F: Float>(
    scene: &Scene,
    hit: &Hits<F>,
    m: F::Mask,
    ng: V3<F>,
    wo: V3<F>,
) -> Normals<F> {
    if !scene.features.shading {
        return Normals::flat(ng);
    }
    // One look at each hit's geometry: its shading normal and tangent, if it has them.
    let nt: F::Arr<(Option<Vec3>, Option<Vec3>)> = Lanes::from_fn(|i| {
        if !m.get(i) {
            return (None, None);
        }
        let g = &scene.geometries[hit.geom[i] as usize];
        match g.shading {
            None => (None, None),
            Some(_) => (
                g.shading_normal(hit.prim[i], hit.u.get(i), hit.v.get(i)),
                g.tangent(hit.prim[i]),
            ),
        }
    });
    let has = F::Mask::from_fn(|i| nt[i].0.is_some());
    let has_t = F::Mask::from_fn(|i| nt[i].1.is_some());
    let mut nrm = Normals::flat(ng);
    if has.any() {
        let ns = V3::from_fn(|i| {
            let g = ng.path(i);
            match nt[i].0 {
                Some(v) if v.dot(g) < 0.0 => -v,
                Some(v) => v,
                None => g,
            }
        });
        nrm = Normals::new(ng, ns, has, wo);
    }
    if has_t.any() {
        nrm = nrm.with_tangents(V3::from_fn(|i| nt[i].1.unwrap_or(Vec3::X)), has_t);
    }
    nrm
}

impl Paths<f32> {
    /// A camera path about to trace `camera_ray` at the wavelengths `lambda`, drawing its
    /// decisions from `rng` and its wavelength shifts from `shift_rng`.
    pub fn camera(
        scene: &Scene,
        camera_ray: Ray,
        lambda: Vec4,
        opts: &PathOptions,
        rng: Streams<f32>,
        shift_rng: LazyStream,
    ) -> Paths<f32> {
        let mut p = Paths::empty();
        p.start(
            scene,
            opts,
            true,
            camera_ray.org.into(),
            camera_ray.dir.into(),
            lambda.into(),
            &rng,
            &[shift_rng],
            &[0],
        );
        p
    }

    /// Splits the path at a dispersive refraction (the hero refracted and some live lane
    /// refracts elsewhere) into one single-wavelength path per live lane, each leaving in
    /// its own direction.
    ///
    /// Lane k's path is the shared prefix, the choice to refract, then its own suffix.
    /// Every "lane j as hero" technique generates it with p_j(prefix)·(1 − F_j), times the
    /// suffix's pdf, which is the same for every technique and cancels. So the child
    /// carries beta_k·(1 − F_k)/η_k² / (1 − F_0) and, as its only ratio, the prefix's MIS
    /// denominator Σ_j ratio_j·(1 − F_j)/(1 − F_0); from there on it is a mono path.
    #[allow(clippy::too_many_arguments)]
    #[cold]
    fn split<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        material: &Lobe,
        p: Vec3,
        nrm: &Normals<f32>,
        wo: Vec3,
        geom: u32,
        children: &mut Vec<Paths<f32>>,
    ) {
        let Some((dirs, f_cos, pdf)) = material.refract_lanes(nrm, wo) else {
            return;
        };
        let ng: Vec3 = nrm.ng.into();
        let p0 = pdf.x;
        if p0 <= 0.0 {
            return;
        }
        let denom = (self.ratio * (Spec::from(pdf) / p0)).sum();
        // The children's random streams: keyed by two draws of this path's stream, so
        // they are the same at every width.
        let rng = &mut self.rng;
        let key = ((rng.next_u32() as u64) << 32) | rng.next_u32() as u64;
        let (pv, nv) = (V3::<f32>::from(p), V3::<f32>::from(ng));
        for (k, wi) in dirs.into_iter().enumerate() {
            let Some(wi) = wi else { continue };
            let b = self.beta[k] * f_cos[k] / p0;
            if b == 0.0 || !b.is_finite() {
                continue;
            }
            let mut child = *self;
            child.alive = true;
            child.at_camera = false;
            child.org = offset(pv, nv, V3::from(wi));
            child.dir = wi.into();
            child.l = Spec::zero();
            child.out_lane = [k as u8];
            child.lambda = Spec::splat(self.lambda[k]);
            child.beta = Spec::from(Vec4::new(b, 0.0, 0.0, 0.0));
            child.ratio = Spec::from(Vec4::new(denom, 0.0, 0.0, 0.0));
            child.prev.has = false;
            if MEDIA {
                child.medium = [medium_after_crossing(scene, geom, ng, wi)];
            }
            child.le_emitter = [NO_EMITTER];
            child.rng = Streams::new(mix64(key), k as u64);
            child.shift_rng = [LazyStream::new(key, k as u64, u64::MAX)];
            child.constant = false;
            if child.roulette(true) {
                children.push(child);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::{F4, F8};

    /// A one-path record whose every field holds a value derived from `k` (a struct
    /// literal without `..`, so that a new field must be given a value here too).
    fn distinct(k: u32) -> Paths<f32> {
        let x = k as f32;
        let v4 = |o: f32| Vec4::new(x + o, x + o + 0.25, x + o + 0.5, x + o + 0.75);
        let v3 = |o: f32| Vec3::new(x + o, x + o + 0.25, x + o + 0.5);
        Paths {
            alive: true,
            at_camera: k.is_multiple_of(2),
            org: v3(1.0).into(),
            dir: v3(2.0).into(),
            l: v4(3.0).into(),
            lambda: v4(400.0).into(),
            beta: v4(5.0).into(),
            ratio: v4(6.0).into(),
            prev: Prev {
                has: k.is_multiple_of(3),
                pdf_dir: v4(7.0).into(),
                ratio: v4(8.0).into(),
                p: v3(9.0).into(),
                pass: v4(10.0).into(),
            },
            constant: k.is_multiple_of(5),
            depth: [k as i32 + 11],
            medium: [k + 12],
            crossings: [k + 13],
            le_emitter: [k + 14],
            le_value: v4(15.0).into(),
            rng: Streams::new(k as u64, 16),
            shift_rng: [LazyStream::new(k as u64, 17, 18)],
            out_lane: [(k % 4) as u8],
            slot: [k + 19],
        }
    }

    /// Moving a path field by field leaves both packets as the one-path record would
    /// (every field, every lane), at widths 4 and 8.
    #[test]
    fn take_lane_moves_every_field_as_the_one_path_record_does() {
        fn check<F: Float>() {
            let w = F::WIDTH;
            let mut source = Paths::<F>::empty();
            let mut target = Paths::<F>::empty();
            for i in 0..w {
                source.set_path(i, &distinct(i as u32));
                target.set_path(i, &distinct(100 + i as u32));
            }
            for (i, j) in [(1, 2), (0, w - 1), (w - 1, 0)] {
                target.alive = target.alive.with(j, false);
                let (mut want_target, mut want_source) = (target, source);
                want_target.set_path(j, &source.path(i));
                want_source.alive = want_source.alive.with(i, false);
                target.take_lane(j, &mut source, i);
                assert_eq!(
                    format!("{target:?}"),
                    format!("{want_target:?}"),
                    "{i} → {j}"
                );
                assert_eq!(
                    format!("{source:?}"),
                    format!("{want_source:?}"),
                    "{i} → {j}"
                );
                source.set_path(i, &distinct(i as u32));
            }
        }
        check::<F4>();
        check::<F8>();
    }
}
