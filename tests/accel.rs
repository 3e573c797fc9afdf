//! Integration tests of the safe Embree layer, `stokes::accel`.
//!
//! - One triangle: hit distance, ids, barycentrics and Embree's geometric-normal convention
//!   (`Ng = (v1 − v0) × (v2 − v0)`, unnormalised, not flipped towards the ray); misses;
//!   `tnear`/`tfar` clipping; `occluded1`.
//! - A non-trivial mesh (a UV sphere plus thousands of random triangles, two geometries):
//!   `intersect4` equals four `intersect1` calls bit for bit with `Coherence::Incoherent`,
//!   and up to the documented edge ambiguity with `Coherence::Coherent`; inactive lanes are
//!   left untouched; `occluded1`/`occluded4` agree with `intersect1` on every ray.
//! - Queries from a `thread_pool(2)` equal the serial ones.
//! - Errors (Embree's own and ours) come back as `EmbreeError`s instead of aborting.

use glam::Vec3;
use rayon::prelude::*;
use stokes::accel::{
    set_flush_denormals, thread_pool, Coherence, Device, EmbreeError, Hit, Ray, RayHit4, Scene,
    SceneBuilder, VertexFormat,
};

// Embree's `RTCError` codes (rtcore_device.h). Named here rather than imported from
// embree-sys, which nothing but `stokes::accel` may use.
const RTC_ERROR_UNKNOWN: u32 = 1;
const RTC_ERROR_INVALID_ARGUMENT: u32 = 2;
const RTC_ERROR_INVALID_OPERATION: u32 = 3;

// Compile-time assertions: a committed scene (and a device) can be shared across threads.
const _: () = {
    fn send_sync<T: Send + Sync>() {}
    let _ = send_sync::<Scene>;
    let _ = send_sync::<Device>;
};

// ---------------------------------------------------------------------------------------
// A small, fixed-seed PRNG (PCG32, O'Neill 2014: XSH-RR output on a 64-bit LCG).

struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut r = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6364136223846793005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in [0, 1).
    fn f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    fn in_box(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        Vec3::new(
            self.range(lo.x, hi.x),
            self.range(lo.y, hi.y),
            self.range(lo.z, hi.z),
        )
    }

    /// Uniform on the unit sphere.
    fn direction(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * self.f32();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// Four independent fair coins: all 16 active masks are equally likely.
    fn mask(&mut self) -> [bool; 4] {
        let b = self.next_u32() >> 28;
        [b & 1 != 0, b & 2 != 0, b & 4 != 0, b & 8 != 0]
    }
}

// ---------------------------------------------------------------------------------------
// Geometry and rays.

type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// The renderer's own UV sphere (`scene::shapes::uv_sphere`), as plain arrays.
fn uv_sphere(centre: Vec3, radius: f32, stacks: u32, slices: u32) -> Mesh {
    let m = stokes::scene::shapes::uv_sphere(centre, radius, stacks, slices);
    assert_eq!(m.indices.len() as u32, 2 * slices * (stacks - 1));
    (m.positions, m.indices)
}

/// `n` random triangles with vertices within `size` of a centre uniform in `[lo, hi]`.
fn random_triangles(rng: &mut Pcg32, n: usize, lo: Vec3, hi: Vec3, size: f32) -> Mesh {
    let mut v = Vec::with_capacity(3 * n);
    let mut t = Vec::with_capacity(n);
    for i in 0..n as u32 {
        let c = rng.in_box(lo, hi);
        for _ in 0..3 {
            v.push((c + size * rng.direction() * rng.f32()).to_array());
        }
        t.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    (v, t)
}

/// Geometry 0: a UV sphere of radius 1.5 (6,240 triangles); geometry 1: 4,000 random
/// triangles inside it.
fn test_scene() -> Scene {
    let device = Device::new().expect("device");
    let mut b = device.scene_builder().expect("scene builder");
    let (v, t) = uv_sphere(Vec3::ZERO, 1.5, 40, 80);
    assert_eq!(b.attach_triangles(&v, &t), Ok(0));
    let mut rng = Pcg32::new(7, 1);
    let (v, t) = random_triangles(&mut rng, 4000, Vec3::splat(-1.0), Vec3::splat(1.0), 0.3);
    assert_eq!(b.attach_triangles(&v, &t), Ok(1));
    let scene = b.commit().expect("commit");
    assert_eq!(scene.triangle_count(), 6240 + 4000);
    assert_eq!(scene.geometry_count(), 2);
    scene
}

/// Random rays: origins in `[-1.8, 1.8]³` (inside and outside the sphere), uniform directions of
/// random length, and a mix of full and clipped `[tnear, tfar]` segments.
fn random_rays(seed: u64, n: usize) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 2);
    (0..n)
        .map(|_| {
            let org = rng.in_box(Vec3::splat(-1.8), Vec3::splat(1.8));
            let dir = rng.direction() * rng.range(0.5, 2.0);
            let tnear = if rng.f32() < 0.5 {
                0.0
            } else {
                rng.range(0.0, 0.5)
            };
            let tfar = if rng.f32() < 0.5 {
                f32::INFINITY
            } else {
                rng.range(tnear, 3.0)
            };
            Ray {
                org,
                dir,
                tnear,
                tfar,
            }
        })
        .collect()
}

/// Pinhole camera rays at (0, 0, −4) looking at the origin, in 2×2 pixel quads.
fn camera_quads(w: u32, h: u32) -> Vec<[Ray; 4]> {
    let tan = (20f32).to_radians().tan();
    let ray = |x: u32, y: u32| {
        let sx = (2.0 * (x as f32 + 0.5) / w as f32 - 1.0) * tan;
        let sy = (1.0 - 2.0 * (y as f32 + 0.5) / h as f32) * tan;
        Ray::new(
            Vec3::new(0.0, 0.0, -4.0),
            Vec3::new(sx, sy, 1.0).normalize(),
        )
    };
    let mut quads = vec![];
    for y in (0..h).step_by(2) {
        for x in (0..w).step_by(2) {
            quads.push([ray(x, y), ray(x + 1, y), ray(x, y + 1), ray(x + 1, y + 1)]);
        }
    }
    quads
}

// Bitwise views, so that NaN sentinels compare equal to themselves.
fn ray_bits(r: &Ray) -> [u32; 8] {
    [
        r.org.x, r.org.y, r.org.z, r.dir.x, r.dir.y, r.dir.z, r.tnear, r.tfar,
    ]
    .map(f32::to_bits)
}

fn hit_bits(h: &Option<Hit>) -> Option<[u32; 8]> {
    h.map(|h| {
        [
            h.t.to_bits(),
            h.geom_id,
            h.prim_id,
            h.u.to_bits(),
            h.v.to_bits(),
            h.ng.x.to_bits(),
            h.ng.y.to_bits(),
            h.ng.z.to_bits(),
        ]
    })
}

/// A ray no lane should ever trace: NaN everywhere, an empty segment.
fn garbage_ray(k: usize) -> Ray {
    let nan = f32::from_bits(0x7fc0_0000 | k as u32);
    Ray {
        org: Vec3::splat(nan),
        dir: Vec3::new(nan, -nan, nan),
        tnear: -7.0 - k as f32,
        tfar: -3.0,
    }
}

/// A packet whose lanes all hold something recognisable, one of three kinds per lane:
/// - a real hit of a ray starting inside the sphere (every hit field has a known value);
/// - a ray from inside the sphere that has not been traced: it would hit if it were, so a
///   query that touches the lane changes its `tfar` and its hit;
/// - a NaN garbage ray with an empty segment.
fn sentinel_packet(scene: &Scene, rng: &mut Pcg32) -> RayHit4 {
    let mut p = RayHit4::new();
    let kind: [u32; 4] = std::array::from_fn(|_| rng.next_u32() % 3);
    let inside = |rng: &mut Pcg32| {
        Ray::new(
            rng.in_box(Vec3::splat(-0.5), Vec3::splat(0.5)),
            rng.direction(),
        )
    };
    for (k, &c) in kind.iter().enumerate() {
        let r = if c == 2 { garbage_ray(k) } else { inside(rng) };
        p.set_ray(k, &r);
    }
    let prefill = kind.map(|c| c != 2);
    scene.intersect4(&mut p, prefill, Coherence::Incoherent);
    for k in 0..4 {
        assert_eq!(
            p.hit(k).is_some(),
            prefill[k],
            "a ray from inside the closed sphere hits"
        );
        if kind[k] == 1 {
            let r = inside(rng);
            assert!(scene.occluded1(&r));
            p.set_ray(k, &r);
        }
    }
    p
}

type LaneSnapshot = ([u32; 8], Option<[u32; 8]>);

fn snapshot(p: &RayHit4) -> [LaneSnapshot; 4] {
    std::array::from_fn(|k| (ray_bits(&p.ray(k)), hit_bits(&p.hit(k))))
}

fn assert_close(a: f32, b: f32, rel: f32, what: &str) {
    assert!(
        (a - b).abs() <= rel * a.abs().max(b.abs()),
        "{what}: {a} vs {b} (relative tolerance {rel})"
    );
}

// ---------------------------------------------------------------------------------------
// Exact-looking values, compared in ULPs.
//
// Embree's arithmetic depends on the kernel it picks for the CPU (or that
// STOKES_EMBREE_CONFIG forces): its SSE and AVX/AVX2 kernels divide with a reciprocal
// approximation plus one Newton step, so even a hit at an exactly representable distance
// (t = 5 below) comes back as 4.9999995 (1 ULP low), while its AVX-512 kernels return 5.0.
// The tests therefore allow a few ULPs (units in the last place) for every float Embree
// computes — far less than any real error: a hit 1e-4 off at t = 5 is about 210 ULPs
// away, one on the neighbouring triangle has another prim_id.

/// Largest distance in ULPs that Embree's rounding is allowed (measured: at most 1).
const MAX_ULPS: u32 = 4;

/// The distance between two finite f32 in units in the last place (0 for equal values,
/// including +0 and −0).
fn ulps(a: f32, b: f32) -> u32 {
    // Map the float bits onto a monotonic integer line.
    let key = |x: f32| -> i64 {
        let i = x.to_bits() as i32 as i64;
        if i < 0 {
            i64::from(i32::MIN) - i
        } else {
            i
        }
    };
    (key(a) - key(b)).unsigned_abs().min(u32::MAX as u64) as u32
}

/// What a hit must be: an exact triangle and floats within [`MAX_ULPS`].
#[derive(Debug, Clone, Copy)]
struct Expected {
    t: f32,
    geom_id: u32,
    prim_id: u32,
    u: f32,
    v: f32,
    ng: Vec3,
}

/// Checks `hit` against `want`; the error says which field is off and by how much.
fn check_hit(hit: Option<Hit>, want: &Expected) -> Result<(), String> {
    let h = hit.ok_or_else(|| format!("expected a hit at t = {}, found a miss", want.t))?;
    if (h.geom_id, h.prim_id) != (want.geom_id, want.prim_id) {
        return Err(format!(
            "expected geometry {} triangle {}, found geometry {} triangle {}",
            want.geom_id, want.prim_id, h.geom_id, h.prim_id
        ));
    }
    let fields = [
        ("t", h.t, want.t),
        ("u", h.u, want.u),
        ("v", h.v, want.v),
        ("Ng.x", h.ng.x, want.ng.x),
        ("Ng.y", h.ng.y, want.ng.y),
        ("Ng.z", h.ng.z, want.ng.z),
    ];
    for (name, got, expected) in fields {
        let d = ulps(got, expected);
        if d > MAX_ULPS {
            return Err(format!(
                "{name}: expected {expected}, found {got} ({d} ULPs apart, at most {MAX_ULPS} allowed)"
            ));
        }
    }
    Ok(())
}

/// Asserts that `got` is within [`MAX_ULPS`] of `want`.
fn assert_ulps(got: f32, want: f32, what: &str) {
    let d = ulps(got, want);
    assert!(
        d <= MAX_ULPS,
        "{what}: expected {want}, found {got} ({d} ULPs apart, at most {MAX_ULPS} allowed)"
    );
}

#[test]
fn ulp_distance_and_hit_check_reject_wrong_hits() {
    assert_eq!(ulps(5.0, 5.0), 0);
    assert_eq!(ulps(0.0, -0.0), 0);
    assert_eq!(ulps(5.0, 4.9999995), 1);
    assert_eq!(ulps(f32::from_bits(1), -f32::from_bits(1)), 2);
    assert_eq!(ulps(1.0, 1.0 + f32::EPSILON), 1);
    let want = Expected {
        t: 5.0,
        geom_id: 0,
        prim_id: 0,
        u: 0.25,
        v: 0.25,
        ng: Vec3::new(0.0, 0.0, 8.0),
    };
    let hit = Hit {
        t: 4.9999995,
        geom_id: 0,
        prim_id: 0,
        u: 0.25,
        v: 0.25,
        ng: want.ng,
    };
    assert_eq!(check_hit(Some(hit), &want), Ok(()));
    // Each of these is a wrong hit and must be caught.
    let wrong = [
        Hit {
            t: 5.0 + 1e-4,
            ..hit
        },
        Hit {
            t: 5.0 - 1e-4,
            ..hit
        },
        Hit { prim_id: 1, ..hit },
        Hit { geom_id: 1, ..hit },
        Hit {
            u: 0.25 + 1e-4,
            ..hit
        },
        Hit {
            v: 0.75,
            u: 0.25,
            ..hit
        },
        Hit {
            ng: -want.ng,
            ..hit
        },
    ];
    for w in wrong {
        assert!(check_hit(Some(w), &want).is_err(), "{w:?} passed");
    }
    assert!(check_hit(None, &want).is_err());
}

// ---------------------------------------------------------------------------------------
// One triangle.

fn one_triangle(v: [[f32; 3]; 3]) -> Scene {
    let device = Device::new().unwrap();
    let mut b = device.scene_builder().unwrap();
    assert_eq!(b.attach_triangles(&v, &[[0, 1, 2]]), Ok(0));
    b.commit().unwrap()
}

/// The triangle of [`one_triangle`]'s tests, (0,0,2), (2,0,2), (0,4,2), as triangle 0 of a
/// 2×4 rectangle at z = 2 whose other half is triangle 1: a hit on the wrong side of the
/// shared edge is a wrong prim_id.
fn rectangle() -> Scene {
    let device = Device::new().unwrap();
    let mut b = device.scene_builder().unwrap();
    let v = [
        [0.0, 0.0, 2.0],
        [2.0, 0.0, 2.0],
        [0.0, 4.0, 2.0],
        [2.0, 4.0, 2.0],
    ];
    assert_eq!(b.attach_triangles(&v, &[[0, 1, 2], [1, 3, 2]]), Ok(0));
    b.commit().unwrap()
}

#[test]
fn single_triangle_hit_is_exact() {
    set_flush_denormals();
    // Edges (2,0,0) and (0,4,0): Ng = (0,0,8), and every value below is exactly
    // representable, so only Embree's kernel-dependent rounding (a few ULPs) separates
    // what it returns from the exact answer.
    let scene = rectangle();
    assert_eq!(scene.triangle_count(), 2);
    assert_eq!(scene.geometry_count(), 1);

    let ray = Ray::new(Vec3::new(0.5, 1.0, -3.0), Vec3::new(0.0, 0.0, 1.0));
    let front = Expected {
        t: 5.0,
        geom_id: 0,
        prim_id: 0,
        // u weighs v1 = (2,0,2), v weighs v2 = (0,4,2).
        u: 0.25,
        v: 0.25,
        // Ng = (v1 − v0) × (v2 − v0), unnormalised.
        ng: Vec3::new(0.0, 0.0, 8.0),
    };
    let h = scene.intersect1(&ray);
    check_hit(h, &front).unwrap();
    assert!(scene.occluded1(&ray));

    // From the other side: same Ng (Embree does not turn it towards the ray).
    let back = Ray::new(Vec3::new(0.5, 1.0, 7.0), Vec3::new(0.0, 0.0, -1.0));
    check_hit(scene.intersect1(&back), &front).unwrap();

    // t is in units of |dir|.
    let long = Ray::new(ray.org, Vec3::new(0.0, 0.0, 4.0));
    check_hit(scene.intersect1(&long), &Expected { t: 1.25, ..front }).unwrap();

    // The other half of the rectangle: triangle 1, (v1, v3, v2), with its own barycentrics.
    let other = Ray::new(Vec3::new(1.5, 3.0, -3.0), Vec3::Z);
    let want = Expected {
        prim_id: 1,
        // p = (1.5, 3) = v1 + u (v3 − v1) + v (v2 − v1) = (2 − 2v, 4u + 4v).
        u: 0.5,
        v: 0.25,
        // (v3 − v1) × (v2 − v1) = (0,4,0) × (−2,4,0).
        ng: Vec3::new(0.0, 0.0, 8.0),
        ..front
    };
    check_hit(scene.intersect1(&other), &want).unwrap();

    // The same through a packet, in every lane, with both coherence hints.
    for coherence in [Coherence::Coherent, Coherence::Incoherent] {
        for k in 0..4 {
            let mut p = RayHit4::new();
            p.set_ray(k, &ray);
            let mut active = [false; 4];
            active[k] = true;
            scene.intersect4(&mut p, active, coherence);
            check_hit(p.hit(k), &front).unwrap_or_else(|e| panic!("lane {k}: {e}"));
            assert_ulps(p.ray(k).tfar, 5.0, "packet tfar");
        }
    }
}

#[test]
fn single_triangle_normal_convention_general_position() {
    set_flush_denormals();
    let v = [[0.3f32, -0.2, 1.1], [1.7, 0.4, 2.3], [-0.6, 1.9, 1.6]];
    let [a, b, c] = v.map(|p| Vec3::from_array(p).as_dvec3());
    let ng = (b - a).cross(c - a);
    let scene = one_triangle(v);
    let flipped = one_triangle([v[0], v[2], v[1]]);
    let mut rng = Pcg32::new(11, 3);
    for _ in 0..1000 {
        // A random point inside the triangle, seen from a random origin.
        let (mut bu, mut bv) = (rng.f32() as f64, rng.f32() as f64);
        if bu + bv > 1.0 {
            (bu, bv) = (1.0 - bu, 1.0 - bv);
        }
        let p = a + bu * (b - a) + bv * (c - a);
        let org = rng.in_box(Vec3::splat(-3.0), Vec3::splat(3.0)).as_dvec3();
        let ray = Ray::new(org.as_vec3(), (p - org).as_vec3());
        // Stay away from the edges, where f32 rounding decides between hit and miss.
        if bu.min(bv).min(1.0 - bu - bv) < 1e-3 {
            continue;
        }
        let h = scene.intersect1(&ray).expect("hit");
        assert_close(h.t, 1.0, 1e-4, "t");
        assert_close(h.u, bu as f32, 2e-3, "u");
        assert_close(h.v, bv as f32, 2e-3, "v");
        for i in 0..3 {
            assert!(
                (h.ng[i] as f64 - ng[i]).abs() <= 1e-5 * ng.length(),
                "Ng {:?} vs {ng:?}",
                h.ng
            );
        }
        // The hit point rebuilt from (t, u, v) agrees.
        let q = ray.org + h.t * ray.dir;
        let r =
            (1.0 - h.u - h.v) * Vec3::from(v[0]) + h.u * Vec3::from(v[1]) + h.v * Vec3::from(v[2]);
        assert!((q - r).length() < 1e-4, "{q} vs {r}");
        // Swapping v1 and v2 swaps u and v and negates Ng.
        let hf = flipped.intersect1(&ray).expect("hit");
        assert_close(hf.u, h.v, 1e-4, "flipped u");
        assert_close(hf.v, h.u, 1e-4, "flipped v");
        assert!((hf.ng + h.ng).length() <= 1e-5 * h.ng.length());
    }
}

#[test]
fn single_triangle_misses_and_segment_clipping() {
    set_flush_denormals();
    let scene = one_triangle([[0.0, 0.0, 2.0], [2.0, 0.0, 2.0], [0.0, 4.0, 2.0]]);
    let org = Vec3::new(0.5, 1.0, -3.0);
    let z = Vec3::Z;
    let at = |tnear: f32, tfar: f32| Ray {
        org,
        dir: z,
        tnear,
        tfar,
    };
    // Outside the triangle, parallel to it, pointing away.
    for r in [
        Ray::new(Vec3::new(1.5, 1.5, -3.0), z),
        Ray::new(Vec3::new(-0.1, 1.0, -3.0), z),
        Ray::new(Vec3::new(0.5, 1.0, 2.0), Vec3::X),
        Ray::new(org, -z),
    ] {
        assert_eq!(scene.intersect1(&r), None, "{r:?}");
        assert!(!scene.occluded1(&r), "{r:?}");
    }
    // The segment ends before the triangle, or starts after it.
    for r in [
        at(0.0, 4.99),
        at(0.0, 4.0),
        at(5.01, 100.0),
        at(5.01, f32::INFINITY),
    ] {
        assert_eq!(scene.intersect1(&r), None, "{r:?}");
        assert!(!scene.occluded1(&r), "{r:?}");
    }
    for r in [at(0.0, 5.01), at(4.99, 5.01), at(4.99, f32::INFINITY)] {
        let t = scene.intersect1(&r).map(|h| h.t);
        assert_ulps(t.unwrap_or(f32::NAN), 5.0, &format!("{r:?}"));
        assert!(scene.occluded1(&r), "{r:?}");
    }
    // Embree makes no promise about hits exactly at tnear or tfar (Embree 3.13.5 here
    // counts tnear < t <= tfar), so the boundaries themselves are not tested.

    // occluded4 on the same rays, one per lane.
    let rays = [
        at(0.0, 4.99),
        at(0.0, 5.01),
        at(5.01, 100.0),
        at(4.99, f32::INFINITY),
    ];
    let mut p = RayHit4::new();
    for (k, r) in rays.iter().enumerate() {
        p.set_ray(k, r);
    }
    scene.occluded4(&mut p, [true; 4], Coherence::Coherent);
    assert_eq!(
        [0, 1, 2, 3].map(|k| p.occluded(k)),
        [false, true, false, true]
    );
    // A miss leaves tfar as it was, bit for bit (Embree does not compute it).
    assert_eq!(p.ray(0).tfar, 4.99);
    assert_eq!(p.ray(2).tfar, 100.0);
}

/// Rays Embree cannot trace: NaN, infinite or huge (beyond ±1.844e18) components, negative
/// or NaN tnear, NaN tfar. Debian's Embree aborts on them; the safe layer reports misses.
fn untraceable_rays() -> Vec<Ray> {
    let good = Ray::new(Vec3::new(0.5, 1.0, -3.0), Vec3::Z);
    let mut v = vec![];
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -2e18] {
        for i in 0..3 {
            let mut r = good;
            r.org[i] = bad;
            v.push(r);
            let mut r = good;
            r.dir[i] = bad;
            v.push(r);
        }
    }
    v.push(Ray {
        tnear: -1.0,
        ..good
    });
    v.push(Ray {
        tnear: -0.0,
        ..good
    }); // -0.0 >= 0: traceable, and a hit
    v.push(Ray {
        tnear: f32::NAN,
        ..good
    });
    v.push(Ray {
        tfar: f32::NAN,
        ..good
    });
    v
}

#[test]
fn untraceable_rays_are_misses_not_aborts() {
    set_flush_denormals();
    let scene = one_triangle([[0.0, 0.0, 2.0], [2.0, 0.0, 2.0], [0.0, 4.0, 2.0]]);
    let rays = untraceable_rays();
    for r in &rays {
        let ok = r.tnear.to_bits() == (-0.0f32).to_bits();
        assert_eq!(r.is_traceable(), ok, "{r:?}");
        assert_eq!(scene.intersect1(r).is_some(), ok, "{r:?}");
        assert_eq!(scene.occluded1(r), ok, "{r:?}");
    }
    // Still traceable: a huge but allowed origin, a zero direction, tnear > tfar, tnear = ∞.
    let big = Ray::new(Vec3::new(0.5, 1.0, -1.8e18), Vec3::Z);
    assert!(big.is_traceable());
    assert!(scene.occluded1(&big));
    for r in [
        Ray::new(Vec3::ZERO, Vec3::ZERO),
        Ray {
            tnear: 6.0,
            tfar: 5.0,
            ..big
        },
        Ray {
            tnear: f32::INFINITY,
            ..big
        },
    ] {
        assert!(r.is_traceable(), "{r:?}");
        assert_eq!(scene.intersect1(&r), None);
        assert!(!scene.occluded1(&r));
    }
    // In packets such lanes are left as they are, next to lanes that hit.
    let good = Ray::new(Vec3::new(0.5, 1.0, -3.0), Vec3::Z);
    for chunk in rays.chunks(3) {
        for coherence in [Coherence::Coherent, Coherence::Incoherent] {
            let mut p = RayHit4::new();
            p.set_ray(0, &good);
            for (k, r) in chunk.iter().enumerate() {
                p.set_ray(k + 1, r);
            }
            let before = snapshot(&p);
            scene.intersect4(&mut p, [true; 4], coherence);
            let t_of = |k: usize| p.hit(k).map_or(f32::NAN, |h| h.t);
            assert_ulps(t_of(0), 5.0, "lane 0");
            for (k, r) in chunk.iter().enumerate() {
                if r.is_traceable() {
                    assert_ulps(t_of(k + 1), 5.0, &format!("{r:?}"));
                } else {
                    assert_eq!(snapshot(&p)[k + 1], before[k + 1], "{r:?}");
                }
            }
            let mut p = RayHit4::new();
            p.set_ray(0, &good);
            for (k, r) in chunk.iter().enumerate() {
                p.set_ray(k + 1, r);
            }
            let before = snapshot(&p);
            scene.occluded4(&mut p, [true; 4], coherence);
            assert!(p.occluded(0));
            for (k, r) in chunk.iter().enumerate() {
                assert_eq!(p.occluded(k + 1), r.is_traceable(), "{r:?}");
                if !r.is_traceable() {
                    assert_eq!(snapshot(&p)[k + 1], before[k + 1], "{r:?}");
                }
            }
        }
    }
}

#[test]
fn empty_scene_misses() {
    set_flush_denormals();
    let scene = Device::new()
        .unwrap()
        .scene_builder()
        .unwrap()
        .commit()
        .unwrap();
    assert_eq!(scene.triangle_count(), 0);
    let r = Ray::new(Vec3::ZERO, Vec3::Z);
    assert_eq!(scene.intersect1(&r), None);
    assert!(!scene.occluded1(&r));
    let mut p = RayHit4::new();
    for k in 0..4 {
        p.set_ray(k, &r);
    }
    scene.intersect4(&mut p, [true; 4], Coherence::Incoherent);
    assert!((0..4).all(|k| p.hit(k).is_none()));
}

// ---------------------------------------------------------------------------------------
// Packets against single rays.

const N_RAYS: usize = 32_768;

/// Runs `intersect4` on `quads` with random active masks over sentinel-filled packets and
/// checks every lane: active lanes against `intersect1` (via `same`), inactive ones
/// against the sentinel they held. Returns how many active lanes hit and how many differ
/// in the primitive.
fn check_intersect4(
    scene: &Scene,
    quads: &[[Ray; 4]],
    coherence: Coherence,
    seed: u64,
    same: impl Fn(&Ray, &Option<Hit>, &Option<Hit>) -> bool,
) -> (usize, usize, usize) {
    let mut rng = Pcg32::new(seed, 4);
    let (mut active_lanes, mut hits, mut other_prim) = (0, 0, 0);
    for (i, quad) in quads.iter().enumerate() {
        let mut p = sentinel_packet(scene, &mut rng);
        let active = if i < 16 { [true; 4] } else { rng.mask() };
        for k in 0..4 {
            if active[k] {
                p.set_ray(k, &quad[k]);
            }
        }
        let before = snapshot(&p);
        scene.intersect4(&mut p, active, coherence);
        let after = snapshot(&p);
        for k in 0..4 {
            if !active[k] {
                assert_eq!(
                    after[k], before[k],
                    "inactive lane {k} of packet {i} was modified"
                );
                continue;
            }
            active_lanes += 1;
            let r = &quad[k];
            let single = scene.intersect1(r);
            let packet = p.hit(k);
            assert!(
                same(r, &single, &packet),
                "packet {i} lane {k} ({coherence:?}): {r:?}\n  intersect1 {single:?}\n  intersect4 {packet:?}"
            );
            // The lane's ray is the input ray with tfar = the hit distance (or unchanged).
            let mut expect = *r;
            if let Some(h) = packet {
                expect.tfar = h.t;
                hits += 1;
                if single.map(|s| s.prim_id) != Some(h.prim_id) {
                    other_prim += 1;
                }
            }
            assert_eq!(
                ray_bits(&p.ray(k)),
                ray_bits(&expect),
                "lane {k} ray after the query"
            );
        }
    }
    (active_lanes, hits, other_prim)
}

fn quads_of(rays: &[Ray]) -> Vec<[Ray; 4]> {
    rays.chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}

#[test]
fn intersect4_incoherent_is_bitwise_intersect1() {
    set_flush_denormals();
    let scene = test_scene();
    let rays = random_rays(1, N_RAYS);
    let (lanes, hits, other) = check_intersect4(
        &scene,
        &quads_of(&rays),
        Coherence::Incoherent,
        10,
        |_, s, p| hit_bits(s) == hit_bits(p),
    );
    eprintln!("incoherent: {lanes} active lanes, {hits} hits, {other} other primitives");
    assert!(
        lanes > N_RAYS / 2 - 500 && hits > lanes / 4 && hits < lanes * 3 / 4,
        "{lanes} lanes, {hits} hits"
    );
    assert_eq!(other, 0);
    // And on coherent camera quads (still with the incoherent flag).
    let quads = camera_quads(64, 64);
    let (_, hits, _) = check_intersect4(&scene, &quads, Coherence::Incoherent, 11, |_, s, p| {
        hit_bits(s) == hit_bits(p)
    });
    assert!(hits > 1000);
}

/// With the coherent flag a ray may differ only in the primitive, and only where the two
/// candidates are at the same distance (an edge or vertex shared by two triangles).
fn same_up_to_edges(r: &Ray, s: &Option<Hit>, p: &Option<Hit>) -> bool {
    match (s, p) {
        (None, None) => true,
        (Some(s), Some(p)) => {
            let t_ok = (s.t - p.t).abs() <= 1e-5 * s.t.abs().max(p.t.abs());
            if s.prim_id == p.prim_id && s.geom_id == p.geom_id {
                t_ok
            } else {
                // Both must be on an edge of their triangle.
                let on_edge = |h: &Hit| h.u.min(h.v).min(1.0 - h.u - h.v) < 1e-4;
                t_ok && on_edge(s) && on_edge(p) && r.tfar >= p.t
            }
        }
        _ => false,
    }
}

#[test]
fn intersect4_coherent_matches_intersect1_up_to_edges() {
    set_flush_denormals();
    let scene = test_scene();
    let rays = random_rays(2, N_RAYS);
    let (lanes, hits, other) = check_intersect4(
        &scene,
        &quads_of(&rays),
        Coherence::Coherent,
        20,
        same_up_to_edges,
    );
    eprintln!("coherent, random rays: {lanes} active lanes, {hits} hits, {other} other primitives");
    assert!(hits > lanes / 4, "{lanes} lanes, {hits} hits");
    assert!(
        other * 100 <= hits,
        "edge ties must stay rare: {other} of {hits}"
    );
    let quads = camera_quads(128, 128);
    let (lanes, hits, other) =
        check_intersect4(&scene, &quads, Coherence::Coherent, 21, same_up_to_edges);
    eprintln!(
        "coherent, camera quads: {lanes} active lanes, {hits} hits, {other} other primitives"
    );
    assert!(hits > lanes / 2);
    assert!(
        other * 100 <= hits,
        "edge ties must stay rare: {other} of {hits}"
    );
}

#[test]
fn occluded_agrees_with_intersect() {
    set_flush_denormals();
    let scene = test_scene();
    let rays = random_rays(3, N_RAYS);
    let mut occluded = 0;
    for r in &rays {
        let o = scene.occluded1(r);
        assert_eq!(o, scene.intersect1(r).is_some(), "{r:?}");
        occluded += o as usize;
    }
    assert!(
        occluded > N_RAYS / 4 && occluded < N_RAYS * 3 / 4,
        "{occluded} of {N_RAYS} occluded"
    );

    for coherence in [Coherence::Incoherent, Coherence::Coherent] {
        let mut rng = Pcg32::new(30, 5);
        for (i, quad) in quads_of(&rays).iter().enumerate() {
            let mut p = sentinel_packet(&scene, &mut rng);
            let active = rng.mask();
            for k in 0..4 {
                if active[k] {
                    p.set_ray(k, &quad[k]);
                }
            }
            let before = snapshot(&p);
            scene.occluded4(&mut p, active, coherence);
            let after = snapshot(&p);
            for k in 0..4 {
                if !active[k] {
                    assert_eq!(
                        after[k], before[k],
                        "inactive lane {k} of packet {i} was modified"
                    );
                    continue;
                }
                let r = &quad[k];
                let hit = scene.intersect1(r).is_some();
                assert_eq!(
                    p.occluded(k),
                    hit,
                    "packet {i} lane {k} ({coherence:?}): {r:?}"
                );
                let mut expect = *r;
                if hit {
                    expect.tfar = f32::NEG_INFINITY;
                }
                assert_eq!(
                    ray_bits(&p.ray(k)),
                    ray_bits(&expect),
                    "lane {k} ray after occluded4"
                );
            }
        }
    }
}

#[test]
fn thread_pool_queries_equal_serial_ones() {
    set_flush_denormals();
    let scene = test_scene();
    let rays = random_rays(4, N_RAYS);
    let serial: Vec<_> = rays
        .iter()
        .map(|r| hit_bits(&scene.intersect1(r)))
        .collect();
    let serial_occ: Vec<bool> = rays.iter().map(|r| scene.occluded1(r)).collect();
    let quads = quads_of(&rays);
    let packets = |q: &[Ray; 4]| {
        let mut p = RayHit4::new();
        for (k, r) in q.iter().enumerate() {
            p.set_ray(k, r);
        }
        scene.intersect4(&mut p, [true; 4], Coherence::Incoherent);
        [0, 1, 2, 3].map(|k| hit_bits(&p.hit(k)))
    };

    let pool = thread_pool(2).expect("pool");
    assert_eq!(pool.current_num_threads(), 2);
    let (par, par_occ, par_packets) = pool.install(|| {
        let par: Vec<_> = rays
            .par_iter()
            .with_min_len(64)
            .map(|r| hit_bits(&scene.intersect1(r)))
            .collect();
        let occ: Vec<bool> = rays
            .par_iter()
            .with_min_len(64)
            .map(|r| scene.occluded1(r))
            .collect();
        let pk: Vec<_> = quads
            .par_iter()
            .with_min_len(16)
            .flat_map_iter(packets)
            .collect();
        (par, occ, pk)
    });
    assert_eq!(par, serial);
    assert_eq!(par_occ, serial_occ);
    assert_eq!(par_packets, serial);

    // The scene can also be moved into scoped threads that share it.
    let s = &scene;
    let halves: Vec<Vec<_>> = std::thread::scope(|sc| {
        let hs: Vec<_> = rays
            .chunks(N_RAYS / 2)
            .map(|c| {
                sc.spawn(move || {
                    set_flush_denormals();
                    c.iter()
                        .map(|r| hit_bits(&s.intersect1(r)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(halves.concat(), serial);
}

// ---------------------------------------------------------------------------------------
// Errors.

fn triangle_builder() -> (SceneBuilder, Vec<[f32; 3]>) {
    let b = Device::new().unwrap().scene_builder().unwrap();
    (b, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
}

#[test]
fn invalid_vertex_format_is_embrees_error() {
    let (mut b, v) = triangle_builder();
    let e: EmbreeError = b
        .attach_triangles_with(&v, &[[0, 1, 2]], VertexFormat::Undefined)
        .expect_err("Embree rejects an undefined vertex format");
    eprintln!("{e}");
    assert_eq!(e.code, RTC_ERROR_INVALID_OPERATION, "{e}");
    assert!(e.message.contains("invalid vertex buffer format"), "{e}");
    assert!(e.to_string().contains("RTC_ERROR_INVALID_OPERATION"), "{e}");
    // The error does not stick: the builder still works and the failed mesh is not there
    // (it took no geometry id).
    assert_eq!(b.attach_triangles(&v, &[[0, 1, 2]]), Ok(0));
    let scene = b.commit().expect("commit after a failed attach");
    assert_eq!(scene.triangle_count(), 1);
    assert_eq!(scene.geometry_count(), 1);
    let h = scene
        .intersect1(&Ray::new(Vec3::new(0.25, 0.25, -1.0), Vec3::Z))
        .unwrap();
    assert_eq!((h.geom_id, h.prim_id), (0, 0));
}

#[test]
fn out_of_range_index_is_our_error() {
    let (mut b, v) = triangle_builder();
    let e = b
        .attach_triangles(&v, &[[0, 1, 2], [0, 2, 3]])
        .expect_err("index 3 with 3 vertices");
    eprintln!("{e}");
    assert_eq!(e.code, RTC_ERROR_INVALID_ARGUMENT);
    assert!(
        e.message.contains("triangle 1") && e.message.contains("out of range"),
        "{e}"
    );
    let e = b
        .attach_triangles(&v, &[[0, 1, u32::MAX]])
        .expect_err("u32::MAX");
    assert_eq!(e.code, RTC_ERROR_INVALID_ARGUMENT);
    // Nothing was attached.
    assert_eq!(b.attach_triangles(&v, &[[0, 1, 2]]), Ok(0));
    assert_eq!(b.commit().unwrap().triangle_count(), 1);
}

#[test]
fn invalid_device_config_is_an_error() {
    // Embree 3.13 ignores unknown keys ("bogus=1") and unknown ISA names ("isa=foo"), but a
    // value of the wrong type makes the config parser throw, `rtcNewDevice` returns null and
    // the thread's error code is RTC_ERROR_UNKNOWN (Embree 3 keeps no message for it).
    for config in ["threads=abc", "threads=", "isa=123", "frequency_level="] {
        match Device::with_config(config) {
            Ok(_) => panic!("Embree accepted {config:?}"),
            Err(e) => {
                eprintln!("{config:?}: {e}");
                assert_eq!(e.code, RTC_ERROR_UNKNOWN, "{config:?}: {e}");
                assert!(e.message.contains(config), "{e}");
            }
        }
    }
    let e = Device::with_config("threads=1\0").err().expect("NUL byte");
    assert_eq!(e.code, RTC_ERROR_INVALID_ARGUMENT);
    // A failed device leaves nothing behind: good configurations still work.
    for config in ["threads=1", "threads=1,isa=sse2", ""] {
        let d = Device::with_config(config).unwrap_or_else(|e| panic!("{config:?}: {e}"));
        let mut b = d.scene_builder().unwrap();
        b.attach_triangles(
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[[0, 1, 2]],
        )
        .unwrap();
        let s = b.commit().unwrap();
        assert!(s.occluded1(&Ray::new(Vec3::new(0.25, 0.25, -1.0), Vec3::Z)));
    }
}
