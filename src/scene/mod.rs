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
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
}

impl Geometry {
    /// Whether rays cross this surface unchanged (only the medium changes).
    #[inline]
    pub fn is_null_interface(&self) -> bool {
        self.null_interface
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
        self.materials.iter().any(
            |m| matches!(m, Material::FluorescentDiffuse { reradiation } if reradiation.is_fluorescent()),
        )
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
            media.push(name, Homogeneous::from_desc(m, &key, &self.ctx)?);
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
            for (name, mesh) in shapes::meshes(s, &key, &self.ctx)? {
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
        if lights.is_empty() {
            self.ctx.warn(
                &shapes,
                "no shape has an `emission`: the scene has no light and renders black",
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
