//! Shapes (`[[shapes]]`): OBJ and PLY meshes and inline quads, boxes and UV spheres,
//! turned into triangle meshes, and their parser.
//!
//! ```toml
//! [[shapes]]
//! type = "obj"                  # file (relative to the scene file), object optional
//! file = "meshes/bunny.obj"
//! object = "bunny"
//! material = "white"
//! scale = 2.0                   # any shape: p ↦ p·scale + translate
//! translate = [0, -0.5, 0]
//! smooth = false                # obj, ply: ignore the file's vertex normals
//!
//! [[shapes]]
//! type = "ply"                  # ASCII or binary PLY, relative to the scene file
//! file = "meshes/dragon.ply"
//! material = "white"
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
//! smooth = true                 # radial normals, uv = (φ/2π, θ/π); default false
//! material = "glass"
//! ```
//!
//! `smooth`: meshes carry per-vertex normals for smooth shading where they have them.
//! OBJ and PLY files use theirs unless `smooth = false` (flat shading); `smooth = true`
//! on a file without normals is an error, so is `smooth = true` on a quad or a box
//! (flat by nature). A sphere is flat-faceted unless `smooth = true`, which keeps older
//! scenes' spheres exactly as they were. OBJ and PLY texture coordinates are always
//! read; a smooth sphere has u = φ/2π (longitude, from +x towards +z) and v = θ/π (from
//! the north pole, +y). The normals follow `flip`, `scale` and `translate`: a uniform
//! positive scale leaves them as they are, `flip` negates them with the winding.
//!
//! Windings are chosen so that Embree's geometric normal `(v1−v0)×(v2−v0)` points to the
//! front: along `edge_u × edge_v` for a quad, outwards for boxes and spheres. One-sided
//! emitters emit on that side. What a shape is made of (`material`, `emission`,
//! `interior`, `exterior`) is resolved by the scene loader.

use super::context::{list, reject_keys, Context};
use super::{obj, ply};
use crate::error::{Detail, Key, KeyError};
use crate::light::EmissionDesc;
use glam::Vec3;
use serde::Deserialize;

/// A shape; `type` selects which keys apply.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShapeDesc {
    /// `obj`, `ply`, `quad`, `box` or `sphere`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Name of a material from `[materials]`.
    pub material: Option<String>,
    /// Makes the shape an area light.
    pub emission: Option<EmissionDesc>,
    /// `obj`, `ply`: the file (relative to the scene file).
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
    /// `obj`, `ply`: `false` drops the file's vertex normals (flat shading), `true`
    /// insists on them (an error if the file has none); by default the file's normals
    /// are used where it has them. `sphere`: `true` gives it exact radial normals and
    /// texture coordinates, default `false` (flat facets, the mesh of older versions).
    /// `quad`, `box`: only `false` (they have no normals to interpolate).
    pub smooth: Option<bool>,
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

/// The values of `type`.
const KINDS: [&str; 5] = ["obj", "ply", "quad", "box", "sphere"];

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
    // Each kind's own keys: a shape of one kind must have none of the others'.
    let keys: [(&str, bool, &[&str]); 11] = [
        ("file", s.file.is_some(), &["obj", "ply"]),
        ("object", s.object.is_some(), &["obj"]),
        ("origin", s.origin.is_some(), &["quad"]),
        ("edge_u", s.edge_u.is_some(), &["quad"]),
        ("edge_v", s.edge_v.is_some(), &["quad"]),
        ("min", s.min.is_some(), &["box"]),
        ("max", s.max.is_some(), &["box"]),
        ("center", s.center.is_some(), &["sphere"]),
        ("radius", s.radius.is_some(), &["sphere"]),
        ("stacks", s.stacks.is_some(), &["sphere"]),
        ("slices", s.slices.is_some(), &["sphere"]),
    ];
    if KINDS.contains(&kind) {
        let foreign: Vec<(&str, bool)> = keys
            .iter()
            .filter(|(_, _, of)| !of.contains(&kind))
            .map(|&(k, present, _)| (k, present))
            .collect();
        reject_keys(key, kind, "shape", &foreign)?;
    }
    // `smooth = true` asks for normals the mesh must then have.
    let smooth = key.field("smooth");
    let no_normals = |what: String| {
        smooth.error(format!(
            "{what}, so `smooth = true` cannot apply (remove it or set it to false)"
        ))
    };
    match kind {
        "obj" => {
            let file = s
                .file
                .as_ref()
                .ok_or_else(|| key.error("missing key `file` for an obj shape"))?;
            let objs = obj::load_obj(&ctx.resolve(file), s.smooth != Some(false))
                .map_err(|e| key.field("file").error(e))?;
            let names: Vec<String> = objs.iter().map(|o| o.name.clone()).collect();
            let picked: Vec<_> = objs
                .into_iter()
                .filter(|o| s.object.as_ref().is_none_or(|n| &o.name == n))
                .map(|o| {
                    let mesh = TriMesh {
                        positions: o.positions,
                        indices: o.indices,
                        normals: o.normals,
                        uvs: o.uvs,
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
            if s.smooth == Some(true) && picked.iter().any(|(_, m)| m.normals.is_none()) {
                return Err(no_normals(format!(
                    "{file} has no vertex normals (its faces reference no `vn`)"
                )));
            }
            Ok(picked)
        }
        "ply" => {
            let file = s
                .file
                .as_ref()
                .ok_or_else(|| key.error("missing key `file` for a ply shape"))?;
            let mut mesh =
                ply::load_ply(&ctx.resolve(file)).map_err(|e| key.field("file").error(e))?;
            match s.smooth {
                Some(false) => mesh.normals = None,
                Some(true) if mesh.normals.is_none() => {
                    return Err(no_normals(format!(
                        "{file} has no vertex normals (no nx, ny, nz properties)"
                    )))
                }
                _ => {}
            }
            Ok(vec![(String::new(), mesh)])
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
            if s.smooth == Some(true) {
                return Err(no_normals(
                    "a quad is flat and has no vertex normals".into(),
                ));
            }
            Ok(vec![(String::new(), quad(o, u, v))])
        }
        "box" => {
            let (a, b) = (need3("min", s.min)?, need3("max", s.max)?);
            if !(a.cmplt(b).all()) {
                return Err(key.expected("min < max on every axis", format!("min {a} max {b}")));
            }
            if s.smooth == Some(true) {
                return Err(no_normals(
                    "a box has flat sides and no vertex normals".into(),
                ));
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
            let mesh = match s.smooth {
                Some(true) => smooth_sphere(c, r, stacks, slices),
                _ => uv_sphere(c, r, stacks, slices),
            };
            Ok(vec![(String::new(), mesh)])
        }
        other => Err(key.field("type").expected(
            "one of \"obj\", \"ply\", \"quad\", \"box\", \"sphere\"",
            format!("{other:?}"),
        )),
    }
}

/// Triangles with positions, ready for Embree, and the per-vertex data smooth shading
/// interpolates.
#[derive(Debug, Clone, Default)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Triangles (indices into `positions`).
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex shading normals (indexed like `positions`, not necessarily unit), on
    /// the front side of the triangles around them; `None` for flat shading.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per-vertex texture coordinates (indexed like `positions`).
    pub uvs: Option<Vec<[f32; 2]>>,
}

impl TriMesh {
    /// Applies `p ↦ p·scale + translate` to every vertex. `scale` must be positive (the
    /// shape parser rejects anything else): a uniform positive scale leaves directions,
    /// and so the normals, unchanged.
    pub fn transform(&mut self, scale: f32, translate: Vec3) {
        for p in &mut self.positions {
            let v = Vec3::from(*p) * scale + translate;
            *p = v.into();
        }
    }

    /// Reverses every triangle's winding (turns the front side around) and the normals
    /// with it, so that they stay on the front side.
    pub fn flip(&mut self) {
        for t in &mut self.indices {
            t.swap(1, 2);
        }
        for n in self.normals.iter_mut().flatten() {
            *n = n.map(|x| -x);
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
        ..TriMesh::default()
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
    let indices = sphere_triangles(stacks, slices, |_| 0, ring, |_| south);
    TriMesh {
        positions,
        indices,
        ..TriMesh::default()
    }
}

/// The triangles of a UV sphere, facing outwards: a fan at each pole and two triangles
/// per cell between rings. `north(j)`/`south(j)` are the pole vertex of slice j, `ring(i,
/// j)` the vertex of ring i (1..stacks) at column j (0..=slices).
fn sphere_triangles(
    stacks: u32,
    slices: u32,
    north: impl Fn(u32) -> u32,
    ring: impl Fn(u32, u32) -> u32,
    south: impl Fn(u32) -> u32,
) -> Vec<[u32; 3]> {
    let mut indices = Vec::with_capacity((2 * slices * (stacks - 1)) as usize);
    for j in 0..slices {
        indices.push([north(j), ring(1, j + 1), ring(1, j)]);
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
        indices.push([south(j), ring(stacks - 1, j), ring(stacks - 1, j + 1)]);
    }
    indices
}

/// [`uv_sphere`] with exact radial normals and texture coordinates (u = φ/2π, v = θ/π):
/// the same triangles at the same positions, but the seam's column of vertices is
/// doubled (u = 0 and u = 1) and each pole has one vertex per slice (u at the slice's
/// middle), so that u interpolates without wrapping across a triangle.
pub fn smooth_sphere(centre: Vec3, radius: f32, stacks: u32, slices: u32) -> TriMesh {
    let stacks = stacks.max(2);
    let slices = slices.max(3);
    let n = ((stacks - 1) * (slices + 1) + 2 * slices) as usize;
    let mut positions = Vec::with_capacity(n);
    let mut normals = Vec::with_capacity(n);
    let mut uvs = Vec::with_capacity(n);
    let mut vertex = |d: Vec3, uv: [f32; 2]| {
        positions.push((centre + d * radius).into());
        normals.push(d.into());
        uvs.push(uv);
    };
    // North pole: vertex j for slice j.
    for j in 0..slices {
        vertex(Vec3::Y, [(j as f32 + 0.5) / slices as f32, 0.0]);
    }
    for i in 1..stacks {
        let theta = std::f32::consts::PI * i as f32 / stacks as f32;
        let mut first = Vec3::ZERO;
        for j in 0..=slices {
            let phi = 2.0 * std::f32::consts::PI * j as f32 / slices as f32;
            // The seam's second copy takes the first's direction, bit for bit: the
            // surface stays closed.
            let d = match j == slices {
                true => first,
                false => Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                ),
            };
            if j == 0 {
                first = d;
            }
            vertex(d, [j as f32 / slices as f32, i as f32 / stacks as f32]);
        }
    }
    let south = slices + (stacks - 1) * (slices + 1);
    for j in 0..slices {
        vertex(-Vec3::Y, [(j as f32 + 0.5) / slices as f32, 1.0]);
    }
    let ring = |i: u32, j: u32| slices + (i - 1) * (slices + 1) + j;
    let indices = sphere_triangles(stacks, slices, |j| j, ring, |j| south + j);
    TriMesh {
        positions,
        indices,
        normals: Some(normals),
        uvs: Some(uvs),
    }
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

    #[test]
    fn smooth_sphere_normals_are_radial_and_unit_on_the_flat_spheres_triangles() {
        let c = Vec3::new(1.0, -2.0, 0.5);
        let (r, stacks, slices) = (3.0, 7, 12);
        let s = smooth_sphere(c, r, stacks, slices);
        let flat = uv_sphere(c, r, stacks, slices);
        let (n, uv) = (s.normals.as_ref().unwrap(), s.uvs.as_ref().unwrap());
        assert_eq!(n.len(), s.positions.len());
        assert_eq!(uv.len(), s.positions.len());
        for ((p, n), uv) in s.positions.iter().zip(n).zip(uv) {
            let (p, n) = (Vec3::from(*p), Vec3::from(*n));
            assert!((n.length() - 1.0).abs() < 1e-6, "{n}");
            assert!(((p - c) / r - n).length() < 1e-6, "{p} {n}");
            // u = φ/2π from +x towards +z, v = θ/π from +y (away from the seam and the
            // poles, where u is a convention).
            let theta = n.y.clamp(-1.0, 1.0).acos();
            assert!(
                (uv[1] - theta / std::f32::consts::PI).abs() < 1e-5,
                "{uv:?} {n}"
            );
            if n.x > 0.01 && n.z.abs() > 0.01 || n.x < -0.01 {
                let phi = n.z.atan2(n.x).rem_euclid(std::f32::consts::TAU);
                assert!(
                    (uv[0] - phi / std::f32::consts::TAU).abs() < 1e-5,
                    "{uv:?} {n}"
                );
            }
        }
        // The same triangles, bit for bit, as the flat sphere's.
        assert_eq!(s.indices.len(), flat.indices.len());
        for (a, b) in s.indices.iter().zip(&flat.indices) {
            assert_eq!(
                a.map(|i| s.positions[i as usize]),
                b.map(|i| flat.positions[i as usize])
            );
        }
        assert!(s.check_closed_outward().is_ok());
        // No triangle's texture coordinates wrap around the seam.
        for t in &s.indices {
            let u = t.map(|i| uv[i as usize][0]);
            let spread = u.iter().cloned().fold(f32::MIN, f32::max)
                - u.iter().cloned().fold(f32::MAX, f32::min);
            assert!(spread <= 1.0 / slices as f32 + 1e-6, "{u:?}");
        }
    }

    #[test]
    fn flip_negates_normals_and_transform_keeps_them() {
        let mut s = smooth_sphere(Vec3::ZERO, 1.0, 4, 8);
        let before = s.normals.clone().unwrap();
        s.transform(2.5, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(s.normals.as_ref().unwrap(), &before);
        s.flip();
        let after = s.normals.as_ref().unwrap();
        for (a, b) in after.iter().zip(&before) {
            assert_eq!(*a, b.map(|x| -x));
        }
        // Still on the front side: against the (flipped) geometric normal.
        for t in &s.indices {
            let [a, b, c] = t.map(|i| Vec3::from(s.positions[i as usize]));
            let ng = (b - a).cross(c - a);
            assert!(ng.dot(Vec3::from(after[t[0] as usize])) > 0.0);
        }
    }

    /// The meshes of one `[[shapes]]` entry given as TOML, with files in `dir`.
    fn shape(toml: &str, dir: &std::path::Path) -> Result<Vec<(String, TriMesh)>, String> {
        let desc: ShapeDesc = toml::from_str(toml).map_err(|e| e.to_string())?;
        let ctx = Context::new(dir, Vec::new());
        meshes(&desc, &Key::root("shapes").index(0), &ctx).map_err(|e| e.to_string())
    }

    #[test]
    fn smooth_key() {
        let dir = std::env::temp_dir().join(format!("stokes-shapes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
        let face = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let normals = "property float nx\nproperty float ny\nproperty float nz\n";
        std::fs::write(
            dir.join("n.ply"),
            format!("{head}{normals}{face}0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n"),
        )
        .unwrap();
        std::fs::write(
            dir.join("flat.ply"),
            format!("{head}{face}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
        )
        .unwrap();
        let normals_of = |toml: &str| shape(toml, &dir).unwrap()[0].1.normals.clone();
        let sphere = "type = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nstacks = 4\n";
        assert!(normals_of(sphere).is_none());
        assert!(normals_of(&format!("{sphere}smooth = false")).is_none());
        assert!(normals_of(&format!("{sphere}smooth = true")).is_some());
        let ply = "type = \"ply\"\nfile = \"n.ply\"\n";
        assert_eq!(normals_of(ply), Some(vec![[0.0, 0.0, 1.0]; 3]));
        assert_eq!(
            normals_of(&format!("{ply}flip = true")),
            Some(vec![[0.0, 0.0, -1.0]; 3])
        );
        assert!(normals_of(&format!("{ply}smooth = false")).is_none());
        let e = shape("type = \"ply\"\nfile = \"flat.ply\"\nsmooth = true", &dir).unwrap_err();
        assert!(
            e.starts_with("shapes[0].smooth:") && e.contains("flat.ply has no vertex normals"),
            "{e}"
        );
        let quad = "type = \"quad\"\norigin = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\n";
        assert!(normals_of(&format!("{quad}smooth = false")).is_none());
        let e = shape(&format!("{quad}smooth = true"), &dir).unwrap_err();
        assert!(e.starts_with("shapes[0].smooth:"), "{e}");
        let e = shape(
            "type = \"box\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nsmooth = true",
            &dir,
        )
        .unwrap_err();
        assert!(e.starts_with("shapes[0].smooth:"), "{e}");
        // `file` belongs to obj and ply only; `object` to obj only.
        let e = shape(&format!("{ply}object = \"a\""), &dir).unwrap_err();
        assert!(e.contains("object: not a key of a ply shape"), "{e}");
        let e = shape(&format!("{sphere}file = \"n.ply\""), &dir).unwrap_err();
        assert!(e.contains("file: not a key of a sphere shape"), "{e}");
    }
}
