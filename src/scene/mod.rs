//! Scene loading: the TOML description ([`desc`]) turned into what the renderer traces —
//! an Embree scene, materials, lights and a camera.
//!
//! This module assembles; each kind parses its own part (`from_desc` beside its type,
//! with the TOML syntax in that module's documentation), with a [`Context`] for the
//! named spectra, relative file names and warnings. Every error names the scene file and
//! the key (or the file and line, for TOML syntax and for OBJ/CSV files) and says what
//! was expected ([`crate::error`]).

pub mod context;
pub mod desc;
pub mod obj;
pub mod ply;
pub mod shapes;
mod summary;

use crate::accel;
use crate::bsdf::Material;
use crate::camera::Camera;
use crate::error::{Error, Key, KeyError};
use crate::light::{Emitter, Lights};
use crate::medium::Homogeneous;
use crate::spectrum::{Spectrum, SpectrumDesc};
use context::list;
use desc::SceneDesc;
use glam::{Vec2, Vec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use context::Context;
pub use desc::RenderDesc;

/// What the renderer knows of one Embree geometry.
#[derive(Debug, Clone)]
pub struct Geometry {
    /// A readable name: `shapes[i]` plus the OBJ object name.
    pub name: String,
    /// Index into [`Scene::materials`], or `None` for a black, non-scattering surface.
    pub material: Option<u32>,
    /// Number of triangles.
    pub triangles: usize,
    /// The medium inside this (closed, outward-facing) mesh.
    pub interior: Option<u32>,
    /// The medium outside it.
    pub exterior: Option<u32>,
    /// An index-matched medium boundary: no material, no emission, rays pass.
    pub null_interface: bool,
    /// The mesh's per-vertex normals and texture coordinates, if it has either (shared:
    /// `Geometry` is cloned with the scene's tables).
    pub shading: Option<Arc<Shading>>,
}

impl Geometry {
    /// Whether rays cross this surface unchanged (only the medium changes).
    #[inline]
    pub fn is_null_interface(&self) -> bool {
        self.null_interface
    }

    /// The smooth-shading normal at barycentrics `(u, v)` of triangle `prim` (Embree's
    /// convention: `u` weighs vertex 1, `v` vertex 2): the interpolated vertex normals,
    /// normalised, on the front side (that of the geometric normal `(v1−v0)×(v2−v0)`,
    /// for well-made meshes). `None` for a mesh without normals, and where the
    /// interpolation is zero or not finite: then shade with the geometric normal.
    #[inline]
    pub fn shading_normal(&self, prim: u32, u: f32, v: f32) -> Option<Vec3> {
        let s = self.shading.as_deref()?;
        let [n0, n1, n2] = s.corners(s.normals.as_deref()?, prim)?;
        let n = Vec3::from(n0) * (1.0 - u - v) + Vec3::from(n1) * u + Vec3::from(n2) * v;
        n.try_normalize()
    }

    /// The unit tangent ∂p/∂u of triangle `prim` (the direction of increasing texture u),
    /// or `None` for a mesh without texture coordinates or a degenerate triangle.
    #[inline]
    pub fn tangent(&self, prim: u32) -> Option<Vec3> {
        let s = self.shading.as_deref()?;
        let t = *s.tangents.as_deref()?.get(prim as usize)?;
        Vec3::from(t).try_normalize()
    }

    /// The texture coordinates at barycentrics `(u, v)` of triangle `prim`, interpolated
    /// like [`Geometry::shading_normal`]; `None` for a mesh without them.
    #[inline]
    pub fn uv(&self, prim: u32, u: f32, v: f32) -> Option<Vec2> {
        let s = self.shading.as_deref()?;
        let [t0, t1, t2] = s.corners(s.uvs.as_deref()?, prim)?;
        let t = Vec2::from(t0) * (1.0 - u - v) + Vec2::from(t1) * u + Vec2::from(t2) * v;
        t.is_finite().then_some(t)
    }
}

/// The per-vertex data of a mesh that shading interpolates over its triangles.
#[derive(Debug, Clone, Default)]
pub struct Shading {
    /// The triangles, as attached to Embree (its `prim` ids index them).
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex normals (any length; normalised after interpolation).
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per-vertex texture coordinates.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Per triangle, ∂p/∂u from the texture coordinates (zero where they are
    /// degenerate): the first tangent of anisotropic lobes.
    pub tangents: Option<Vec<[f32; 3]>>,
}

impl Shading {
    /// The shading data of `mesh`, or `None` if it has neither normals nor texture
    /// coordinates (then its indices are not kept: Embree has its own copy).
    pub fn from_mesh(mesh: shapes::TriMesh) -> Option<Shading> {
        if mesh.normals.is_none() && mesh.uvs.is_none() {
            return None;
        }
        let tangents = mesh.uvs.as_ref().map(|uvs| {
            mesh.indices
                .iter()
                .map(|t| {
                    dp_du(
                        t.map(|i| mesh.positions[i as usize]),
                        t.map(|i| uvs[i as usize]),
                    )
                })
                .collect()
        });
        Some(Shading {
            indices: mesh.indices,
            normals: mesh.normals,
            uvs: mesh.uvs,
            tangents,
        })
    }

    /// The values of `data` at the three corners of triangle `prim`; `None` if an
    /// index is out of range (a malformed `Shading` never panics).
    #[inline(always)]
    fn corners<T: Copy>(&self, data: &[T], prim: u32) -> Option<[T; 3]> {
        let [a, b, c] = *self.indices.get(prim as usize)?;
        Some([
            *data.get(a as usize)?,
            *data.get(b as usize)?,
            *data.get(c as usize)?,
        ])
    }
}

/// ∂p/∂u of a triangle with corners `p` and texture coordinates `t`: the solution of
/// e₁ = ∂p/∂u·Δu₁ + ∂p/∂v·Δv₁, e₂ likewise; zero when the texture coordinates are
/// degenerate or it does not come out finite.
fn dp_du(p: [[f32; 3]; 3], t: [[f32; 2]; 3]) -> [f32; 3] {
    let [p0, p1, p2] = p.map(Vec3::from);
    let (e1, e2) = (p1 - p0, p2 - p0);
    let (du1, dv1) = (t[1][0] - t[0][0], t[1][1] - t[0][1]);
    let (du2, dv2) = (t[2][0] - t[0][0], t[2][1] - t[0][1]);
    let det = du1 * dv2 - du2 * dv1;
    let d = (e1 * dv2 - e2 * dv1) / det;
    match det != 0.0 && d.is_finite() {
        true => d.into(),
        false => [0.0; 3],
    }
}

/// A loaded scene.
pub struct Scene {
    /// The scene file.
    pub path: PathBuf,
    /// The scene file's fingerprint ([`crate::header::scene_hash`] of its text): images
    /// of the same file carry the same one.
    pub hash: String,
    /// Embree's view of the geometry.
    pub accel: accel::Scene,
    /// The camera.
    pub camera: Camera,
    /// Render defaults from the file.
    pub render: RenderDesc,
    /// Materials, by index.
    pub materials: Vec<Material>,
    /// What the scene's materials and meshes use: a surface step skips the work of what
    /// none of them has.
    pub features: Features,
    /// Material names, by index.
    pub material_names: Vec<String>,
    /// Per Embree geometry id.
    pub geometries: Vec<Geometry>,
    /// Area lights.
    pub lights: Lights,
    /// Homogeneous media, by index.
    pub media: Vec<Homogeneous>,
    /// Medium names, by index.
    pub medium_names: Vec<String>,
    /// The medium the camera is in.
    pub camera_medium: Option<u32>,
    /// Axis-aligned bounds of all geometry.
    pub bounds: (Vec3, Vec3),
    /// Things worth telling the user that are not errors (clamped matrix entries, energy
    /// gain), one message each.
    pub warnings: Vec<String>,
    /// Named regions of interest of the image (`[[region]]`), in file order.
    pub regions: Vec<Region>,
}

/// What a scene uses, so that the surface step can skip what it does not (the image is the
/// same either way: skipped work would find nothing to do).
#[derive(Debug, Clone, Copy, Default)]
pub struct Features {
    /// Some material is textured ([`Material::is_textured`]): texture coordinates.
    pub textured: bool,
    /// Some surface material shifts wavelengths (fluorescent, bare or under a coat).
    pub fluorescent_surfaces: bool,
    /// Some material is coated: the choice between coat and base.
    pub coated: bool,
    /// Some mesh has shading normals or texture directions.
    pub shading: bool,
}

impl Features {
    /// The features of these materials and meshes.
    pub fn of(materials: &[Material], geometries: &[Geometry]) -> Features {
        let any = |f: fn(&Material) -> bool| materials.iter().any(f);
        Features {
            textured: any(Material::is_textured),
            fluorescent_surfaces: any(|m| match m {
                Material::FluorescentDiffuse { .. } => true,
                Material::Coated(c) => c.fluoresces(),
                _ => false,
            }),
            coated: any(|m| matches!(m, Material::Coated(_))),
            shading: geometries.iter().any(|g| g.shading.is_some()),
        }
    }
}

/// A named region of interest (`[[region]]`): a rectangle of pixels of the scene file's
/// camera resolution, `[min, max)` on each axis (x to the right, y down).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Region {
    /// Its name in reports.
    pub name: String,
    /// First column and row.
    pub min: [u32; 2],
    /// One past the last column and row.
    pub max: [u32; 2],
    /// The resolution `min` and `max` refer to: the scene file's `camera.resolution`.
    pub resolution: [u32; 2],
}

impl Region {
    /// The rectangle `[x0, x1) × [y0, y1)`, as `[x0, y0, x1, y1]`, at `width`×`height`:
    /// the pixels whose centres fall inside the region scaled to that resolution (each
    /// axis by its own factor), and at least the pixel under the region's centre.
    pub fn rect(&self, width: u32, height: u32) -> [u32; 4] {
        let axis = |lo: u32, hi: u32, base: u32, n: u32| -> (u32, u32) {
            let s = n as f64 / base.max(1) as f64;
            let first = |v: u32| ((v as f64 * s - 0.5).ceil().max(0.0) as u32).min(n);
            let (a, b) = (first(lo), first(hi));
            if a < b {
                (a, b)
            } else {
                let c = (((lo + hi) as f64 * 0.5 * s).floor() as u32).min(n.saturating_sub(1));
                (c, c + 1)
            }
        };
        let (x0, x1) = axis(self.min[0], self.max[0], self.resolution[0], width);
        let (y0, y1) = axis(self.min[1], self.max[1], self.resolution[1], height);
        [x0, y0, x1, y1]
    }

    /// The row-major indices of [`Region::rect`]'s pixels at `width`×`height`.
    pub fn pixels(&self, width: u32, height: u32) -> Vec<usize> {
        let [x0, y0, x1, y1] = self.rect(width, height);
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| y as usize * width as usize + x as usize))
            .collect()
    }
}

impl Scene {
    /// Loads a scene file. The error names the file and the key or line.
    pub fn load(path: &Path) -> Result<Scene, Error> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::file(path, None, format!("cannot read scene file: {e}")))?;
        Scene::from_str(&text, path)
    }

    /// Parses scene text; `path` names it in errors and anchors relative file names.
    pub fn from_str(text: &str, path: &Path) -> Result<Scene, Error> {
        let desc: SceneDesc = toml::from_str(text).map_err(|e| syntax_error(&e, text, path))?;
        // Not the scene file's error: the message names the environment variable.
        let device = accel::Device::new()?;
        let base = path.parent().unwrap_or(Path::new("."));
        let names = desc.spectra.keys().cloned().collect();
        Builder {
            device,
            text,
            file: path,
            desc: &desc,
            ctx: Context::new(base, names),
        }
        .build()
        .map_err(|error| Error::Value {
            file: path.to_path_buf(),
            error,
        })
    }

    /// Renders at another resolution (same vertical field of view).
    pub fn set_resolution(&mut self, width: u32, height: u32) {
        self.camera = self.camera.with_resolution(width, height);
    }

    /// Total triangle count.
    pub fn triangle_count(&self) -> usize {
        self.accel.triangle_count()
    }

    /// Whether any material refracts with a wavelength-dependent index.
    pub fn has_dispersion(&self) -> bool {
        self.materials
            .iter()
            .any(|m| matches!(m, Material::Dielectric { ior, .. } if ior.is_dispersive()))
    }

    /// Whether any rough dielectric has a wavelength-dependent index (its lanes stay
    /// together: each gets its own BTDF value and pdf).
    pub fn has_rough_dispersion(&self) -> bool {
        self.materials
            .iter()
            .any(|m| matches!(m, Material::RoughDielectric { ior, .. } if ior.is_dispersive()))
    }

    /// Whether any medium is present (then shadow rays look for medium boundaries).
    #[inline]
    pub fn has_media(&self) -> bool {
        !self.media.is_empty()
    }

    /// Whether any medium carries a fluorescent dye.
    pub fn has_fluorescent_media(&self) -> bool {
        self.media.iter().any(|m| m.is_fluorescent())
    }

    /// Whether any material fluoresces (then the shifting method matters).
    pub fn has_fluorescence(&self) -> bool {
        self.materials.iter().any(|m| match m {
            Material::FluorescentDiffuse { reradiation, .. } => reradiation.is_fluorescent(),
            Material::Coated(c) => c.fluoresces(),
            _ => false,
        })
    }

    /// A name for reports: the file stem.
    pub fn name(&self) -> String {
        self.path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    }
}

/// The TOML reader's error as `file:line:column: what was expected (in `the line`)`.
fn syntax_error(e: &toml::de::Error, text: &str, path: &Path) -> Error {
    let message = e.message().trim().replace('\n', " ");
    match e.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            Error::Syntax {
                file: path.to_path_buf(),
                line,
                column,
                message,
                text: text.lines().nth(line - 1).unwrap_or("").trim().to_string(),
            }
        }
        None => Error::file(path, None, message),
    }
}

/// A scene file being turned into a [`Scene`].
struct Builder<'a> {
    device: accel::Device,
    file: &'a Path,
    text: &'a str,
    desc: &'a SceneDesc,
    ctx: Context,
}

/// Named items (`[materials]`, `[media]`) by index, with their names for lookups.
struct Named<T> {
    items: Vec<T>,
    names: Vec<String>,
    index: BTreeMap<String, u32>,
    /// What they are, for messages: `material`, `medium`.
    what: &'static str,
}

impl<T> Named<T> {
    fn new(what: &'static str) -> Named<T> {
        Named {
            items: Vec::new(),
            names: Vec::new(),
            index: BTreeMap::new(),
            what,
        }
    }

    fn push(&mut self, name: &str, item: T) {
        self.index.insert(name.to_string(), self.items.len() as u32);
        self.items.push(item);
        self.names.push(name.to_string());
    }

    /// The index of `name` (given at `key`), if any is named.
    fn lookup(&self, key: &Key, name: &Option<String>) -> Result<Option<u32>, KeyError> {
        let Some(n) = name else { return Ok(None) };
        match self.index.get(n) {
            Some(&i) => Ok(Some(i)),
            None => Err(key.error(format!(
                "no {} named {n:?} (defined: {})",
                self.what,
                list(self.index.keys())
            ))),
        }
    }
}

impl Builder<'_> {
    fn build(mut self) -> Result<Scene, KeyError> {
        let d = self.desc;
        // Named spectra first: materials and emitters refer to them.
        for name in d.spectra.keys() {
            self.named_spectrum(name)?;
        }
        let camera = self.camera()?;
        let regions = self.regions()?;
        let render = Key::root("render");
        if d.render.spp == 0 {
            return Err(render
                .field("spp")
                .expected("at least 1 sample per pixel", 0));
        }
        if d.render.max_depth < -1 || d.render.max_depth == 0 {
            return Err(render
                .field("max_depth")
                .expected("−1 (unbounded) or a depth ≥ 1", d.render.max_depth));
        }
        let mut media = Named::new("medium");
        for (name, m) in &d.media {
            let key = Key::root("media").field(name);
            media.push(name, Homogeneous::from_desc(m, &key, &mut self.ctx)?);
        }
        let camera_medium = media.lookup(&Key::root("camera").field("medium"), &d.camera.medium)?;
        let mut materials = Named::new("material");
        for (name, m) in &d.materials {
            let key = Key::root("materials").field(name);
            materials.push(name, Material::from_desc(m, &key, &mut self.ctx)?);
        }
        let (accel, geometries, lights, bounds) = self.shapes(&materials, &media)?;
        Ok(Scene {
            path: self.file.to_path_buf(),
            hash: crate::header::scene_hash(self.text.as_bytes()),
            accel,
            camera,
            render: d.render.clone(),
            features: Features::of(&materials.items, &geometries),
            materials: materials.items,
            material_names: materials.names,
            geometries,
            lights,
            media: media.items,
            medium_names: media.names,
            camera_medium,
            bounds,
            warnings: self.ctx.into_warnings(),
            regions,
        })
    }

    fn camera(&self) -> Result<Camera, KeyError> {
        let c = &self.desc.camera;
        let key = Key::root("camera");
        let v = |k: &str, v| shapes::finite_vec(&key.field(k), v);
        Camera::new(
            v("position", c.position)?,
            v("look_at", c.look_at)?,
            v("up", c.up)?,
            c.fov,
            c.resolution[0],
            c.resolution[1],
        )
    }

    /// Every shape's meshes, attached to Embree, with their materials, media and lights.
    #[allow(clippy::type_complexity)]
    fn shapes(
        &mut self,
        materials: &Named<Material>,
        media: &Named<Homogeneous>,
    ) -> Result<(accel::Scene, Vec<Geometry>, Lights, (Vec3, Vec3)), KeyError> {
        let mut builder = self
            .device
            .scene_builder()
            .map_err(|e| Key::root("shapes").error(e))?;
        let mut geometries = Vec::new();
        let mut lights = Lights::default();
        // Total power of the lights (W, for scene units of metres), for the check that
        // their selection table stays finite.
        let mut power = 0.0f64;
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for (i, s) in self.desc.shapes.iter().enumerate() {
            let key = Key::root("shapes").index(i);
            let material = match &s.material {
                Some(_) => materials.lookup(&key.field("material"), &s.material)?,
                None if s.emission.is_some() || s.interior.is_some() || s.exterior.is_some() => {
                    None
                }
                None => return Err(key.error("missing key `material`")),
            };
            let interior = media.lookup(&key.field("interior"), &s.interior)?;
            let exterior = media.lookup(&key.field("exterior"), &s.exterior)?;
            let bounds_medium = interior.is_some() || exterior.is_some();
            let null_interface = material.is_none() && s.emission.is_none() && bounds_medium;
            if let Some(m) = material {
                if bounds_medium
                    && !matches!(materials.items[m as usize], Material::Dielectric { .. })
                {
                    return Err(key.field("material").error(
                        "a medium boundary must be a dielectric or have no material (index-matched)",
                    ));
                }
            }
            let emitter = match &s.emission {
                Some(e) => Some(Emitter::from_desc(e, &key, &mut self.ctx)?),
                None => None,
            };
            let textured = material.is_some_and(|m| materials.items[m as usize].is_textured());
            for (name, mut mesh) in shapes::meshes(s, &key, &self.ctx)? {
                if textured && mesh.uvs.is_none() {
                    // A quad's coordinates run along its edges; other shapes need their own.
                    if s.kind != "quad" {
                        return Err(key.field("material").error(format!(
                            "a textured material on a {} shape without texture coordinates (quads have them, as do smooth spheres and meshes whose files give them)",
                            s.kind
                        )));
                    }
                    mesh.uvs = Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
                }
                if interior.is_some() {
                    mesh.check_closed_outward()
                        .map_err(|e| key.field("interior").error(e))?;
                }
                let (a, b) = mesh.bounds();
                lo = lo.min(a);
                hi = hi.max(b);
                let id = builder
                    .attach_triangles(&mesh.positions, &mesh.indices)
                    .map_err(|e| key.error(e))?;
                if let Some(em) = &emitter {
                    let area = lights
                        .add(id, em.clone(), &mesh.positions, &mesh.indices)
                        .map_err(|e| key.error(e))?;
                    power += em.checked_power(&key, area)?;
                }
                geometries.push(Geometry {
                    name: if name.is_empty() {
                        key.to_string()
                    } else {
                        format!("{key} ({name})")
                    },
                    material,
                    triangles: mesh.indices.len(),
                    interior,
                    exterior,
                    null_interface,
                    shading: Shading::from_mesh(mesh).map(Arc::new),
                });
            }
        }
        let shapes = Key::root("shapes");
        if geometries.is_empty() {
            return Err(shapes.error("the scene has no shapes"));
        }
        if power > f64::from(f32::MAX) {
            return Err(shapes.expected(
                "lights whose total power is finite in 32-bit floats",
                format!("{power:.3e} (each is, their sum is not)"),
            ));
        }
        lights.set_bounds(lo, hi);
        let radius = 0.5 * (hi - lo).length();
        for (i, l) in self.desc.lights.iter().enumerate() {
            l.add_to(
                &mut lights,
                &Key::root("lights").index(i),
                &mut self.ctx,
                radius,
            )?;
        }
        if lights.is_empty() {
            self.ctx.warn(
                &shapes,
                "no shape has an `emission` and there are no `[[lights]]`: the scene has no light and renders black",
            );
        }
        lights.finish();
        let accel = builder.commit().map_err(|e| shapes.error(e))?;
        Ok((accel, geometries, lights, (lo, hi)))
    }

    /// Resolves `[spectra].name` into the context. An entry may name another entry
    /// (`sun = "lamp"`), which is resolved first, whatever the order of the file; a name
    /// that is not an entry is a CIE illuminant. A chain that comes back to where it
    /// started is an error listing it.
    fn named_spectrum(&mut self, name: &str) -> Result<(), KeyError> {
        let d = self.desc;
        let key = |n: &str| Key::root("spectra").field(n);
        // Follow the chain of references to its first entry that is not a name of another
        // entry (or is resolved already), then resolve the chain from there back.
        let mut chain = vec![name];
        let mut last = name;
        while let Some(SpectrumDesc::Name(next)) = d.spectra.get(last) {
            if self.ctx.has_named(last) || !d.spectra.contains_key(next) {
                break;
            }
            if let Some(start) = chain.iter().position(|n| n == next) {
                let mut cycle: Vec<&str> = chain[start..].to_vec();
                cycle.push(next);
                return Err(key(chain[start]).expected(
                    "a spectrum or the name of one",
                    format!("a cycle of references {}", cycle.join(" → ")),
                ));
            }
            chain.push(next);
            last = next;
        }
        for n in chain.into_iter().rev() {
            if !self.ctx.has_named(n) {
                let spec = Spectrum::from_desc(&d.spectra[n], &key(n), &self.ctx, None)?;
                self.ctx.add_named(n, spec);
            }
        }
        Ok(())
    }
    /// The `[[region]]` tables, checked against the camera's resolution.
    fn regions(&self) -> Result<Vec<Region>, KeyError> {
        let res = self.desc.camera.resolution;
        let mut out: Vec<Region> = Vec::new();
        for (i, r) in self.desc.regions.iter().enumerate() {
            let key = Key::root("region").index(i);
            let n = &r.name;
            let name = key.field("name");
            let allowed = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_';
            if n.is_empty() || !n.chars().all(allowed) {
                return Err(name.expected("letters, digits, `-` and `_`", format!("{n:?}")));
            }
            if n == "image" {
                return Err(
                    name.error("`image` is reserved for the whole image; choose another name")
                );
            }
            if out.iter().any(|o| &o.name == n) {
                return Err(name.error(format!("another region is already named {n:?}")));
            }
            for (axis, what) in [(0, "x"), (1, "y")] {
                let (lo, hi) = (r.min[axis], r.max[axis]);
                if lo >= hi {
                    return Err(key.expected("min < max", format!("{what} from {lo} to {hi}")));
                }
                if hi > res[axis] {
                    return Err(key.field("max").expected(
                        format!("a rectangle inside camera.resolution {res:?} (pixels of the scene's own resolution)"),
                        format!("{what} up to {hi}"),
                    ));
                }
            }
            out.push(Region {
                name: n.clone(),
                min: r.min,
                max: r.max,
                resolution: res,
            });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn dp_du_follows_the_texture_coordinates() {
        let p = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 3.0]];
        assert_eq!(
            dp_du(p, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
            [2.0, 0.0, 0.0]
        );
        assert_eq!(
            dp_du(p, [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]]),
            [0.0, 0.0, 3.0]
        );
        assert_eq!(dp_du(p, [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]), [0.0; 3]);
    }
    use super::*;

    fn geometry(shading: Option<Shading>) -> Geometry {
        Geometry {
            name: "test".into(),
            material: None,
            triangles: 1,
            interior: None,
            exterior: None,
            null_interface: false,
            shading: shading.map(Arc::new),
        }
    }

    #[test]
    fn shading_normal_and_uv_interpolate_embrees_barycentrics() {
        // Vertex 3 is unused; triangle 1 lists the corners in another order.
        let g = geometry(Some(Shading {
            tangents: None,
            indices: vec![[0, 1, 2], [2, 0, 1]],
            normals: Some(vec![
                [0.0, 0.0, 2.0],
                [1.0, 0.0, 0.0],
                [0.0, 3.0, 0.0],
                [9.0; 3],
            ]),
            uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [5.0; 2]]),
        }));
        let (u, v) = (0.2, 0.5);
        // (1−u−v)·n0 + u·n1 + v·n2, normalised: u weighs vertex 1, v vertex 2.
        let want = Vec3::new(0.2, 1.5, 0.6).normalize();
        let n = g.shading_normal(0, u, v).unwrap();
        assert!((n - want).length() < 1e-6, "{n} {want}");
        assert!((g.uv(0, u, v).unwrap() - Vec2::new(0.2, 0.5)).length() < 1e-6);
        // Triangle 1 = (2, 0, 1): 0.3·(0, 3, 0) + 0.2·(0, 0, 2) + 0.5·(1, 0, 0).
        let want = Vec3::new(0.5, 0.9, 0.4).normalize();
        let n = g.shading_normal(1, 0.2, 0.5).unwrap();
        assert!((n - want).length() < 1e-6, "{n} {want}");
        // At the corners, the vertex's own normal.
        assert_eq!(g.shading_normal(0, 0.0, 0.0), Some(Vec3::Z));
        assert_eq!(g.shading_normal(0, 1.0, 0.0), Some(Vec3::X));
        assert_eq!(g.shading_normal(0, 0.0, 1.0), Some(Vec3::Y));
        // A triangle past the end, or no data: none.
        assert_eq!(g.shading_normal(2, u, v), None);
        assert_eq!(geometry(None).shading_normal(0, u, v), None);
        assert_eq!(geometry(None).uv(0, u, v), None);
    }

    #[test]
    fn degenerate_normals_give_none() {
        let shading = |normals: Vec<[f32; 3]>| Shading {
            tangents: None,
            indices: vec![[0, 1, 2]],
            normals: Some(normals),
            uvs: None,
        };
        // Opposite normals cancel halfway between vertices 0 and 1.
        let g = geometry(Some(shading(vec![
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [0.0, 1.0, 0.0],
        ])));
        assert_eq!(g.shading_normal(0, 0.5, 0.0), None);
        assert!(g.shading_normal(0, 0.25, 0.0).is_some());
        let g = geometry(Some(shading(vec![
            [f32::NAN, 0.0, 1.0],
            [0.0; 3],
            [0.0; 3],
        ])));
        assert_eq!(g.shading_normal(0, 0.0, 0.0), None);
        assert_eq!(g.uv(0, 0.2, 0.2), None);
        // From a mesh: none at all without normals and texture coordinates.
        assert!(Shading::from_mesh(shapes::quad(Vec3::ZERO, Vec3::X, Vec3::Y)).is_none());
    }
}
