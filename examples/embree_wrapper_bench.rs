//! The overhead of the safe layer (`stokes::accel`) over Embree's C API: the same sphere and
//! the same camera rays as `benches/embree_baseline/baseline.c`, traced through
//! `Scene::intersect1` and `Scene::intersect4` (2×2 quads, coherent) on one thread.
//!
//! ```text
//! cargo run --release --example embree_wrapper_bench [stacks slices size runs passes]
//! ```
//!
//! Geometry: a UV sphere, centre (0,0,0), radius 1, `stacks` latitude bands × `slices`
//! longitude segments, `2·slices·(stacks−1)` triangles (default 160 × 318 = 101,124).
//! Camera: pinhole at (0,0,−3) looking at the origin, 40° vertical field of view,
//! `size`² pixels (default 1024), one ray per pixel centre, generated before timing.
//! Each run traces the image `passes` times (default 3); single and packet runs alternate;
//! the median of `runs` (default 5) is printed.

use glam::{DVec3, Vec3};
use std::hint::black_box;
use std::time::Instant;
use stokes::accel::{set_flush_denormals, Coherence, Device, Ray, RayHit4, Scene};

/// The same vertex and triangle order, and f64 maths, as `baseline.c` (not
/// `scene::shapes::uv_sphere`), so that the C and Rust drivers trace identical triangles.
fn uv_sphere(stacks: u32, slices: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut v = vec![[0.0, 1.0, 0.0]];
    for i in 1..stacks {
        let theta = std::f64::consts::PI * i as f64 / stacks as f64;
        for j in 0..slices {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / slices as f64;
            let p = DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            v.push(p.as_vec3().to_array());
        }
    }
    v.push([0.0, -1.0, 0.0]);
    let south = v.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + (i - 1) * slices + j % slices;
    let mut t = Vec::with_capacity(2 * (slices * (stacks - 1)) as usize);
    for j in 0..slices {
        t.push([0, ring(1, j + 1), ring(1, j)]);
        t.push([south, ring(stacks - 1, j), ring(stacks - 1, j + 1)]);
    }
    for i in 1..stacks - 1 {
        for j in 0..slices {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j),
                ring(i + 1, j + 1),
            );
            t.push([a, b, d]);
            t.push([a, d, c]);
        }
    }
    (v, t)
}

/// Row-major camera rays, computed with the same f32 operations as `baseline.c`.
fn camera_rays(w: u32, h: u32) -> Vec<Ray> {
    let tan_half = 0.363_970_23_f32; // tan(20°)
    let aspect = w as f32 / h as f32;
    let mut rays = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h {
        for x in 0..w {
            let sx = (2.0 * (x as f32 + 0.5) / w as f32 - 1.0) * tan_half * aspect;
            let sy = (1.0 - 2.0 * (y as f32 + 0.5) / h as f32) * tan_half;
            let sz = 1.0f32;
            let inv = 1.0 / (sx * sx + sy * sy + sz * sz).sqrt();
            rays.push(Ray::new(
                Vec3::new(0.0, 0.0, -3.0),
                Vec3::new(sx * inv, sy * inv, sz * inv),
            ));
        }
    }
    rays
}

fn single_pass(scene: &Scene, rays: &[Ray]) -> u64 {
    rays.iter()
        .map(|r| scene.intersect1(black_box(r)).is_some() as u64)
        .sum()
}

fn packet_pass(scene: &Scene, rays: &[Ray], w: u32, h: u32) -> u64 {
    let mut hits = 0;
    let mut p = RayHit4::new();
    for y in (0..h).step_by(2) {
        for x in (0..w).step_by(2) {
            let mut active = [false; 4];
            for (k, a) in active.iter_mut().enumerate() {
                let (px, py) = (x + (k as u32 & 1), y + (k as u32 >> 1));
                *a = px < w && py < h;
                p.set_ray(k, &rays[(py.min(h - 1) * w + px.min(w - 1)) as usize]);
            }
            scene.intersect4(&mut p, active, Coherence::Coherent);
            for (k, &a) in active.iter().enumerate() {
                hits += (a && p.hit(k).is_some()) as u64;
            }
        }
    }
    hits
}

fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[xs.len() / 2]
}

fn main() -> Result<(), String> {
    let args: Vec<u32> = std::env::args()
        .skip(1)
        .map(|a| {
            a.parse()
                .map_err(|_| format!("expected a number, found {a:?}"))
        })
        .collect::<Result<_, _>>()?;
    let arg = |i: usize, default: u32| args.get(i).copied().unwrap_or(default);
    let (stacks, slices, size, runs, passes) =
        (arg(0, 160), arg(1, 318), arg(2, 1024), arg(3, 5), arg(4, 3));
    if stacks < 2 || slices < 3 || size < 1 || runs < 1 || passes < 1 {
        return Err("usage: embree_wrapper_bench [stacks>=2 slices>=3 size runs passes]".into());
    }
    set_flush_denormals();

    let device = Device::new().map_err(|e| e.to_string())?;
    let mut builder = device.scene_builder().map_err(|e| e.to_string())?;
    let (v, t) = uv_sphere(stacks, slices);
    builder
        .attach_triangles(&v, &t)
        .map_err(|e| e.to_string())?;
    let scene = builder.commit().map_err(|e| e.to_string())?;
    let (w, h) = (size, size);
    let rays = camera_rays(w, h);
    let n = rays.len() as f64;

    let (mut hs, mut hp) = (single_pass(&scene, &rays), packet_pass(&scene, &rays, w, h)); // warm-up
    let (mut rs, mut rp) = (vec![], vec![]);
    for _ in 0..runs {
        let t0 = Instant::now();
        for _ in 0..passes {
            hs = single_pass(&scene, &rays);
        }
        let t1 = Instant::now();
        for _ in 0..passes {
            hp = packet_pass(&scene, &rays, w, h);
        }
        let t2 = Instant::now();
        rs.push(n * passes as f64 / (t1 - t0).as_secs_f64() / 1e6);
        rp.push(n * passes as f64 / (t2 - t1).as_secs_f64() / 1e6);
    }
    let (s, p) = (median(rs), median(rp));
    println!(
        "stokes::accel: UV sphere {stacks} x {slices} = {} triangles, {w}x{h} camera rays, 1 thread, median of {runs} runs x {passes} passes",
        scene.triangle_count()
    );
    println!("hits: single {hs}, packet {hp} (of {} rays)", rays.len());
    println!("intersect1              {s:8.2} Mrays/s");
    println!("intersect4 coherent     {p:8.2} Mrays/s  ({:.2}x)", p / s);
    Ok(())
}
