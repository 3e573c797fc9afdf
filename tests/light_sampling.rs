//! Light sampling (`stokes::light`): which emitter and triangle [`Lights::sample`] picks,
//! where on the triangle, the area density [`Lights::pdf_area`] that the MIS weights use,
//! and the directions [`Lights::sample_towards`] produces from a shading point, all on one
//! set of emitters of different power, size, spectrum and sidedness.
//!
//! Every chi-square test uses a fixed seed; a test function's checks share a false-alarm
//! rate of 1e-4 (Bonferroni). Each has a must-fail control: the same samples against an
//! expected distribution that is wrong by a factor 1.1 in one region (then renormalised)
//! must be rejected at p < 1e-6.

mod common;
use common::stats::{chi_square, perturbed, ChiSquare, Rng};
use glam::{DVec2, DVec3, Vec3};
use stokes::light::{Emitter, Lights};
use stokes::spectrum::{Spectrum, Tabulated, LAMBDA_MAX, LAMBDA_MIN};

/// False-alarm rate of each test function (split over its chi-square checks).
const FALSE_ALARM: f64 = 1e-4;
/// What a must-fail control must reach.
const CONTROL_P: f64 = 1e-6;
/// The factor by which a control's expected distribution is wrong in one region.
const WRONG_BY: f64 = 1.1;

// ---------------------------------------------------------------------------------------
// The emitters under test.

/// One emissive shape as the test knows it, independently of `Lights`.
struct Shape {
    geom: u32,
    positions: Vec<[f32; 3]>,
    indices: Vec<[u32; 3]>,
    radiance: Spectrum,
    scale: f32,
    two_sided: bool,
    /// Mean radiance over [LAMBDA_MIN, LAMBDA_MAX] (× scale), worked out by hand.
    mean_radiance: f64,
}

/// One emissive triangle as the test knows it.
struct Tri {
    geom: u32,
    prim: u32,
    shape: usize,
    v: [DVec3; 3],
    /// Unit front normal (right-handed winding).
    n: DVec3,
    area: f64,
}

/// A unit quad (ceiling, one-sided, facing down), a small bright two-sided triangle, a fan
/// of three unequal triangles with a sloped spectrum, and a large dim wall. Geometry ids
/// have gaps (1, 4 do not emit).
fn shapes() -> Vec<Shape> {
    let ramp = Tabulated::new(vec![LAMBDA_MIN, LAMBDA_MAX], vec![0.5, 1.5]).unwrap();
    let fan_rim = [-80.0f32, -50.0, 40.0, 160.0].map(|deg| {
        let a = deg.to_radians();
        [-0.8, 0.35 * a.cos(), 0.4 + 0.35 * a.sin()]
    });
    vec![
        Shape {
            geom: 0,
            positions: vec![
                [-0.5, -0.5, 1.0],
                [-0.5, 0.5, 1.0],
                [0.5, 0.5, 1.0],
                [0.5, -0.5, 1.0],
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            radiance: Spectrum::Constant(1.0),
            scale: 4.0,
            two_sided: false,
            mean_radiance: 4.0,
        },
        Shape {
            geom: 2,
            positions: vec![[0.8, -0.2, 0.3], [0.8, 0.1, 0.3], [0.8, -0.2, 0.6]],
            indices: vec![[0, 1, 2]],
            radiance: Spectrum::Constant(2.0),
            scale: 10.0,
            two_sided: true,
            mean_radiance: 20.0,
        },
        Shape {
            geom: 3,
            positions: vec![
                [-0.8, 0.0, 0.4],
                fan_rim[0],
                fan_rim[1],
                fan_rim[2],
                fan_rim[3],
            ],
            indices: vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]],
            radiance: Spectrum::Tabulated(ramp),
            scale: 1.5,
            two_sided: false,
            // The ramp's mean is 1 (the midpoint rule is exact on a line).
            mean_radiance: 1.5,
        },
        Shape {
            geom: 5,
            positions: vec![
                [-1.0, 1.2, -0.5],
                [1.0, 1.2, -0.5],
                [1.0, 1.2, 1.5],
                [-1.0, 1.2, 1.5],
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            radiance: Spectrum::Constant(0.2),
            scale: 1.0,
            two_sided: false,
            mean_radiance: 0.2,
        },
    ]
}

/// The `Lights` built from `shapes` through the public API, as the scene loader does.
fn build(shapes: &[Shape]) -> Lights {
    let mut lights = Lights::default();
    for s in shapes {
        let emitter = Emitter {
            radiance: s.radiance.clone(),
            scale: s.scale,
            two_sided: s.two_sided,
        };
        lights
            .add(s.geom, emitter, &s.positions, &s.indices)
            .expect("a finite emitter");
    }
    lights.finish();
    lights
}

fn triangles(shapes: &[Shape]) -> Vec<Tri> {
    let mut out = Vec::new();
    for (k, s) in shapes.iter().enumerate() {
        for (prim, t) in s.indices.iter().enumerate() {
            let v = t.map(|i| Vec3::from(s.positions[i as usize]).as_dvec3());
            let c = (v[1] - v[0]).cross(v[2] - v[0]);
            out.push(Tri {
                geom: s.geom,
                prim: prim as u32,
                shape: k,
                v,
                n: c.normalize(),
                area: 0.5 * c.length(),
            });
        }
    }
    out
}

/// Each triangle's selection probability from the emitters' power: area × mean radiance
/// (× scale), normalised.
fn power_pmf(shapes: &[Shape], tris: &[Tri]) -> Vec<f64> {
    let w: Vec<f64> = tris
        .iter()
        .map(|t| t.area * shapes[t.shape].mean_radiance)
        .collect();
    let total: f64 = w.iter().sum();
    w.iter().map(|x| x / total).collect()
}

/// Barycentric (b1, b2) of `p` on `t` (p ≈ v0 + b1 (v1 − v0) + b2 (v2 − v0)).
fn barycentric(t: &Tri, p: DVec3) -> DVec2 {
    let (e1, e2, d) = (t.v[1] - t.v[0], t.v[2] - t.v[0], p - t.v[0]);
    let (a, b, c) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (r1, r2) = (e1.dot(d), e2.dot(d));
    let det = a * c - b * b;
    DVec2::new((c * r1 - b * r2) / det, (a * r2 - b * r1) / det)
}

/// The triangle of shape `shape` that holds `p` (the one it lies least outside of).
fn locate(tris: &[Tri], shape: usize, p: DVec3) -> usize {
    let outside = |i: usize| {
        let b = barycentric(&tris[i], p);
        (-b.x).max(-b.y).max(b.x + b.y - 1.0)
    };
    (0..tris.len())
        .filter(|&i| tris[i].shape == shape)
        .min_by(|&i, &j| outside(i).total_cmp(&outside(j)))
        .unwrap()
}

// ---------------------------------------------------------------------------------------
// Points: selection by power and uniform sampling of each triangle.

/// Sub-triangles per edge: each triangle is cut into SUB² sub-triangles of equal area.
const SUB: usize = 8;
const POINT_SAMPLES: usize = 1_000_000;

/// The sub-triangle cell (0..2·SUB², half of them real) of barycentric `b`.
fn sub_cell(b: DVec2) -> usize {
    let k = SUB as f64;
    let (x, y) = (b.x.clamp(0.0, 1.0) * k, b.y.clamp(0.0, 1.0) * k);
    let (mut i, mut j) = (x.floor() as usize, y.floor() as usize);
    i = i.min(SUB - 1);
    j = j.min(SUB - 1 - i);
    // In the grid square (i, j): the lower triangle, or the upper one (which exists only
    // below the hypotenuse).
    let upper = i + j < SUB - 1 && (x - i as f64) + (y - j as f64) > 1.0;
    (i * SUB + j) * 2 + usize::from(upper)
}

/// Whether sub-cell `c` exists (an upper triangle only exists off the hypotenuse).
fn sub_cell_exists(c: usize) -> bool {
    let (ij, upper) = (c / 2, c % 2 == 1);
    let (i, j) = (ij / SUB, ij % SUB);
    i + j < SUB && (!upper || i + j < SUB - 1)
}

/// Histogram of `Lights::sample` over (triangle, sub-triangle), and per emitter.
struct PointHistogram {
    cells: Vec<u64>,
    per_shape: Vec<u64>,
}

fn point_histogram(seed: u64) -> PointHistogram {
    let shapes = shapes();
    let lights = build(&shapes);
    let tris = triangles(&shapes);
    let mut h = PointHistogram {
        cells: vec![0; tris.len() * 2 * SUB * SUB],
        per_shape: vec![0; shapes.len()],
    };
    let mut rng = Rng::new(seed, 1);
    for _ in 0..POINT_SAMPLES {
        let ls = lights.sample(rng.next_3d()).expect("no light sampled");
        let shape = ls.emitter as usize;
        let p = ls.p.as_dvec3();
        let t = locate(&tris, shape, p);
        h.cells[t * 2 * SUB * SUB + sub_cell(barycentric(&tris[t], p))] += 1;
        h.per_shape[shape] += 1;
    }
    h
}

/// Expected probability of every (triangle, sub-triangle) cell: the power pmf spread
/// uniformly by area.
fn point_cell_probabilities() -> Vec<f64> {
    let shapes = shapes();
    let tris = triangles(&shapes);
    let pmf = power_pmf(&shapes, &tris);
    let mut p = vec![0.0; tris.len() * 2 * SUB * SUB];
    for (t, &pt) in pmf.iter().enumerate() {
        for c in 0..2 * SUB * SUB {
            if sub_cell_exists(c) {
                p[t * 2 * SUB * SUB + c] = pt / (SUB * SUB) as f64;
            }
        }
    }
    p
}

fn shape_probabilities() -> Vec<f64> {
    let shapes = shapes();
    let tris = triangles(&shapes);
    let pmf = power_pmf(&shapes, &tris);
    let mut p = vec![0.0; shapes.len()];
    for (t, tri) in tris.iter().enumerate() {
        p[tri.shape] += pmf[t];
    }
    p
}

fn counts(probabilities: &[f64], n: usize) -> Vec<f64> {
    probabilities.iter().map(|p| p * n as f64).collect()
}

#[test]
fn sub_cells_tile_the_triangle() {
    let real = (0..2 * SUB * SUB).filter(|&c| sub_cell_exists(c)).count();
    assert_eq!(real, SUB * SUB);
    let mut rng = Rng::new(1, 1);
    for _ in 0..10_000 {
        let [u, v] = rng.next_2d().map(f64::from);
        let b = if u + v > 1.0 {
            DVec2::new(1.0 - u, 1.0 - v)
        } else {
            DVec2::new(u, v)
        };
        assert!(sub_cell_exists(sub_cell(b)), "{b}");
    }
}

#[test]
fn lights_are_chosen_by_power() {
    let h = point_histogram(11);
    let r = chi_square(&h.per_shape, &counts(&shape_probabilities(), POINT_SAMPLES));
    println!("selection by power: {r}");
    r.assert_accepts(FALSE_ALARM, "emitter selection against power");
}

#[test]
fn points_are_uniform_on_each_triangle_chosen_by_power() {
    let h = point_histogram(11);
    let r = chi_square(
        &h.cells,
        &counts(&point_cell_probabilities(), POINT_SAMPLES),
    );
    println!("points on triangles: {r}");
    r.assert_accepts(FALSE_ALARM, "(triangle, sub-triangle) cells");
}

#[test]
fn point_chi_squares_reject_a_pdf_off_by_ten_percent() {
    let h = point_histogram(11);
    // The small bright triangle chosen 1.1 × as often.
    let wrong = perturbed(&shape_probabilities(), |s| s == 1, WRONG_BY);
    let r = chi_square(&h.per_shape, &counts(&wrong, POINT_SAMPLES));
    println!("control, selection: {r}");
    r.assert_rejects(CONTROL_P, "selection with one emitter × 1.1");
    // On every triangle, the part with b1 < 1/2 (grid rows i < SUB/2, three quarters of
    // the area) 1.1 × as dense.
    let wrong = perturbed(
        &point_cell_probabilities(),
        |c| (c % (2 * SUB * SUB)) / 2 / SUB < SUB / 2,
        WRONG_BY,
    );
    let r = chi_square(&h.cells, &counts(&wrong, POINT_SAMPLES));
    println!("control, points: {r}");
    r.assert_rejects(CONTROL_P, "points with half of each triangle × 1.1");
}

#[test]
fn pdf_area_is_the_power_pmf_over_the_area() {
    let shapes = shapes();
    let lights = build(&shapes);
    let tris = triangles(&shapes);
    let pmf = power_pmf(&shapes, &tris);
    for (t, tri) in tris.iter().enumerate() {
        let expect = pmf[t] / tri.area;
        let got = f64::from(lights.pdf_area(tri.geom, tri.prim));
        assert!(
            (got / expect - 1.0).abs() < 1e-5,
            "geometry {} triangle {}: pdf_area {got}, expected {expect}",
            tri.geom,
            tri.prim
        );
        assert_eq!(lights.emitter_index_of(tri.geom), Some(tri.shape as u32));
    }
    for geom in [1, 4, 6, 1000] {
        assert_eq!(
            lights.pdf_area(geom, 0),
            0.0,
            "geometry {geom} does not emit"
        );
        assert_eq!(lights.emitter_index_of(geom), None);
    }
    // Every sample reports the density of the triangle it lies on.
    let mut rng = Rng::new(12, 1);
    for _ in 0..100_000 {
        let ls = lights.sample(rng.next_3d()).unwrap();
        let t = &tris[locate(&tris, ls.emitter as usize, ls.p.as_dvec3())];
        let b = barycentric(t, ls.p.as_dvec3());
        assert!(b.x > -1e-5 && b.y > -1e-5 && b.x + b.y < 1.0 + 1e-5, "{b}");
        assert!(((ls.p.as_dvec3() - t.v[0]).dot(t.n)).abs() < 1e-5);
        assert_eq!(ls.pdf_area, lights.pdf_area(t.geom, t.prim));
        assert!((ls.n.as_dvec3() - t.n).length() < 1e-5);
    }
}

// ---------------------------------------------------------------------------------------
// Directions from a shading point.

/// Cells per cube-face edge: directions are binned on the six faces of a cube around the
/// shading point, whose cells' edges and the triangles' edges are all straight lines (a
/// central projection maps lines to lines), so each cell's overlap with a light's image is
/// an exact polygon.
const FACE: usize = 24;
const DIRECTION_CELLS: usize = 6 * FACE * FACE;
const DIRECTION_SAMPLES: usize = 500_000;
/// Shading points: below the ceiling facing every light; above the ceiling (which faces
/// away, so part of the samples fail); beside the small triangle, seeing its front.
const POINTS: [[f64; 3]; 3] = [[0.1, 0.05, 0.4], [0.2, -0.1, 1.4], [1.0, -0.6, 0.2]];

/// Face `f` (0..6): its outward axis and the two axes that span it.
fn face_frame(f: usize) -> (DVec3, DVec3, DVec3) {
    let axis = f / 2;
    let sign = [1.0, -1.0][f % 2];
    let e = |i: usize| DVec3::from_array(std::array::from_fn(|k| f64::from(u8::from(k == i))));
    (e(axis) * sign, e((axis + 1) % 3), e((axis + 2) % 3))
}

/// The cube-map cell of direction `w`.
fn direction_cell(w: DVec3) -> usize {
    let a = w.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let f = 2 * axis + usize::from(w[axis] < 0.0);
    let (m, s, t) = face_frame(f);
    let (u, v) = (w.dot(s) / w.dot(m), w.dot(t) / w.dot(m));
    let idx = |x: f64| (((x + 1.0) * 0.5 * FACE as f64) as usize).min(FACE - 1);
    f * FACE * FACE + idx(u) * FACE + idx(v)
}

/// Clips a convex polygon to the half-space `dist(x) ≥ 0` (Sutherland–Hodgman).
fn clip<
    T: Copy + std::ops::Sub<Output = T> + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
>(
    poly: &[T],
    dist: impl Fn(T) -> f64,
) -> Vec<T> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (da, db) = (dist(a), dist(b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

/// ∫ g over a convex polygon: a fan of triangles, each split four ways `SPLITS` times
/// and integrated with the degree-5 seven-point rule.
fn integrate_polygon(poly: &[DVec2], g: &impl Fn(DVec2) -> f64) -> f64 {
    const SPLITS: u32 = 2;
    (1..poly.len().saturating_sub(1))
        .map(|i| integrate_triangle([poly[0], poly[i], poly[i + 1]], g, SPLITS))
        .sum()
}

fn integrate_triangle(t: [DVec2; 3], g: &impl Fn(DVec2) -> f64, splits: u32) -> f64 {
    if splits > 0 {
        let [a, b, c] = t;
        let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
        return [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            .into_iter()
            .map(|s| integrate_triangle(s, g, splits - 1))
            .sum();
    }
    const W: [f64; 3] = [0.225, 0.132_394_152_788_506, 0.125_939_180_544_827];
    const A: [f64; 2] = [0.059_715_871_789_770, 0.797_426_985_353_087];
    const B: [f64; 2] = [0.470_142_064_105_115, 0.101_286_507_323_456];
    let [p0, p1, p2] = t;
    let area = 0.5 * ((p1 - p0).perp_dot(p2 - p0)).abs();
    let at = |l0: f64, l1: f64, l2: f64| g(p0 * l0 + p1 * l1 + p2 * l2);
    let mut s = W[0] * at(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0);
    for k in 0..2 {
        let (a, b) = (A[k], B[k]);
        s += W[k + 1] * (at(a, b, b) + at(b, a, b) + at(b, b, a));
    }
    area * s
}

/// The solid-angle density of sampling direction `w` (unit) towards triangle `t` from `p`,
/// as the MIS weights compute it: pdf_area · d² / |cos θ_light| at the point hit.
fn pdf_solid_angle(pdf_area: f64, t: &Tri, p: DVec3, w: DVec3) -> f64 {
    let d = (t.v[0] - p).dot(t.n) / w.dot(t.n);
    let cos_l = w.dot(t.n).abs();
    pdf_area * d * d / cos_l
}

/// The probability of each direction cell (and, last, of no sample) under the density
/// the MIS weights use, from every light facing `p`; checks that the quadrature recovers
/// each triangle's whole probability.
fn direction_cell_probabilities(
    lights: &Lights,
    tris: &[Tri],
    shapes: &[Shape],
    p: DVec3,
) -> Vec<f64> {
    let mut prob = vec![0.0; DIRECTION_CELLS + 1];
    for t in tris {
        let pdf_area = f64::from(lights.pdf_area(t.geom, t.prim));
        let side = (p - t.v[0]).dot(t.n);
        if !(side > 0.0 || shapes[t.shape].two_sided) {
            prob[DIRECTION_CELLS] += pdf_area * t.area;
            continue;
        }
        let mut total = 0.0;
        for f in 0..6 {
            let (m, s, q) = face_frame(f);
            // The part in front of the face's plane, projected onto the face.
            let front = clip(&t.v.map(|v| v - p), |x| x.dot(m) - 1e-6);
            if front.len() < 3 {
                continue;
            }
            let image: Vec<DVec2> = front
                .iter()
                .map(|x| DVec2::new(x.dot(s), x.dot(q)) / x.dot(m))
                .collect();
            // Density per (u, v): solid-angle pdf × dω/(du dv) = 1/|w|³.
            let g = |uv: DVec2| {
                let w = m + s * uv.x + q * uv.y;
                let len = w.length();
                pdf_solid_angle(pdf_area, t, p, w / len) / (len * len * len)
            };
            let h = 2.0 / FACE as f64;
            for i in 0..FACE {
                for j in 0..FACE {
                    let (u0, v0) = (-1.0 + i as f64 * h, -1.0 + j as f64 * h);
                    let mut cell = clip(&image, |x| x.x - u0);
                    cell = clip(&cell, |x| u0 + h - x.x);
                    cell = clip(&cell, |x| x.y - v0);
                    cell = clip(&cell, |x| v0 + h - x.y);
                    if cell.len() >= 3 {
                        let mass = integrate_polygon(&cell, &g);
                        prob[f * FACE * FACE + i * FACE + j] += mass;
                        total += mass;
                    }
                }
            }
        }
        let whole = pdf_area * t.area;
        assert!(
            (total / whole - 1.0).abs() < 1e-6,
            "quadrature: geometry {} triangle {} from {p}: {total} of {whole}",
            t.geom,
            t.prim
        );
    }
    prob
}

/// Histogram of `Lights::sample_towards(p)` over the direction cells (last: no sample),
/// checking each sample's reported pdf against pdf_area · d² / |cos| of its triangle.
fn direction_histogram(lights: &Lights, tris: &[Tri], p: DVec3, seed: u64) -> Vec<u64> {
    let mut h = vec![0u64; DIRECTION_CELLS + 1];
    let mut rng = Rng::new(seed, 2);
    for _ in 0..DIRECTION_SAMPLES {
        let Some((ls, wi, pdf)) = lights.sample_towards(p.as_vec3(), rng.next_3d()) else {
            h[DIRECTION_CELLS] += 1;
            continue;
        };
        let t = &tris[locate(tris, ls.emitter as usize, ls.p.as_dvec3())];
        let to = ls.p.as_dvec3() - p;
        assert!(
            (wi.as_dvec3() - to.normalize()).length() < 1e-5,
            "{wi} towards {to}"
        );
        let expect = pdf_solid_angle(
            f64::from(lights.pdf_area(t.geom, t.prim)),
            t,
            p,
            to.normalize(),
        );
        assert!(
            (f64::from(pdf) / expect - 1.0).abs() < 1e-4,
            "from {p} to {}: pdf {pdf}, pdf_area · d²/|cos| = {expect}",
            ls.p
        );
        h[direction_cell(wi.as_dvec3())] += 1;
    }
    h
}

/// The direction chi-square at each shading point; `wrong_by` scales the expected density
/// in the half of every cube face with u > 0 (1 for the real test).
fn direction_chi_squares(wrong_by: f64) -> Vec<ChiSquare> {
    let shapes = shapes();
    let lights = build(&shapes);
    let tris = triangles(&shapes);
    POINTS
        .iter()
        .enumerate()
        .map(|(k, &p)| {
            let p = DVec3::from_array(p);
            let h = direction_histogram(&lights, &tris, p, 20 + k as u64);
            let mut prob = direction_cell_probabilities(&lights, &tris, &shapes, p);
            if wrong_by != 1.0 {
                prob = perturbed(
                    &prob,
                    |c| c < DIRECTION_CELLS && (c % (FACE * FACE)) / FACE >= FACE / 2,
                    wrong_by,
                );
            }
            chi_square(&h, &counts(&prob, DIRECTION_SAMPLES))
        })
        .collect()
}

#[test]
fn sample_towards_directions_follow_the_mis_pdf() {
    let results = direction_chi_squares(1.0);
    for (p, r) in POINTS.iter().zip(&results) {
        println!("directions from {p:?}: {r}");
    }
    for (p, r) in POINTS.iter().zip(&results) {
        r.assert_accepts(
            FALSE_ALARM / POINTS.len() as f64,
            &format!("directions from {p:?}"),
        );
    }
}

#[test]
fn direction_chi_square_rejects_a_pdf_off_by_ten_percent() {
    for (p, r) in POINTS.iter().zip(direction_chi_squares(WRONG_BY)) {
        println!("control, directions from {p:?}: {r}");
        r.assert_rejects(
            CONTROL_P,
            &format!("directions from {p:?}, half of each face × 1.1"),
        );
    }
}

// ---------------------------------------------------------------------------------------
// What an emitter emits (the integrator's emission and next-event terms use these).

fn emitter(radiance: Spectrum, scale: f32, two_sided: bool) -> Emitter {
    Emitter {
        radiance,
        scale,
        two_sided,
    }
}

#[test]
fn an_emitter_emits_from_its_front_only_unless_two_sided() {
    let one = emitter(Spectrum::Constant(1.0), 1.0, false);
    let two = emitter(Spectrum::Constant(1.0), 1.0, true);
    // cos is the cosine between the front normal and the direction of emission.
    assert!(one.emits_towards(0.5) && one.emits_towards(1e-30));
    assert!(!one.emits_towards(-0.5) && !one.emits_towards(-1e-30));
    assert!(two.emits_towards(0.5) && two.emits_towards(-0.5) && two.emits_towards(-1e-30));
    // Exactly grazing: no emission from either side.
    assert!(!one.emits_towards(0.0) && !two.emits_towards(0.0));
    assert!(!one.emits_towards(f32::NAN) && !two.emits_towards(f32::NAN));
}

#[test]
fn spectral_radiance_and_its_mean_carry_the_scale() {
    // A ramp from 0 at 360 nm to 470 at 830 nm: mean 235 over the range.
    let ramp = Tabulated::new(vec![LAMBDA_MIN, LAMBDA_MAX], vec![0.0, 470.0]).unwrap();
    let e = emitter(Spectrum::Tabulated(ramp.clone()), 3.0, false);
    let lambda = glam::Vec4::new(400.0, 500.0, 600.0, 700.0);
    let want = lambda.to_array().map(|l| 3.0 * ramp.eval(l));
    let got = e.spectral_radiance(lambda).to_array();
    for k in 0..4 {
        assert!(
            (got[k] - want[k]).abs() <= 1e-5 * want[k],
            "{got:?} vs {want:?}"
        );
    }
    let mean = e.mean_radiance();
    assert!((mean - 3.0 * 235.0).abs() < 1e-3 * 705.0, "mean {mean}");
    let flat = emitter(Spectrum::Constant(2.0), 0.5, true);
    assert!(
        (flat.mean_radiance() - 1.0).abs() < 1e-5,
        "{}",
        flat.mean_radiance()
    );
}

#[test]
fn black_lights_are_chosen_uniformly_and_keep_a_finite_density() {
    let mut lights = Lights::default();
    let quad = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    for g in 0..2 {
        let black = emitter(Spectrum::Constant(0.0), 1.0, false);
        lights.add(g, black, &quad, &[[0, 1, 2]]).unwrap();
    }
    lights.finish();
    for g in 0..2 {
        // Each triangle: probability 1/2 over area 1.
        assert_eq!(lights.pdf_area(g, 0), 0.5, "geometry {g}");
    }
    let s = lights
        .sample([0.75, 0.3, 0.6])
        .expect("a black light is still sampled");
    assert!(s.p.is_finite() && s.pdf_area == 0.5, "{s:?}");
}

/// Scene warnings for a floor under a quad light of the given emission (no light at all
/// for `None`).
fn light_warnings_of(emission: Option<&str>) -> Vec<String> {
    let mut text = r#"
[camera]
position = [0, 1, -3]
look_at = [0, 1, 0]
fov = 40
resolution = [8, 8]

[materials.white]
type = "diffuse"
reflectance = 0.5

[[shapes]]
type = "quad"
origin = [-1, 0, -1]
edge_u = [2, 0, 0]
edge_v = [0, 0, 2]
material = "white"
"#
    .to_string();
    if let Some(e) = emission {
        text += &format!(
            r#"
[[shapes]]
type = "quad"
origin = [-0.5, 2, -0.5]
edge_u = [1, 0, 0]
edge_v = [0, 0, 1]
emission = {e}
"#
        );
    }
    common::scene_from(&text).warnings
}

/// Scene warnings for a quad light of the given emission.
fn light_warnings(emission: &str) -> Vec<String> {
    light_warnings_of(Some(emission))
}

#[test]
fn bands_narrower_than_a_nanometre_are_warned_of() {
    let narrow = |e: &str| light_warnings(e).iter().any(|w| w.contains("fwhm"));
    assert!(narrow("{ radiance = { narrow_band = 500, fwhm = 0.5 } }"));
    assert!(narrow(
        "{ radiance = { narrow_band = 500, fwhm = 0.5, scale = 2 } }"
    ));
    assert!(!narrow("{ radiance = { narrow_band = 500, fwhm = 10 } }"));
    assert!(!narrow(
        "{ radiance = { narrow_band = 500, fwhm = 1.5, scale = 2 } }"
    ));
    assert!(!narrow("{ radiance = 1.0 }"));
    assert!(!narrow("{ radiance = \"D65\", scale = 0.01 }"));
}

#[test]
fn a_scene_without_lights_is_warned_of() {
    let dark = |w: &[String]| w.iter().any(|w| w.contains("has no light"));
    assert!(!dark(&light_warnings("{ radiance = 1.0 }")));
    assert!(dark(&light_warnings_of(None)));
}

#[test]
fn a_selection_sample_at_the_top_of_the_range_picks_the_last_triangle() {
    let mut lights = Lights::default();
    let tri = |x: f32| [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 0.0, 1.0]];
    for g in 0..3 {
        let e = emitter(Spectrum::Constant(1.0 + g as f32), 1.0, false);
        lights
            .add(g, e, &tri(3.0 * g as f32), &[[0, 1, 2]])
            .unwrap();
    }
    lights.finish();
    // Uniforms lie in [0, 1); a selection sample of exactly 1 (rounding) must still land
    // on a triangle, the last one.
    let s = lights.sample([1.0, 0.5, 0.5]).expect("a light");
    assert!(s.p.x >= 6.0 && s.emitter == 2, "{s:?}");
    let s = lights.sample([0.0, 0.5, 0.5]).expect("a light");
    assert!(s.p.x < 1.0 && s.emitter == 0, "{s:?}");
}
