//! Packet tracing: many paths advance together, one bounce at a time, and every query —
//! camera, bounce and next-event shadow rays (in media: each shadow-ray segment between
//! index-matched boundaries) — goes to Embree four rays at a time.
//!
//! The paths of a [`Wavefront`] start as 2×2 pixel quads, so the first packets are the
//! coherent camera rays of one quad. After each bounce the surviving paths are either
//! regrouped into full packets ([`Grouping::Regroup`]) or kept in their quads with dead
//! lanes masked off ([`Grouping::Lockstep`]). A path that splits at a dispersive
//! refraction continues as a packet of its own whose lanes are its four wavelengths.
//!
//! Each path is the same state machine as in single-ray mode ([`super::path`]) with the
//! same random numbers, so both modes compute the same estimate per pixel sample.

use super::path::{Path, ShadowQuery};
use super::{PathOptions, PathStats, ShadowStep};
use crate::accel::{Coherence, Hit, RayHit4};
use crate::scene::Scene;
use glam::Vec4;

/// An empty lane of a packet.
const NONE: u32 = u32::MAX;

/// How paths are packed into packets after the first bounce.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Grouping {
    /// Compact the surviving paths into full packets at every bounce.
    Regroup,
    /// Keep each quad's paths together, masking the lanes whose path has ended.
    Lockstep,
}

/// The paths of one batch of pixel samples and the buffers to advance them (kept
/// between batches to avoid reallocating).
#[derive(Default)]
pub struct Wavefront {
    paths: Vec<Path>,
    /// Lanes of the packets of the next query, four per packet; [`NONE`] for empty.
    active: Vec<u32>,
    next: Vec<u32>,
    hits: Vec<Option<Hit>>,
    shadows: Vec<(u32, ShadowQuery)>,
    ended: Vec<u32>,
    children: Vec<Path>,
    /// Where each split path's children start in `children`.
    child_groups: Vec<usize>,
    /// Packet lanes that carried a ray.
    pub lanes_used: u64,
    /// Lanes of all packets traced (4 per query).
    pub lanes_total: u64,
}

impl Wavefront {
    /// Makes room for `lanes` paths (and as many hits) without reallocating.
    pub fn reserve(&mut self, lanes: usize) {
        self.paths.reserve(lanes);
        self.active.reserve(lanes);
        self.next.reserve(lanes);
        self.hits.reserve(lanes);
        self.ended.reserve(lanes);
        self.shadows.reserve(lanes);
    }

    /// Empties the batch.
    pub fn clear(&mut self) {
        self.paths.clear();
        self.active.clear();
    }

    /// Adds a path as the next lane (lanes fill packets in order: push a quad's four
    /// pixels one after the other).
    pub fn push(&mut self, path: Path) {
        self.active.push(self.paths.len() as u32);
        self.paths.push(path);
    }

    /// Leaves the next lane empty (a quad sticking out of the image).
    pub fn push_empty(&mut self) {
        self.active.push(NONE);
    }

    /// Runs every path to its end, adding each path's radiance to `results[path.slot]`.
    pub fn run<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        opts: &PathOptions,
        grouping: Grouping,
        results: &mut [Vec4],
        stats: &mut PathStats,
    ) {
        while !self.active.len().is_multiple_of(4) {
            self.active.push(NONE);
        }
        let accel = &scene.accel;
        while !self.active.is_empty() {
            // Trace this bounce's rays, four per query.
            self.hits.clear();
            self.hits.resize(self.active.len(), None);
            for (c, lanes) in self.active.chunks_exact(4).enumerate() {
                let mut packet = RayHit4::new();
                let mut mask = [false; 4];
                let mut camera = true;
                for (k, &i) in lanes.iter().enumerate() {
                    if i != NONE {
                        let path = &self.paths[i as usize];
                        packet.set_ray(k, &path.ray);
                        mask[k] = true;
                        camera &= path.at_camera;
                    }
                }
                let coherence = if camera {
                    Coherence::Coherent
                } else {
                    Coherence::Incoherent
                };
                accel.intersect4(&mut packet, mask, coherence);
                self.lanes_total += 4;
                for (k, &live) in mask.iter().enumerate() {
                    if live {
                        self.hits[c * 4 + k] = packet.hit(k);
                        self.lanes_used += 1;
                    }
                }
            }

            // Advance every path by its hit.
            self.next.clear();
            self.shadows.clear();
            self.ended.clear();
            for (lane, &i) in self.active.iter().enumerate() {
                if i == NONE {
                    self.next.push(NONE);
                    continue;
                }
                let path = &mut self.paths[i as usize];
                let mut shadow = None;
                let before = self.children.len();
                let alive = path.step::<MEDIA>(
                    scene,
                    opts,
                    self.hits[lane],
                    stats,
                    &mut shadow,
                    &mut self.children,
                );
                if self.children.len() > before {
                    self.child_groups.push(before);
                }
                if let Some(s) = shadow {
                    self.shadows.push((i, s));
                }
                if alive {
                    self.next.push(i);
                } else {
                    self.ended.push(i);
                    self.next.push(NONE);
                }
            }

            // Next-event shadow rays, four per query.
            if MEDIA {
                self.trace_media_shadows(scene, opts, stats);
            }
            for group in self.shadows.chunks(4) {
                let mut packet = RayHit4::new();
                let mut mask = [false; 4];
                for (k, (_, s)) in group.iter().enumerate() {
                    packet.set_ray(k, &s.ray);
                    mask[k] = true;
                }
                // Incoherent even from a quad's camera hits: each lane has its own light point.
                accel.occluded4(&mut packet, mask, Coherence::Incoherent);
                self.lanes_total += 4;
                self.lanes_used += group.len() as u64;
                for (k, (i, s)) in group.iter().enumerate() {
                    if !packet.occluded(k) {
                        self.paths[*i as usize].l += s.contribution;
                    }
                }
            }

            for &i in &self.ended {
                let path = &self.paths[i as usize];
                path.add_to(&mut results[path.slot as usize]);
            }

            // The next packets: split-off paths first, one packet per split path (its
            // lanes are that path's wavelengths).
            self.active.clear();
            self.child_groups.push(self.children.len());
            for w in 1..self.child_groups.len() {
                let (a, b) = (self.child_groups[w - 1], self.child_groups[w]);
                for child in &self.children[a..b] {
                    self.active.push(self.paths.len() as u32);
                    self.paths.push(child.clone());
                }
                while !self.active.len().is_multiple_of(4) {
                    self.active.push(NONE);
                }
            }
            self.children.clear();
            self.child_groups.clear();
            match grouping {
                Grouping::Regroup => {
                    self.active
                        .extend(self.next.iter().copied().filter(|&i| i != NONE));
                    while !self.active.len().is_multiple_of(4) {
                        self.active.push(NONE);
                    }
                }
                Grouping::Lockstep => {
                    for lanes in self.next.chunks_exact(4) {
                        if lanes.iter().any(|&i| i != NONE) {
                            self.active.extend_from_slice(lanes);
                        }
                    }
                }
            }
        }
    }

    /// Traces the shadow rays of a scene with media segment by segment, four segments per
    /// `intersect4`, until each is blocked or reaches its light; empties `shadows`.
    fn trace_media_shadows(&mut self, scene: &Scene, opts: &PathOptions, stats: &mut PathStats) {
        let mut pending = std::mem::take(&mut self.shadows);
        while !pending.is_empty() {
            let mut next = Vec::new();
            for group in pending.chunks_mut(4) {
                let mut packet = RayHit4::new();
                let mut mask = [false; 4];
                for (k, (_, s)) in group.iter().enumerate() {
                    packet.set_ray(k, &s.ray);
                    mask[k] = true;
                }
                scene
                    .accel
                    .intersect4(&mut packet, mask, Coherence::Incoherent);
                self.lanes_total += 4;
                self.lanes_used += group.len() as u64;
                for (k, (i, s)) in group.iter_mut().enumerate() {
                    let Some(m) = s.media.as_mut() else { continue };
                    let hit = packet.hit(k);
                    match m.segment(scene, &mut s.ray, hit, opts.method.tracking, s.contribution) {
                        ShadowStep::Blocked => {}
                        ShadowStep::Reached(c) => self.paths[*i as usize].l += c,
                        ShadowStep::Continue => {
                            stats.rays += 1;
                            next.push((*i, *s));
                        }
                    }
                }
            }
            pending = next;
        }
        self.shadows = pending;
    }
}
