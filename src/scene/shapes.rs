//! Shapes (`[[shapes]]`): OBJ meshes and inline quads, boxes and UV spheres, turned into
//! triangle meshes, and their parser.
//!
//! ```toml
//! [[shapes]]
//! type = "obj"                  # file (relative to the scene file), object optional
//! file = "meshes/bunny.obj"
//! object = "bunny"
//! material = "white"
//! scale = 2.0                   # any shape: p ↦ p·scale + translate
//! translate = [0, -0.5, 0]
//!
//! [[shapes]]
//! type = "quad"                 # faces edge_u × edge_v
//! origin = [-1, 2, -1]
//! edge_u = [2, 0, 0]
//! edge_v = [0, 0, 2]
//! emission = { radiance = "D65", scale = 4, two_sided = false }   # an area light
//!
//! [[shapes]]
//! type = "box"                  # faces outwards; flip = true turns it inside out
//! min = [-1, 0, -1]
//! max = [1, 2, 1]
//! interior = "fog"              # the medium inside (a closed mesh facing outwards)
//!
//! [[shapes]]
//! type = "sphere"               # stacks default 64, slices 2·stacks
//! center = [0, 1, 0]
//! radius = 0.5
//! material = "glass"
//! ```
//!
//! Windings are chosen so that Embree's geometric normal `(v1−v0)×(v2−v0)` points to the
//! front: along `edge_u × edge_v` for a quad, outwards for boxes and spheres. One-sided
//! emitters emit on that side. What a shape is made of (`material`, `emission`,
//! `interior`, `exterior`) is resolved by the scene loader.

use super::context::{list, reject_keys, Context};
use super::obj;
use crate::error::{Detail, Key, KeyError};
use crate::light::EmissionDesc;
use glam::Vec3;
use serde::Deserialize;

/// A shape; `type` selects which keys apply.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShapeDesc {
    /// `obj`, `quad`, `box` or `sphere`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Name of a material from `[materials]`.
    pub material: Option<String>,
    /// Makes the shape an area light.
    pub emission: Option<EmissionDesc>,
    /// `obj`: the file (relative to the scene file).
    pub file: Option<String>,
    /// `obj`: only the object (`o`/`g`) of this name.
    pub object: Option<String>,
    /// `quad`: a corner.
    pub origin: Option<[f32; 3]>,
    /// `quad`: first edge from `origin`.
    pub edge_u: Option<[f32; 3]>,
    /// `quad`: second edge from `origin`; the quad faces `edge_u × edge_v`.
    pub edge_v: Option<[f32; 3]>,
    /// `box`: minimum corner.
    pub min: Option<[f32; 3]>,
    /// `box`: maximum corner.
    pub max: Option<[f32; 3]>,
    /// `sphere`: centre.
    pub center: Option<[f32; 3]>,
    /// `sphere`: radius.
    pub radius: Option<f32>,
    /// `sphere`: rings of latitude (default 64).
    pub stacks: Option<u32>,
    /// `sphere`: segments of longitude (default 2·stacks).
    pub slices: Option<u32>,
    /// Any shape: uniform scale applied before `translate` (default 1).
    pub scale: Option<f32>,
    /// Any shape: translation.
    pub translate: Option<[f32; 3]>,
    /// Any shape: turn the front side around (for example a box seen from inside).
    #[serde(default)]
    pub flip: bool,
    /// Any closed shape facing outwards: the medium inside it. Without a `material` the
    /// boundary is index-matched (rays cross it unchanged).
    pub interior: Option<String>,
    /// The medium outside the shape (default: none).
    pub exterior: Option<String>,
}

/// A point or vector given at `key`, which must be finite.
pub fn finite_vec(key: &Key, v: [f32; 3]) -> Result<Vec3, KeyError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(Vec3::from(v))
    } else {
        Err(key.expected("finite numbers", format!("{v:?}")))
    }
}

/// The meshes of shape `s` at `key`, named (an OBJ's object names; empty for inline
/// shapes), with `scale`, `translate` and `flip` applied.
pub fn meshes(s: &ShapeDesc, key: &Key, ctx: &Context) -> Result<Vec<(String, TriMesh)>, KeyError> {
    let mut out = untransformed(s, key, ctx)?;
    for (_, mesh) in &mut out {
        let scale = s.scale.unwrap_or(1.0);
        if !(scale.is_finite() && scale > 0.0) {
            return Err(key.field("scale").expected("a positive number", scale));
        }
        let t = finite_vec(&key.field("translate"), s.translate.unwrap_or([0.0; 3]))?;
        mesh.transform(scale, t);
        if let Some(v) = mesh
            .positions
            .iter()
            .find(|v| !v.iter().all(|x| x.is_finite()))
        {
            return Err(key.expected(
                "a shape whose vertices are finite in 32-bit floats (after any `scale` and `translate`)",
                format!("a vertex at {v:?}"),
            ));
        }
        if s.flip {
            mesh.flip();
        }
    }
    Ok(out)
}

/// [`meshes`] before `scale`, `translate` and `flip`.
fn untransformed(
    s: &ShapeDesc,
    key: &Key,
    ctx: &Context,
) -> Result<Vec<(String, TriMesh)>, KeyError> {
    let kind = s.kind.as_str();
    let need3 = |k: &str, v: Option<[f32; 3]>| -> Result<Vec3, KeyError> {
        let v = v.ok_or_else(|| key.error(format!("missing key `{k}` for a {kind} shape")))?;
        finite_vec(&key.field(k), v)
    };
    let obj_keys = [("file", s.file.is_some()), ("object", s.object.is_some())];
    let quad_keys = [
        ("origin", s.origin.is_some()),
        ("edge_u", s.edge_u.is_some()),
        ("edge_v", s.edge_v.is_some()),
    ];
    let box_keys = [("min", s.min.is_some()), ("max", s.max.is_some())];
    let sphere_keys = [
        ("center", s.center.is_some()),
        ("radius", s.radius.is_some()),
        ("stacks", s.stacks.is_some()),
        ("slices", s.slices.is_some()),
    ];
    // A shape of one kind must have none of the other kinds' keys.
    let kinds: [(&str, &[(&str, bool)]); 4] = [
        ("obj", &obj_keys),
        ("quad", &quad_keys),
        ("box", &box_keys),
        ("sphere", &sphere_keys),
    ];
    if kinds.iter().any(|(k, _)| *k == kind) {
        for (_, keys) in kinds.iter().filter(|(k, _)| *k != kind) {
            reject_keys(key, kind, "shape", keys)?;
        }
    }
    match kind {
        "obj" => {
            let file = s
                .file
                .as_ref()
                .ok_or_else(|| key.error("missing key `file` for an obj shape"))?;
            let objs = obj::load_obj(&ctx.resolve(file)).map_err(|e| key.field("file").error(e))?;
            let names: Vec<String> = objs.iter().map(|o| o.name.clone()).collect();
            let picked: Vec<_> = objs
                .into_iter()
                .filter(|o| s.object.as_ref().is_none_or(|n| &o.name == n))
                .map(|o| {
                    let mesh = TriMesh {
                        positions: o.positions,
                        indices: o.indices,
                    };
                    (o.name, mesh)
                })
                .collect();
            if picked.is_empty() {
                return Err(key.field("object").error(format!(
                    "{file} has no object named {:?} (objects: {})",
                    s.object.as_deref().unwrap_or(""),
                    list(names.iter())
                )));
            }
            Ok(picked)
        }
        "quad" => {
            let (o, u, v) = (
                need3("origin", s.origin)?,
                need3("edge_u", s.edge_u)?,
                need3("edge_v", s.edge_v)?,
            );
            if u.cross(v).length_squared() == 0.0 {
                return Err(key.error("edge_u and edge_v must not be parallel or zero"));
            }
            Ok(vec![(String::new(), quad(o, u, v))])
        }
        "box" => {
            let (a, b) = (need3("min", s.min)?, need3("max", s.max)?);
            if !(a.cmplt(b).all()) {
                return Err(key.expected("min < max on every axis", format!("min {a} max {b}")));
            }
            Ok(vec![(String::new(), cuboid(a, b))])
        }
        "sphere" => {
            let c = need3("center", s.center)?;
            let r = s
                .radius
                .ok_or_else(|| key.error("missing key `radius` for a sphere shape"))?;
            if !(r.is_finite() && r > 0.0) {
                return Err(key.field("radius").expected("a positive number", r));
            }
            let stacks = s.stacks.unwrap_or(64);
            let slices = s.slices.unwrap_or(2 * stacks);
            if !(2..=4096).contains(&stacks) || !(3..=8192).contains(&slices) {
                return Err(key.expected(
                    "stacks in 2..=4096 and slices in 3..=8192",
                    format!("{stacks} and {slices}"),
                ));
            }
            Ok(vec![(String::new(), uv_sphere(c, r, stacks, slices))])
        }
        other => Err(key.field("type").expected(
            "one of \"obj\", \"quad\", \"box\", \"sphere\"",
            format!("{other:?}"),
        )),
    }
}

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
    pub fn check_closed_outward(&self) -> Result<(), Detail> {
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
            return Err(Detail::Text(format!(
                "the mesh is not closed (an edge is shared by {n} triangle(s) instead of 2), so it cannot hold a medium"
            )));
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
            .unwrap_err()
            .to_string();
        assert!(open.contains("not closed"), "{open}");
        let mut inward = cuboid(Vec3::ZERO, Vec3::ONE);
        inward.flip();
        assert!(inward
            .check_closed_outward()
            .unwrap_err()
            .to_string()
            .contains("inwards"));
    }

    #[test]
    fn quad_faces_u_cross_v() {
        let q = quad(Vec3::ZERO, Vec3::X, Vec3::Y);
        let [a, b, c] = q.indices[0].map(|i| Vec3::from(q.positions[i as usize]));
        assert!((b - a).cross(c - a).z > 0.0);
    }
}
