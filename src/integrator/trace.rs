//! The driver: feeds pixel samples to W lanes of paths ([`Paths`]) and their rays to
//! Embree, W at a time ([`Width`]: single rays for W = 1, `rtcIntersect4`/`rtcOccluded4`
//! for W = 4).
//!
//! A lane whose path ends takes the next pixel sample at once (or a path split off at a
//! dispersive refraction), so the lanes stay busy until the work runs out. Each pixel
//! sample's radiance goes to its own slot, and the film adds the slots in sample order
//! afterwards: which lane or packet carried a sample changes nothing in the image.

use super::path::Paths;
use super::shadow::Shadows;
use super::{PathOptions, PathStats};
use crate::accel::{self, Coherence, Ray};
use crate::method::Spectral;
use crate::sampler::{LazyStream, Streams};
use crate::scene::Scene;
use crate::simd::{Float, Lanes, Mask, F4, F8, V3};
use crate::spectrum;
use glam::{Vec3, Vec4};

/// The closest hits of W rays.
#[derive(Clone, Copy, Debug)]
pub struct Hits<F: Float> {
    /// The lanes whose ray hit something.
    pub valid: F::Mask,
    /// Distances along the rays (in units of their direction's length).
    pub t: F,
    /// Unnormalised geometric normals.
    pub ng: V3<F>,
    /// Geometry ids.
    pub geom: F::Arr<u32>,
    /// Triangle indices.
    pub prim: F::Arr<u32>,
    /// Barycentric coordinate of the triangle's vertex 1 (Embree's `u`; 0 for a miss),
    /// for [`crate::scene::Geometry::shading_normal`] and [`crate::scene::Geometry::uv`].
    pub u: F,
    /// Barycentric coordinate of vertex 2 (Embree's `v`; 0 for a miss).
    pub v: F,
}

/// A lane width the renderer traces with: how W rays go to Embree.
pub trait Width: Float {
    /// Groups of W paths a tracer keeps in flight. With more than one, their shadow rays
    /// go to Embree together as a stream ([`PATHS_IN_FLIGHT`]); single rays keep one path
    /// and trace each shadow ray alone (as a stream they measured slower: `docs/packets.md`,
    /// "Random streams in SIMD, shadow rays as Embree streams").
    const GROUPS: usize;
    /// The closest hits of the rays `org + t·dir`, t in `[0, tfar]`, of the lanes in
    /// `active` (the other lanes miss).
    fn intersect(
        accel: &accel::Scene,
        org: &V3<Self>,
        dir: &V3<Self>,
        tfar: Self,
        active: Self::Mask,
        coherence: Coherence,
    ) -> Hits<Self>;
    /// The lanes of `active` whose ray is blocked.
    fn occluded(
        accel: &accel::Scene,
        org: &V3<Self>,
        dir: &V3<Self>,
        tfar: Self,
        active: Self::Mask,
    ) -> Self::Mask;
    /// Appends the rays `org + t·dir`, t in `[0, tfar]`, of the lanes in `active` to
    /// `stream` as one packet of W (the other lanes, and those Embree cannot trace,
    /// skipped: checked for all lanes at once); returns where it starts.
    fn push_rays(
        stream: &mut RayStream,
        org: &V3<Self>,
        dir: &V3<Self>,
        tfar: Self,
        active: Self::Mask,
    ) -> usize;
    /// The closest hits of the packet that [`Self::push_rays`] put at `at`, once the
    /// stream was traced (the lanes it skipped miss).
    fn stream_hits(stream: &RayStream, at: usize) -> Hits<Self>;
}

/// Closest-hit rays of the groups in flight, traced as one stream: one for the camera
/// rays, one for the bounce rays ([`Tracer::trace_streams`]).
pub type RayStream = accel::PacketStream<PATHS_IN_FLIGHT>;

/// The lanes whose ray `org + t·dir`, t in `[0, tfar]`, Embree can trace
/// ([`accel::Ray::is_traceable`]), all at once: every coordinate within ±[`FLT_LARGE`]
/// (so not NaN or infinite) and `tfar` not NaN.
///
/// [`FLT_LARGE`]: accel::FLT_LARGE
#[inline(always)]
fn traceable<F: Float>(org: &V3<F>, dir: &V3<F>, tfar: F) -> F::Mask {
    let ok = |x: F| x.abs().le(F::splat(accel::FLT_LARGE));
    ok(org.x) & ok(org.y) & ok(org.z) & ok(dir.x) & ok(dir.y) & ok(dir.z) & tfar.eq(tfar)
}

/// One path's ray over `[0, tfar]`.
#[inline(always)]
fn ray1(org: &V3<f32>, dir: &V3<f32>, tfar: f32) -> Ray {
    Ray {
        org: (*org).into(),
        dir: (*dir).into(),
        tnear: 0.0,
        tfar,
    }
}

impl Width for f32 {
    const GROUPS: usize = 1;
    #[inline(always)]
    fn intersect(
        accel: &accel::Scene,
        org: &V3<f32>,
        dir: &V3<f32>,
        tfar: f32,
        active: bool,
        _: Coherence,
    ) -> Hits<f32> {
        let hit = match active {
            true => accel.intersect1(&ray1(org, dir, tfar)),
            false => None,
        };
        Hits::from_hit(hit)
    }

    #[inline(always)]
    fn occluded(
        accel: &accel::Scene,
        org: &V3<f32>,
        dir: &V3<f32>,
        tfar: f32,
        active: bool,
    ) -> bool {
        active && accel.occluded1(&ray1(org, dir, tfar))
    }

    #[inline(always)]
    fn push_rays(
        stream: &mut RayStream,
        org: &V3<f32>,
        dir: &V3<f32>,
        tfar: f32,
        active: bool,
    ) -> usize {
        let ok = active & traceable(org, dir, tfar);
        let rays = accel::RaysN {
            org: [[org.x], [org.y], [org.z]],
            dir: [[dir.x], [dir.y], [dir.z]],
            tfar: [if ok { tfar } else { f32::NEG_INFINITY }],
        };
        stream.push_checked(&rays)
    }

    #[inline(always)]
    fn stream_hits(stream: &RayStream, at: usize) -> Hits<f32> {
        Hits::from_hit(stream.hits::<1>(at).hit(0))
    }
}

impl Hits<f32> {
    /// A single ray's hit, or its miss.
    #[inline(always)]
    fn from_hit(hit: Option<accel::Hit>) -> Hits<f32> {
        match hit {
            Some(h) => Hits {
                valid: true,
                t: h.t,
                ng: h.ng.into(),
                geom: [h.geom_id],
                prim: [h.prim_id],
                u: h.u,
                v: h.v,
            },
            None => Hits {
                valid: false,
                t: 0.0,
                ng: V3::splat(Vec3::Z),
                geom: [u32::MAX],
                prim: [0],
                u: 0.0,
                v: 0.0,
            },
        }
    }
}

/// [`Width`] for a packet type of `$w` lanes: its rays in Embree's SoA layout, queried
/// with `$intersect`/`$occluded`, converted by the functions of module `$soa`.
macro_rules! packet_width {
    ($f:ident, $w:literal, $soa:ident, $intersect:ident, $occluded:ident) => {
        mod $soa {
            use super::*;

            /// The rays of the paths' vectors in Embree's SoA layout.
            #[inline(always)]
            pub fn rays(org: &V3<$f>, dir: &V3<$f>, tfar: $f) -> accel::RaysN<$w> {
                let a = |f: $f| f.0.to_array();
                accel::RaysN {
                    org: [a(org.x), a(org.y), a(org.z)],
                    dir: [a(dir.x), a(dir.y), a(dir.z)],
                    tfar: a(tfar),
                }
            }

            /// Embree's hits as the paths' vectors.
            #[inline(always)]
            pub fn hits(h: &accel::HitsN<$w>) -> Hits<$f> {
                let f = |v| $f(v);
                let hit = Mask::from_fn(|k| h.geom[k] != u32::MAX);
                // Embree leaves a miss's barycentrics unwritten.
                let zero = <$f as Float>::splat(0.0);
                Hits {
                    valid: hit,
                    t: f(h.t.into()),
                    ng: V3::new(f(h.ng[0].into()), f(h.ng[1].into()), f(h.ng[2].into())),
                    geom: h.geom,
                    prim: h.prim,
                    u: <$f as Float>::select(hit, f(h.u.into()), zero),
                    v: <$f as Float>::select(hit, f(h.v.into()), zero),
                }
            }
        }

        impl Width for $f {
            const GROUPS: usize = PATHS_IN_FLIGHT / <$f as Float>::WIDTH;
            #[inline(always)]
            fn intersect(
                accel: &accel::Scene,
                org: &V3<$f>,
                dir: &V3<$f>,
                tfar: $f,
                active: <$f as Float>::Mask,
                coherence: Coherence,
            ) -> Hits<$f> {
                let valid = Lanes::from_fn(|k| active.get(k));
                let h = accel.$intersect(&$soa::rays(org, dir, tfar), valid, coherence);
                $soa::hits(&h)
            }

            #[inline(always)]
            fn occluded(
                accel: &accel::Scene,
                org: &V3<$f>,
                dir: &V3<$f>,
                tfar: $f,
                active: <$f as Float>::Mask,
            ) -> <$f as Float>::Mask {
                let valid = Lanes::from_fn(|k| active.get(k));
                let rays = $soa::rays(org, dir, tfar);
                let o = accel.$occluded(&rays, valid, Coherence::Incoherent);
                Mask::from_fn(|k| o[k])
            }

            #[inline(always)]
            fn push_rays(
                stream: &mut RayStream,
                org: &V3<$f>,
                dir: &V3<$f>,
                tfar: $f,
                active: <$f as Float>::Mask,
            ) -> usize {
                let ok = active & traceable(org, dir, tfar);
                let skip = <$f as Float>::splat(f32::NEG_INFINITY);
                let tfar = <$f as Float>::select(ok, tfar, skip);
                stream.push_checked(&$soa::rays(org, dir, tfar))
            }

            #[inline(always)]
            fn stream_hits(stream: &RayStream, at: usize) -> Hits<$f> {
                $soa::hits(&stream.hits::<$w>(at))
            }
        }
    };
}

packet_width!(F4, 4, soa4, intersect4_soa, occluded4_soa);
packet_width!(F8, 8, soa8, intersect8_soa, occluded8_soa);

/// One pixel sample: pixel (x, y), sample index `index` of that pixel's streams, and the
/// `slot` its radiance and wavelengths go to.
#[derive(Clone, Copy, Debug, Default)]
pub struct SampleId {
    /// Column.
    pub x: u32,
    /// Row.
    pub y: u32,
    /// Sample index.
    pub index: u32,
    /// Where the results go.
    pub slot: u32,
}

/// Every ray a tracer traced, by kind (see `stokes bench limit`).
#[derive(Debug, Default, Clone)]
pub struct RayLog {
    /// Camera rays (closest hit).
    pub camera: Vec<Ray>,
    /// Bounce rays after the camera (closest hit).
    pub bounce: Vec<Ray>,
    /// Next-event shadow rays in scenes without media (occlusion).
    pub shadow: Vec<Ray>,
    /// Shadow-ray segments through media (closest hit).
    pub segment: Vec<Ray>,
}

impl RayLog {
    /// The rays of the lanes `m` of a query.
    fn push<F: Float>(to: &mut Vec<Ray>, m: F::Mask, org: &V3<F>, dir: &V3<F>, tfar: F) {
        to.extend(m.iter().map(|i| Ray {
            org: org.path(i),
            dir: dir.path(i),
            tnear: 0.0,
            tfar: tfar.get(i),
        }));
    }
}

/// Paths a packet tracer keeps in flight, in groups of W: the shadow rays of all of them
/// go to Embree together, as one stream. `rtcOccluded1M` packs a stream into packets of
/// its own and traces it about 1.6× as fast as 4-wide packets or single rays (`stokes
/// bench limit`: a Cornell box's shadow rays in streams of 32 against 4-wide packets),
/// while streams of 4 gain nothing. 128 rather than 64: a round runs the refill, Embree's
/// camera and shadow streams and the hand-in once for all its groups, and with the step
/// their code does not fit the first-level instruction cache; twice the paths per round
/// fetch it half as often per path (`benches/cachesim.py`; `docs/packets.md`, "Where packets
/// miss the caches").
pub const PATHS_IN_FLIGHT: usize = 128;

/// W lanes of paths, their shadow rays, and which of them were live before the step.
struct Group<F: Float> {
    paths: Paths<F>,
    shadows: Shadows<F>,
    live: F::Mask,
    /// Which of the round's streams holds the paths' rays, and where, if they were
    /// traced ahead of the step ([`Tracer::trace_streams`]).
    rays_at: Option<(Stream, usize)>,
}

/// The two closest-hit streams of a round, and their index in [`Tracer`]'s arrays.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Stream {
    /// Groups whose live paths all start at the camera: coherent.
    Camera = 0,
    /// The other groups' rays: incoherent.
    Bounce = 1,
}

impl<F: Float> Group<F> {
    fn new(paths: Paths<F>) -> Group<F> {
        Group {
            paths,
            shadows: Shadows::default(),
            live: F::Mask::splat(false),
            rays_at: None,
        }
    }
}

/// The groups of W lanes of paths and their buffers, kept from one batch of samples to
/// the next.
pub struct Tracer<F: Width> {
    groups: Vec<Group<F>>,
    /// Paths split off at dispersive refractions, waiting for a lane.
    pending: Vec<Paths<f32>>,
    /// The groups' shadow rays, in group and lane order.
    shadow_rays: accel::OcclusionStream,
    /// The round's closest-hit rays traced ahead of their steps, by [`Stream`]: the
    /// camera rays of the groups that start together, and the rays of the other groups
    /// with live paths, each in group order (Embree 3).
    #[cfg_attr(embree4, allow(dead_code))]
    streams: [Box<RayStream>; 2],
    /// Rays of each stream's kind queued in it this round, by [`Stream`] (a bounce
    /// group's camera rays are not counted).
    #[cfg_attr(embree4, allow(dead_code))]
    queued: [u64; 2],
    /// Packet lanes that carried a ray (W > 1).
    pub lanes_used: u64,
    /// Lanes of all packets traced (W per query, W > 1).
    pub lanes_total: u64,
    /// Paths that started a step inside a medium (W > 1, scenes with media), and W for
    /// each group step that had any: how busy the medium's parts of the step run.
    pub medium_lanes_used: u64,
    pub medium_lanes_total: u64,
    /// Paths whose camera ray a step traced (W > 1), and W for each group step that
    /// traced any: how full the camera packets go to Embree.
    pub camera_lanes_used: u64,
    pub camera_lanes_total: u64,
    /// Camera rays traced in a stream ahead of their step ([`Self::trace_streams`]).
    pub camera_rays_streamed: u64,
    /// Bounce rays (closest hit, not from the camera) traced in a stream ahead of their
    /// step.
    pub bounce_rays_streamed: u64,
    /// Refill a group's lanes only when every one of them is free (the samples of a
    /// packet run until the longest path ends, as Mitsuba 3 runs them), to measure what
    /// refilling buys.
    pub lockstep: bool,
    /// The lanes of each group the tracer may fill (bit i for lane i; all by default): a
    /// test hook for packets with empty lanes.
    pub usable: u32,
    /// Where every traced ray is recorded, if anywhere (`stokes bench limit`).
    pub log: Option<Box<RayLog>>,
    /// Gather the free lanes before each refill, and the paths that start a round inside
    /// a medium after it, into as few groups as they fill ([`Self::sort_lanes`]); a test
    /// hook to turn it off.
    pub sort: bool,
    /// Trace the camera rays of the groups whose paths all start at the camera as one
    /// coherent stream ([`Self::trace_streams`]); a test hook to turn it off.
    pub stream_cameras: bool,
    /// Trace the other groups' closest-hit rays as one incoherent stream; a test hook
    /// to turn it off.
    pub stream_bounces: bool,
}

impl<F: Width> Default for Tracer<F> {
    fn default() -> Tracer<F> {
        Tracer {
            groups: (0..F::GROUPS).map(|_| Group::new(Paths::empty())).collect(),
            pending: Vec::new(),
            shadow_rays: accel::OcclusionStream::default(),
            streams: Default::default(),
            queued: [0; 2],
            lanes_used: 0,
            lanes_total: 0,
            medium_lanes_used: 0,
            medium_lanes_total: 0,
            camera_lanes_used: 0,
            camera_lanes_total: 0,
            camera_rays_streamed: 0,
            bounce_rays_streamed: 0,
            lockstep: false,
            usable: u32::MAX,
            log: None,
            sort: true,
            stream_cameras: true,
            stream_bounces: true,
        }
    }
}

impl<F: Width> Tracer<F> {
    /// Runs every sample of `work` to its end: `results[slot]` gets the sample's radiance
    /// at its camera wavelengths (balance-heuristic weighted, see [`super::radiance`]),
    /// `lambdas[slot]` the wavelengths.
    ///
    /// Each round refills the free lanes and traces the camera rays of the groups that
    /// start together, steps every group once, then traces the shadow rays of all groups,
    /// then hands in the paths that ended: each path's radiance takes the same additions
    /// in the same order as if its group ran alone. The camera and shadow streams are
    /// filled group by group right after the refill or the step that made the rays, while
    /// the group's state is still in the first-level data cache, which 32 groups of
    /// 1.6 KB (width 4) do not fit.
    #[allow(clippy::too_many_arguments)]
    pub fn run<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        opts: &PathOptions,
        seed: u64,
        work: &mut impl Iterator<Item = SampleId>,
        results: &mut [Vec4],
        lambdas: &mut [Vec4],
        stats: &mut PathStats,
    ) {
        let sort = self.sort && F::GROUPS > 1 && !self.lockstep;
        let stream_rays = cfg!(embree3) && sort && (self.stream_cameras || self.stream_bounces);
        // Without media the shadow rays of all groups go to Embree as one stream, each
        // group's pushed right after its step, while its state is in the cache.
        let stream_shadows = !MEDIA && F::GROUPS > 1;
        loop {
            if sort {
                // Free lanes gathered first: the refill then starts its camera paths in
                // whole groups, and a path moves into a free lane instead of trading.
                self.sort_lanes(|g| !g.paths.alive);
                self.streams.iter_mut().for_each(|s| s.clear());
                for k in 0..F::GROUPS {
                    self.refill(k, scene, opts, seed, work, lambdas);
                    // Queued while the refill's writes are in the cache (with media,
                    // after the paths in media are gathered).
                    if stream_rays && !MEDIA {
                        self.queue_rays(k);
                    }
                }
                if MEDIA {
                    self.sort_lanes(|g| g.paths.alive & F::Mask::from_fn(|i| g.paths.in_medium(i)));
                    if stream_rays {
                        (0..F::GROUPS).for_each(|k| self.queue_rays(k));
                    }
                }
                #[cfg(embree3)]
                if stream_rays {
                    self.trace_streams(scene);
                }
            }
            if stream_shadows {
                self.shadow_rays.clear();
            }
            let mut any = false;
            for k in 0..F::GROUPS {
                if !sort {
                    self.refill(k, scene, opts, seed, work, lambdas);
                }
                let live = self.groups[k].paths.alive;
                self.groups[k].live = live;
                if live.any() {
                    any = true;
                    self.advance::<MEDIA>(k, scene, opts, stats);
                    if stream_shadows {
                        self.queue_shadows(k);
                    }
                }
            }
            if !any {
                break;
            }
            if stream_shadows {
                let n = self.shadow_rays.len();
                if n > 0 {
                    let stream = &mut self.shadow_rays;
                    scene
                        .accel
                        .occluded_stream(stream, n, Coherence::Incoherent);
                }
            } else if !MEDIA {
                self.trace_shadows(scene);
            }
            self.hand_in(results, stream_shadows);
        }
    }

    /// Adds the stream's unblocked shadow rays to their paths if the round streamed them
    /// (`streamed`: scenes without media, W > 1; otherwise they were traced alone or in
    /// the step), and hands in the paths that ended this round, group by group in one
    /// pass.
    #[inline(always)]
    fn hand_in(&mut self, results: &mut [Vec4], streamed: bool) {
        let mut r = 0;
        for g in self.groups.iter_mut() {
            let s = &mut g.shadows;
            if streamed && s.active.any() {
                let mut bits = 0;
                for i in s.active.iter() {
                    bits |= (self.shadow_rays.blocked(r) as u32) << i;
                    r += 1;
                }
                let blocked = F::Mask::from_fn(|i| bits >> i & 1 != 0);
                g.paths
                    .l
                    .set_where(s.active & !blocked, g.paths.l + s.contribution);
                s.active = F::Mask::splat(false);
            }
            for i in (g.live & !g.paths.alive).iter() {
                let slot = g.paths.slot[i] as usize;
                g.paths.add_to(i, &mut results[slot]);
            }
        }
    }

    /// Moves paths between groups so that the lanes of `kind` fill as few groups as they
    /// can: the free lanes before the refill (camera rays then go to Embree as full,
    /// coherent packets), and in scenes with media the paths inside a medium after it
    /// (the medium's parts of the step then run with their lanes busy). The groups that
    /// hold the most such lanes keep them and take the others', lane for lane, so a path
    /// moves only when its kind changes. A path computes the same bits in any lane, so
    /// the image does not change.
    fn sort_lanes(&mut self, kind: impl Fn(&Group<F>) -> F::Mask) {
        let w = F::WIDTH;
        let usable = F::Mask::from_fn(|i| self.usable >> i & 1 != 0);
        let capacity = usable.bits().count_ones();
        // Bit k of `by_count[c]`: group k holds c lanes of the kind (c ≤ W ≤ 8).
        let mut by_count = [0u64; 9];
        let mut n = 0;
        for (k, g) in self.groups.iter().enumerate() {
            let c = (kind(g) & usable).bits().count_ones();
            by_count[c as usize] |= 1 << k;
            n += c;
        }
        let partial = !(by_count[0] | by_count[capacity as usize]);
        if n == 0 || (partial & self.all_groups()).count_ones() <= 1 {
            return; // Already as gathered as it can be.
        }
        // Most first; among equal counts the lower group first, round after round.
        let mut order = [0usize; PATHS_IN_FLIGHT];
        let mut len = 0;
        for c in (0..=w).rev() {
            let mut bits = by_count[c];
            while bits != 0 {
                order[len] = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                len += 1;
            }
        }
        let (kept, rest) = order[..F::GROUPS].split_at(n.div_ceil(capacity) as usize);
        let (mut holes, mut movers) = ([0usize; PATHS_IN_FLIGHT], [0usize; PATHS_IN_FLIGHT]);
        let (mut h, mut m) = (0, 0);
        for &k in kept {
            for i in (usable & !kind(&self.groups[k])).iter() {
                holes[h] = k * w + i;
                h += 1;
            }
        }
        for &k in rest {
            for i in (usable & kind(&self.groups[k])).iter() {
                movers[m] = k * w + i;
                m += 1;
            }
        }
        for (&a, &b) in holes[..h].iter().zip(&movers[..m]) {
            self.swap_lanes(a, b);
        }
    }

    /// Queues group `k`'s closest-hit rays in one of the round's streams: in the camera
    /// stream if all its live paths start at the camera (after [`Self::sort_lanes`],
    /// every group the refill filled), else in the bounce stream.
    #[inline(always)]
    fn queue_rays(&mut self, k: usize) {
        let g = &mut self.groups[k];
        let (live, p) = (g.paths.alive, &g.paths);
        let bounces = live & !p.at_camera;
        // Counted by kind: a bounce group's camera rays are not counted.
        let (stream, on, counted) = match bounces.none() {
            true => (Stream::Camera, self.stream_cameras, live),
            false => (Stream::Bounce, self.stream_bounces, bounces),
        };
        if live.any() && on {
            let rays = &mut self.streams[stream as usize];
            let inf = F::splat(f32::INFINITY);
            let at = F::push_rays(rays, &p.org, &p.dir, inf, live);
            g.rays_at = Some((stream, at));
            self.queued[stream as usize] += counted.bits().count_ones() as u64;
        }
    }

    /// Traces the queued rays as two streams (`rtcIntersectNp`), the camera rays as
    /// coherent and the bounce rays as incoherent; each group's step reads its hits
    /// there. A stream of one packet is traced in its step instead.
    ///
    /// Embree packs a stream into packets of its widest vectors and traverses them
    /// together: `stokes bench limit` on an AMD EPYC Zen 3 replays a Cornell box's camera
    /// rays at 25–29 M rays/s as this SoA stream, 22 as 4-wide coherent packets. As an
    /// AoS stream (`rtcIntersect1M`) they replay at 32–37, but in the renderer that
    /// measured no faster (`docs/packets.md`, "Streams filled while each group is hot").
    /// The bounce stream saves the per-query call overhead of the 4-wide packets
    /// (`docs/packets.md`, "Bounce rays as a stream").
    #[cfg(embree3)]
    fn trace_streams(&mut self, scene: &Scene) {
        for (stream, coherence) in [
            (Stream::Camera, Coherence::Coherent),
            (Stream::Bounce, Coherence::Incoherent),
        ] {
            let rays = &mut *self.streams[stream as usize];
            if rays.len() <= F::WIDTH {
                // One packet at most: traced as it is, in its step.
                if !rays.is_empty() {
                    for g in self.groups.iter_mut() {
                        if g.rays_at.is_some_and(|(s, _)| s == stream) {
                            g.rays_at = None;
                        }
                    }
                }
            } else {
                scene.accel.intersect_packets(rays, coherence);
                let queued = self.queued[stream as usize];
                match stream {
                    Stream::Camera => self.camera_rays_streamed += queued,
                    Stream::Bounce => self.bounce_rays_streamed += queued,
                }
            }
        }
        self.queued = [0; 2];
    }

    /// Bit k for every group k.
    fn all_groups(&self) -> u64 {
        u64::MAX >> (64 - F::GROUPS)
    }

    /// Exchanges the paths of global lanes `a` and `b` (group · W + lane) of two groups;
    /// a path facing a free lane just moves there.
    fn swap_lanes(&mut self, a: usize, b: usize) {
        let w = F::WIDTH;
        let (ga, gb) = (a / w, b / w);
        let (ia, ib) = (a % w, b % w);
        let alive_a = self.groups[ga].paths.alive.get(ia);
        let alive_b = self.groups[gb].paths.alive.get(ib);
        // A live path moving to a free lane of another group (the common case): field
        // by field.
        if ga != gb && alive_a != alive_b {
            let ((gs, is), (gt, it)) = match alive_a {
                true => ((ga, ia), (gb, ib)),
                false => ((gb, ib), (ga, ia)),
            };
            if let Ok([source, target]) = self.groups.get_disjoint_mut([gs, gt]) {
                target.paths.take_lane(it, &mut source.paths, is);
                return;
            }
        }
        let (pa, pb) = (
            alive_a.then(|| self.groups[ga].paths.path(ia)),
            alive_b.then(|| self.groups[gb].paths.path(ib)),
        );
        for (g, i, p) in [(ga, ia, pb), (gb, ib, pa)] {
            let paths = &mut self.groups[g].paths;
            match p {
                Some(p) => paths.set_path(i, &p),
                None => paths.alive = paths.alive.with(i, false),
            }
        }
    }

    /// Gives every free lane a path: a waiting split-off path, else the next sample of
    /// `work`.
    #[inline(always)]
    fn refill(
        &mut self,
        k: usize,
        scene: &Scene,
        opts: &PathOptions,
        seed: u64,
        work: &mut impl Iterator<Item = SampleId>,
        lambdas: &mut [Vec4],
    ) {
        let paths = &mut self.groups[k].paths;
        let mut free = !paths.alive & F::Mask::from_fn(|i| self.usable >> i & 1 != 0);
        if free.none() || (self.lockstep && paths.alive.any()) {
            return;
        }
        for i in free.iter() {
            match self.pending.pop() {
                Some(child) => {
                    paths.set_path(i, &child);
                    free = free.with(i, false);
                }
                None => break,
            }
        }
        let mut fresh = F::Mask::splat(false);
        let mut ids: F::Arr<SampleId> = Lanes::splat(SampleId::default());
        for i in free.iter() {
            match work.next() {
                Some(id) => {
                    ids[i] = id;
                    fresh = fresh.with(i, true);
                }
                None => break,
            }
        }
        if fresh.any() {
            super::census::record(super::census::Part::Start, fresh);
            Self::start(paths, scene, opts, seed, fresh, &ids, lambdas);
        }
    }

    /// Starts the camera paths of samples `ids` in the lanes of `m`: a jittered ray
    /// through the pixel, the wavelengths, and the sample's two random streams (seed,
    /// pixel, sample index), in that order of draws.
    #[inline(always)]
    fn start(
        paths: &mut Paths<F>,
        scene: &Scene,
        opts: &PathOptions,
        seed: u64,
        m: F::Mask,
        ids: &F::Arr<SampleId>,
        lambdas: &mut [Vec4],
    ) {
        let camera = &scene.camera;
        let mut rng = Streams::<F>::idle();
        let mut shift: F::Arr<LazyStream> = Lanes::splat(LazyStream::new(0, 0, 0));
        let mut slot: F::Arr<u32> = Lanes::splat(0);
        for i in m.iter() {
            let id = ids[i];
            let pixel = id.y as u64 * camera.width as u64 + id.x as u64;
            rng.set_lane(i, Streams::for_sample(seed, pixel, id.index as u64));
            // The shift stream: a second, independent stream of the same pixel sample.
            shift[i] = LazyStream::new(seed, pixel, id.index as u64);
            slot[i] = id.slot;
        }
        let x = F::from_fn(|i| ids[i].x as f32) + rng.draw(m);
        let y = F::from_fn(|i| ids[i].y as f32) + rng.draw(m);
        let u = rng.draw(m);
        let dirs = camera.dirs(x, y);
        let lambda = match opts.method.spectral {
            Spectral::Hwss => spectrum::hwss(opts.method.wavelengths, u, m),
            Spectral::Mono => spectrum::mono(opts.method.wavelengths, u, m),
        };
        for i in m.iter() {
            lambdas[slot[i] as usize] = lambda.path(i);
        }
        let org = V3::splat(camera.position);
        paths.start(scene, opts, m, org, dirs, lambda, &rng, &shift, &slot);
    }

    /// One step of group `k`'s live paths: trace, step, and with media trace the shadow
    /// rays (without media [`Self::trace_shadows`] traces them with every group's).
    #[inline(always)]
    fn advance<const MEDIA: bool>(
        &mut self,
        k: usize,
        scene: &Scene,
        opts: &PathOptions,
        stats: &mut PathStats,
    ) {
        let accel = &scene.accel;
        let Group {
            paths,
            shadows,
            rays_at,
            ..
        } = &mut self.groups[k];
        let live = paths.alive;
        // Camera rays that start together go out as one coherent packet.
        let coherence = if F::WIDTH > 1 && (live & !paths.at_camera).none() {
            Coherence::Coherent
        } else {
            Coherence::Incoherent
        };
        let inf = F::splat(f32::INFINITY);
        if let Some(log) = self.log.as_deref_mut() {
            let camera = live & paths.at_camera;
            RayLog::push(&mut log.camera, camera, &paths.org, &paths.dir, inf);
            RayLog::push(&mut log.bounce, live & !camera, &paths.org, &paths.dir, inf);
        }
        let hits = match rays_at.take() {
            Some((stream, at)) => F::stream_hits(&self.streams[stream as usize], at),
            None => F::intersect(accel, &paths.org, &paths.dir, inf, live, coherence),
        };
        if F::WIDTH > 1 {
            self.lanes_used += live.bits().count_ones() as u64;
            self.lanes_total += F::WIDTH as u64;
            let camera = live & paths.at_camera;
            self.camera_lanes_used += camera.bits().count_ones() as u64;
            self.camera_lanes_total += (camera.any() as u64) * F::WIDTH as u64;
            if MEDIA {
                let inside = live & F::Mask::from_fn(|i| paths.in_medium(i));
                self.medium_lanes_used += inside.bits().count_ones() as u64;
                self.medium_lanes_total += (inside.any() as u64) * F::WIDTH as u64;
            }
        }
        // `shadows` is empty: the last round's were traced and cleared.
        paths.step::<MEDIA>(scene, opts, &hits, stats, shadows, &mut self.pending);
        if !MEDIA {
            return;
        }
        while shadows.active.any() {
            let m = shadows.active;
            if let Some(log) = self.log.as_deref_mut() {
                let s = &*shadows;
                RayLog::push(&mut log.segment, m, &s.org, &s.dir, s.tfar);
            }
            let h = F::intersect(
                accel,
                &shadows.org,
                &shadows.dir,
                shadows.tfar,
                m,
                Coherence::Incoherent,
            );
            if F::WIDTH > 1 {
                self.lanes_used += m.bits().count_ones() as u64;
                self.lanes_total += F::WIDTH as u64;
            }
            let (reached, add) = shadows.segment(scene, opts.method.tracking, &h);
            paths.l.set_where(reached, paths.l + add);
            stats.rays += shadows.active.bits().count_ones() as u64;
        }
    }

    /// Queues group `k`'s shadow rays in the round's stream (scenes without media, W > 1),
    /// in lane order after those of the groups before it.
    #[inline(always)]
    fn queue_shadows(&mut self, k: usize) {
        let s = &self.groups[k].shadows;
        if let Some(log) = self.log.as_deref_mut() {
            RayLog::push(&mut log.shadow, s.active, &s.org, &s.dir, s.tfar);
        }
        // Checked and laid out as Embree wants them for all lanes at once; an untraceable
        // ray goes as an empty segment, which Embree reports as not blocked.
        let ok = traceable(&s.org, &s.dir, s.tfar);
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let keep = |v: F, empty: F| F::select(ok, v, empty);
        let (o, d) = (&s.org, &s.dir);
        let org = F::rows([keep(o.x, zero), keep(o.y, zero), keep(o.z, zero), zero]);
        let dir = F::rows([keep(d.x, zero), keep(d.y, zero), keep(d.z, one), zero]);
        let tfar = keep(s.tfar, F::splat(-1.0));
        for i in s.active.iter() {
            self.shadow_rays.push_traceable(org[i], dir[i], tfar.get(i));
        }
    }

    /// The shadow rays of a tracer with one group (W = 1, scenes without media), traced
    /// as they are; each unblocked one adds its contribution to its path.
    #[inline(always)]
    fn trace_shadows(&mut self, scene: &Scene) {
        let accel = &scene.accel;
        for g in self.groups.iter_mut().filter(|g| g.shadows.active.any()) {
            let s = &mut g.shadows;
            if let Some(log) = self.log.as_deref_mut() {
                RayLog::push(&mut log.shadow, s.active, &s.org, &s.dir, s.tfar);
            }
            let blocked = F::occluded(accel, &s.org, &s.dir, s.tfar, s.active);
            g.paths
                .l
                .set_where(s.active & !blocked, g.paths.l + s.contribution);
            s.active = F::Mask::splat(false);
        }
    }
}

/// Runs one path (and the paths it splits into) to its end with single rays; returns its
/// radiance at its camera wavelengths.
pub fn trace_one(
    scene: &Scene,
    opts: &PathOptions,
    path: Paths<f32>,
    stats: &mut PathStats,
) -> Vec4 {
    let mut tracer = Tracer::<f32> {
        groups: vec![Group::new(path)],
        ..Tracer::default()
    };
    let mut results = [Vec4::ZERO];
    let mut lambdas = [Vec4::ZERO];
    let mut none = std::iter::empty();
    if scene.has_media() {
        tracer.run::<true>(scene, opts, 0, &mut none, &mut results, &mut lambdas, stats);
    } else {
        tracer.run::<false>(scene, opts, 0, &mut none, &mut results, &mut lambdas, stats);
    }
    results[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rays on both sides of each of Embree's limits: NaN, infinite and huge components
    /// (within and beyond ±`FLT_LARGE`), NaN, infinite and negative segment ends.
    fn rays() -> Vec<Ray> {
        let good = Ray::new(Vec3::new(0.5, 1.0, -3.0), Vec3::Z);
        let mut v = vec![good];
        let big = accel::FLT_LARGE;
        for x in [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e30,
            -2e18,
            big,
            -big,
        ] {
            for i in 0..3 {
                let mut r = good;
                r.org[i] = x;
                v.push(r);
                let mut r = good;
                r.dir[i] = x;
                v.push(r);
            }
        }
        for tfar in [f32::NAN, f32::INFINITY, -1.0, 0.0] {
            v.push(Ray { tfar, ..good });
        }
        v
    }

    /// The tracer's all-lanes-at-once check accepts exactly the rays the safe layer
    /// traces ([`Ray::is_traceable`]), in every lane of every width.
    #[test]
    fn traceable_lanes_match_the_ray_check() {
        fn check<F: Float>(rays: &[Ray]) {
            for (n, chunk) in rays.chunks(F::WIDTH).enumerate() {
                let r = |i: usize| chunk[i.min(chunk.len() - 1)];
                let lane = |f: fn(&Ray) -> f32| F::from_fn(|i| f(&r(i)));
                let org = V3::new(lane(|r| r.org.x), lane(|r| r.org.y), lane(|r| r.org.z));
                let dir = V3::new(lane(|r| r.dir.x), lane(|r| r.dir.y), lane(|r| r.dir.z));
                let ok = traceable(&org, &dir, lane(|r| r.tfar));
                for i in 0..F::WIDTH {
                    let want = r(i).is_traceable();
                    assert_eq!(ok.get(i), want, "width {}, chunk {n}: {:?}", F::WIDTH, r(i));
                }
            }
        }
        let rays = rays();
        assert!(rays.iter().any(|r| r.is_traceable()) && rays.iter().any(|r| !r.is_traceable()));
        check::<f32>(&rays);
        check::<F4>(&rays);
        check::<F8>(&rays);
    }
}
