//! Inline shapes turned into triangle meshes: quads, boxes and UV spheres.
//!
//! Windings are chosen so that Embree's geometric normal `(v1−v0)×(v2−v0)` points to the
//! front: along `edge_u × edge_v` for a quad, outwards for boxes and spheres. One-sided
//! emitters emit on that side.

use glam::Vec3;

/// Triangles with positions, ready for Embree.
#[derive(Debug, Clone, Default)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Triangles (indices into `positions`).
    pub indices: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Applies `p ↦ p·scale + translate` to every vertex.
    pub fn transform(&mut self, scale: f32, translate: Vec3) {
        for p in &mut self.positions {
            let v = Vec3::from(*p) * scale + translate;
            *p = v.into();
        }
    }

    /// Reverses every triangle's winding (turns the front side around).
    pub fn flip(&mut self) {
        for t in &mut self.indices {
            t.swap(1, 2);
        }
    }

    /// Checks that the mesh can bound a medium: closed (after welding equal positions,
    /// every edge is shared by exactly two triangles) and facing outwards (positive signed
    /// volume). The error says what is wrong.
    pub fn check_closed_outward(&self) -> Result<(), String> {
        use std::collections::HashMap;
        if self.indices.is_empty() {
            return Err("the mesh is empty".into());
        }
        let mut weld: HashMap<[u32; 3], u32> = HashMap::new();
        let ids: Vec<u32> = self
            .positions
            .iter()
            .map(|p| {
                let key = p.map(f32::to_bits);
                let n = weld.len() as u32;
                *weld.entry(key).or_insert(n)
            })
            .collect();
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &self.indices {
            let v = t.map(|i| ids[i as usize]);
            for (a, b) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        if let Some((_, n)) = edges.iter().find(|(_, &n)| n != 2) {
            return Err(format!(
                "the mesh is not closed (an edge is shared by {n} triangle(s) instead of 2), so it cannot hold a medium"
            ));
        }
        let volume: f64 = self
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| Vec3::from(self.positions[i as usize]).as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        if volume <= 0.0 {
            return Err("the mesh faces inwards (negative volume); a medium boundary must face outwards (toggle `flip`)".into());
        }
        Ok(())
    }

    /// Axis-aligned bounds.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in &self.positions {
            lo = lo.min(Vec3::from(*p));
            hi = hi.max(Vec3::from(*p));
        }
        (lo, hi)
    }
}

/// A parallelogram `origin + s·edge_u + t·edge_v`, s, t ∈ [0, 1], facing `edge_u × edge_v`.
pub fn quad(origin: Vec3, edge_u: Vec3, edge_v: Vec3) -> TriMesh {
    let p = [
        origin,
        origin + edge_u,
        origin + edge_u + edge_v,
        origin + edge_v,
    ];
    TriMesh {
        positions: p.iter().map(|v| (*v).into()).collect(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// An axis-aligned box with outward-facing sides.
pub fn cuboid(min: Vec3, max: Vec3) -> TriMesh {
    let d = max - min;
    let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
    let faces = [
        (min, z, y),     // −x
        (min + x, y, z), // +x
        (min, x, z),     // −y
        (min + y, z, x), // +y
        (min, y, x),     // −z
        (min + z, x, y), // +z
    ];
    let mut m = TriMesh::default();
    for (o, u, v) in faces {
        let q = quad(o, u, v);
        let base = m.positions.len() as u32;
        m.positions.extend(q.positions);
        m.indices
            .extend(q.indices.iter().map(|t| t.map(|i| i + base)));
    }
    m
}

/// A UV sphere with `stacks` rings of latitude and `slices` of longitude:
/// 2·slices·(stacks−1) triangles, facing outwards.
pub fn uv_sphere(centre: Vec3, radius: f32, stacks: u32, slices: u32) -> TriMesh {
    let stacks = stacks.max(2);
    let slices = slices.max(3);
    let mut positions = Vec::with_capacity(((stacks - 1) * slices + 2) as usize);
    positions.push((centre + Vec3::Y * radius).into()); // north pole
    for i in 1..stacks {
        let theta = std::f32::consts::PI * i as f32 / stacks as f32;
        for j in 0..slices {
            let phi = 2.0 * std::f32::consts::PI * j as f32 / slices as f32;
            let d = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            positions.push((centre + d * radius).into());
        }
    }
    positions.push((centre - Vec3::Y * radius).into()); // south pole
    let south = positions.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + (i - 1) * slices + (j % slices);
    let mut indices = Vec::with_capacity((2 * slices * (stacks - 1)) as usize);
    for j in 0..slices {
        indices.push([0, ring(1, j + 1), ring(1, j)]);
    }
    for i in 1..stacks - 1 {
        for j in 0..slices {
            let (a, b) = (ring(i, j), ring(i, j + 1));
            let (c, d) = (ring(i + 1, j), ring(i + 1, j + 1));
            indices.push([a, b, d]);
            indices.push([a, d, c]);
        }
    }
    for j in 0..slices {
        indices.push([south, ring(stacks - 1, j), ring(stacks - 1, j + 1)]);
    }
    TriMesh { positions, indices }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outward(m: &TriMesh, centre: Vec3) -> bool {
        m.indices.iter().all(|t| {
            let [a, b, c] = t.map(|i| Vec3::from(m.positions[i as usize]));
            let n = (b - a).cross(c - a);
            n.dot((a + b + c) / 3.0 - centre) > 0.0
        })
    }

    #[test]
    fn box_and_sphere_face_outwards() {
        let b = cuboid(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(b.indices.len(), 12);
        assert!(outward(&b, Vec3::new(0.5, 1.0, 1.5)));
        let s = uv_sphere(Vec3::new(1.0, 0.0, 0.0), 2.0, 8, 16);
        assert_eq!(s.indices.len(), 2 * 16 * 7);
        assert!(outward(&s, Vec3::new(1.0, 0.0, 0.0)));
    }

    #[test]
    fn closed_outward_check() {
        assert!(cuboid(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0))
            .check_closed_outward()
            .is_ok());
        assert!(uv_sphere(Vec3::ZERO, 1.0, 8, 16)
            .check_closed_outward()
            .is_ok());
        let open = quad(Vec3::ZERO, Vec3::X, Vec3::Y)
            .check_closed_outward()
            .unwrap_err();
        assert!(open.contains("not closed"), "{open}");
        let mut inward = cuboid(Vec3::ZERO, Vec3::ONE);
        inward.flip();
        assert!(inward
            .check_closed_outward()
            .unwrap_err()
            .contains("inwards"));
    }

    #[test]
    fn quad_faces_u_cross_v() {
        let q = quad(Vec3::ZERO, Vec3::X, Vec3::Y);
        let [a, b, c] = q.indices[0].map(|i| Vec3::from(q.positions[i as usize]));
        assert!((b - a).cross(c - a).z > 0.0);
    }
}
