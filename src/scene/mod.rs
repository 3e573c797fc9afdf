//! Scene loading: the TOML description ([`desc`]) turned into what the renderer traces —
//! an Embree scene, materials, lights and a camera.
//!
//! Every error names the scene file and the key (or the file and line, for TOML syntax
//! and for OBJ/CSV files) and says what was expected.

pub mod desc;
pub mod obj;
pub mod shapes;

use crate::accel;
use crate::bsdf::{Ior, Material};
use crate::camera::Camera;
use crate::fluoro::Reradiation;
use crate::light::{Emitter, Lights};
use crate::medium::tracking::Tracking;
use crate::medium::{HenyeyGreenstein, Homogeneous};
use crate::spectrum::{self, Spectrum, Tabulated};
use desc::{IorDesc, SceneDesc, SpectrumDesc};
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
    /// Loads a scene file. The error is one message naming the file and the key or line.
    pub fn load(path: &Path) -> Result<Scene, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read scene file: {e}", path.display()))?;
        Scene::from_str(&text, path)
    }

    /// Parses scene text; `path` names it in errors and anchors relative file names.
    pub fn from_str(text: &str, path: &Path) -> Result<Scene, String> {
        let desc: SceneDesc = toml::from_str(text).map_err(|e| {
            // One line: file:line:column: what was expected.
            let msg = e.message().trim().replace('\n', " ");
            match e.span() {
                Some(span) => {
                    let before = &text[..span.start.min(text.len())];
                    let line = before.matches('\n').count() + 1;
                    let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
                    let src = text.lines().nth(line - 1).unwrap_or("").trim();
                    format!("{}:{line}:{col}: {msg} (in `{src}`)", path.display())
                }
                None => format!("{}: {msg}", path.display()),
            }
        })?;
        let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        // Not the scene file's error: the message names the environment variable.
        let device = accel::Device::new().map_err(|e| e.to_string())?;
        Builder {
            device,
            file: path,
            base,
            desc: &desc,
            spectra: BTreeMap::new(),
            warnings: Vec::new(),
        }
        .build()
        .map_err(|e| one_line(&format!("{}: {e}", path.display())))
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

    /// Whether any medium is present (then shadow rays look for medium boundaries).
    #[inline]
    pub fn has_media(&self) -> bool {
        !self.media.is_empty()
    }

    /// Whether any medium carries a fluorescent dye.
    pub fn has_fluorescent_media(&self) -> bool {
        self.media.iter().any(|m| m.is_fluorescent())
    }

    /// The tracking method used when none is asked for: classic where no medium
    /// fluoresces, fluorescence-aware where one does, and why.
    pub fn default_tracking(&self) -> (Tracking, &'static str) {
        if self.has_fluorescent_media() {
            (
                Tracking::FluoAware,
                "a medium fluoresces: classic tracking would miss re-emission where σ̂_t is small",
            )
        } else {
            (
                Tracking::Classic,
                "no medium fluoresces: classic tracking is unbiased and cheapest",
            )
        }
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

struct Builder<'a> {
    device: accel::Device,
    file: &'a Path,
    base: PathBuf,
    desc: &'a SceneDesc,
    spectra: BTreeMap<String, Spectrum>,
    warnings: Vec<String>,
}

/// The largest spectral radiance × scale of an emitter (W·sr⁻¹·m⁻²·nm⁻¹): some 25 orders
/// of magnitude above the Sun's (about 2·10⁴) and 8 below `f32::MAX`, the headroom a
/// path's estimate needs (radiance over the wavelength pdf, times colour matching and
/// throughput) to stay finite in 32-bit floats.
const MAX_RADIANCE: f32 = 1e30;

/// The largest coefficient σ_a, σ_s, σ_t or σ_dye of a medium (per scene unit): a mean
/// free path of 10⁻³⁰ scene units is opaque at any scale 32-bit positions resolve, and
/// beyond it sums of coefficients (σ̂_t = σ_a + σ_s + σ_dye) and σ × distance overflow.
const MAX_COEFFICIENT: f32 = 1e30;

/// The power of one emitter (π × sides × area × radiance integrated over the rendered
/// range, with `area` its total area), which must be finite in 32-bit floats: the light
/// selection table holds it (divided by π × sides × 470 nm) in them.
fn check_power(key: &str, e: &Emitter, area: f64) -> Result<f64, String> {
    let sides = if e.two_sided { 2.0 } else { 1.0 };
    let power = std::f64::consts::PI
        * sides
        * area
        * f64::from(e.mean_radiance())
        * f64::from(spectrum::LAMBDA_RANGE);
    if power > f64::from(f32::MAX) {
        return Err(format!(
            "{key}.emission: expected a light whose power (π × area × radiance over {}–{} nm) is finite in 32-bit floats, found {power:.3e} (area {area:.3e})",
            spectrum::LAMBDA_MIN,
            spectrum::LAMBDA_MAX
        ));
    }
    Ok(power)
}

/// The smallest fwhm (nm) of a narrow band in `s`, if it is one (possibly scaled).
fn narrowest_band(s: &Spectrum) -> Option<f32> {
    match s {
        Spectrum::NarrowBand { fwhm, .. } => Some(*fwhm),
        Spectrum::Scaled(inner, _) => narrowest_band(inner),
        _ => None,
    }
}

fn check_vec(key: &str, v: [f32; 3]) -> Result<Vec3, String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(Vec3::from(v))
    } else {
        Err(format!("{key}: expected finite numbers, found {v:?}"))
    }
}

/// What range a spectrum's values must lie in.
#[derive(Clone, Copy)]
enum Range {
    /// Reflectances: [0, 1].
    Unit,
    /// Radiances: ≥ 0.
    NonNegative,
}

impl Builder<'_> {
    fn build(mut self) -> Result<Scene, String> {
        let d = self.desc;
        // Named spectra first: materials and emitters refer to them.
        for name in d.spectra.keys() {
            self.named_spectrum(name)?;
        }

        let c = &d.camera;
        let camera = Camera::new(
            check_vec("camera.position", c.position)?,
            check_vec("camera.look_at", c.look_at)?,
            check_vec("camera.up", c.up)?,
            c.fov,
            c.resolution[0],
            c.resolution[1],
        )?;
        let regions = self.regions()?;
        if d.render.spp == 0 {
            return Err("render.spp: expected at least 1 sample per pixel, found 0".into());
        }
        if d.render.max_depth < -1 || d.render.max_depth == 0 {
            return Err(format!(
                "render.max_depth: expected −1 (unbounded) or a depth ≥ 1, found {}",
                d.render.max_depth
            ));
        }

        let mut media = Vec::new();
        let mut medium_names = Vec::new();
        let mut medium_index = BTreeMap::new();
        for (name, m) in &d.media {
            let key = format!("media.{name}");
            medium_index.insert(name.clone(), media.len() as u32);
            media.push(self.medium(&key, m)?);
            medium_names.push(name.clone());
        }
        let lookup_medium = |key: &str, name: &Option<String>| -> Result<Option<u32>, String> {
            match name {
                None => Ok(None),
                Some(n) => medium_index.get(n).copied().map(Some).ok_or_else(|| {
                    format!(
                        "{key}: no medium named {n:?} (defined: {})",
                        list(medium_index.keys())
                    )
                }),
            }
        };
        let camera_medium = lookup_medium("camera.medium", &c.medium)?;

        let mut materials = Vec::new();
        let mut material_names = Vec::new();
        let mut material_index = BTreeMap::new();
        for (name, m) in &d.materials {
            let key = format!("materials.{name}");
            material_index.insert(name.clone(), materials.len() as u32);
            let material = self.material(&key, m)?;
            materials.push(material);
            material_names.push(name.clone());
        }

        let mut builder = self.device.scene_builder().map_err(|e| e.to_string())?;
        let mut geometries = Vec::new();
        let mut lights = Lights::default();
        // Total power of the lights (W, for scene units of metres), for the check that
        // their selection table stays finite.
        let mut power = 0.0f64;
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);

        for (i, s) in d.shapes.iter().enumerate() {
            let key = format!("shapes[{i}]");
            let material = match &s.material {
                Some(m) => Some(*material_index.get(m).ok_or_else(|| {
                    format!(
                        "{key}.material: no material named {m:?} (defined: {})",
                        list(material_index.keys())
                    )
                })?),
                None if s.emission.is_some() || s.interior.is_some() || s.exterior.is_some() => {
                    None
                }
                None => return Err(format!("{key}: missing key `material`")),
            };
            let interior = lookup_medium(&format!("{key}.interior"), &s.interior)?;
            let exterior = lookup_medium(&format!("{key}.exterior"), &s.exterior)?;
            let null_interface = material.is_none()
                && s.emission.is_none()
                && (interior.is_some() || exterior.is_some());
            if let Some(m) = material {
                if (interior.is_some() || exterior.is_some())
                    && !matches!(materials[m as usize], Material::Dielectric { .. })
                {
                    return Err(format!(
                        "{key}.material: a medium boundary must be a dielectric or have no material (index-matched)"
                    ));
                }
            }
            let emitter = match &s.emission {
                Some(e) => {
                    let scale = e.scale.unwrap_or(1.0);
                    if !(scale.is_finite() && scale >= 0.0) {
                        return Err(format!(
                            "{key}.emission.scale: expected a non-negative number, found {scale}"
                        ));
                    }
                    let radiance = self.spectrum(
                        &format!("{key}.emission.radiance"),
                        &e.radiance,
                        Some(Range::NonNegative),
                    )?;
                    self.check_emitter(&key, &radiance, scale)?;
                    Some(Emitter {
                        radiance,
                        scale,
                        two_sided: e.two_sided,
                    })
                }
                None => None,
            };
            for (name, mut mesh) in self.meshes(&key, s)? {
                let scale = s.scale.unwrap_or(1.0);
                if !(scale.is_finite() && scale > 0.0) {
                    return Err(format!(
                        "{key}.scale: expected a positive number, found {scale}"
                    ));
                }
                let t = check_vec(&format!("{key}.translate"), s.translate.unwrap_or([0.0; 3]))?;
                mesh.transform(scale, t);
                if let Some(v) = mesh
                    .positions
                    .iter()
                    .find(|v| !v.iter().all(|x| x.is_finite()))
                {
                    return Err(format!(
                        "{key}: expected a shape whose vertices are finite in 32-bit floats (after any `scale` and `translate`), found a vertex at {v:?}"
                    ));
                }
                if s.flip {
                    mesh.flip();
                }
                if interior.is_some() {
                    mesh.check_closed_outward()
                        .map_err(|e| format!("{key}.interior: {e}"))?;
                }
                let (a, b) = mesh.bounds();
                lo = lo.min(a);
                hi = hi.max(b);
                let id = builder
                    .attach_triangles(&mesh.positions, &mesh.indices)
                    .map_err(|e| format!("{key}: {e}"))?;
                if let Some(em) = &emitter {
                    let area = lights
                        .add(id, em.clone(), &mesh.positions, &mesh.indices)
                        .map_err(|e| format!("{key}: {e}"))?;
                    power += check_power(&key, em, area)?;
                }
                geometries.push(Geometry {
                    name: if name.is_empty() {
                        key.clone()
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
        if geometries.is_empty() {
            return Err("shapes: the scene has no shapes".into());
        }
        if power > f64::from(f32::MAX) {
            return Err(format!(
                "shapes: expected lights whose total power is finite in 32-bit floats, found {power:.3e} (each is, their sum is not)"
            ));
        }
        if lights.is_empty() {
            self.warnings.push(
                "shapes: no shape has an `emission`: the scene has no light and renders black"
                    .into(),
            );
        }
        lights.finish();
        let accel = builder.commit().map_err(|e| e.to_string())?;
        Ok(Scene {
            path: self.file.to_path_buf(),
            accel,
            camera,
            render: d.render.clone(),
            materials,
            material_names,
            geometries,
            lights,
            media,
            medium_names,
            camera_medium,
            bounds: (lo, hi),
            warnings: self.warnings,
            regions,
        })
    }

    /// Checks an emitter's radiance × scale against [`MAX_RADIANCE`], naming the key that
    /// takes it over; warns of a light that emits nothing, and of a band too narrow to be
    /// found by wavelength samples.
    fn check_emitter(&mut self, key: &str, radiance: &Spectrum, scale: f32) -> Result<(), String> {
        let peak = radiance.max_value();
        if peak.is_nan() || peak > MAX_RADIANCE {
            return Err(format!(
                "{key}.emission.radiance: expected a spectral radiance ≤ {MAX_RADIANCE:e} W·sr⁻¹·m⁻²·nm⁻¹ (larger ones overflow 32-bit floats in a path's estimate), found a maximum of {peak:e}"
            ));
        }
        // In f32, as the renderer multiplies (the limit itself, 1e20 × 1e10, passes).
        let scaled = peak * scale;
        if scaled > MAX_RADIANCE {
            let scaled = f64::from(peak) * f64::from(scale);
            return Err(format!(
                "{key}.emission.scale: expected radiance × scale ≤ {MAX_RADIANCE:e} W·sr⁻¹·m⁻²·nm⁻¹ (larger ones overflow 32-bit floats in a path's estimate), found {peak:e} × {scale:e} = {scaled:.3e}"
            ));
        }
        if scaled == 0.0 {
            self.warnings.push(format!(
                "{key}.emission: radiance × scale is 0 over {}–{} nm: the light is black",
                spectrum::LAMBDA_MIN,
                spectrum::LAMBDA_MAX
            ));
        } else if let Some(fwhm) = narrowest_band(radiance).filter(|&w| w < 1.0) {
            self.warnings.push(format!(
                "{key}.emission.radiance: a band {fwhm:e} nm wide (fwhm) is rarely hit by the sampled wavelengths and is weighed on a 1 nm grid when lights are chosen: expect a noisy image (a band of a few nm has nearly the same colour)"
            ));
        }
        Ok(())
    }

    /// Resolves `[spectra].name` into [`Builder::spectra`]. An entry may name another
    /// entry (`sun = "lamp"`), which is resolved first, whatever the order of the file; a
    /// name that is not an entry is a CIE illuminant. A chain that comes back to where it
    /// started is an error listing it.
    fn named_spectrum(&mut self, name: &str) -> Result<(), String> {
        let d = self.desc;
        // Follow the chain of references to its first entry that is not a name of another
        // entry (or is resolved already), then resolve the chain from there back.
        let mut chain = vec![name];
        let mut last = name;
        while let Some(SpectrumDesc::Name(next)) = d.spectra.get(last) {
            if self.spectra.contains_key(last) || !d.spectra.contains_key(next) {
                break;
            }
            if let Some(start) = chain.iter().position(|n| n == next) {
                let mut cycle: Vec<&str> = chain[start..].to_vec();
                cycle.push(next);
                return Err(format!(
                    "spectra.{}: expected a spectrum or the name of one, found a cycle of references {}",
                    chain[start],
                    cycle.join(" → ")
                ));
            }
            chain.push(next);
            last = next;
        }
        for n in chain.into_iter().rev() {
            if !self.spectra.contains_key(n) {
                let spec = self.spectrum(&format!("spectra.{n}"), &d.spectra[n], None)?;
                self.spectra.insert(n.to_string(), spec);
            }
        }
        Ok(())
    }

    /// The `[[region]]` tables, checked against the camera's resolution.
    fn regions(&self) -> Result<Vec<Region>, String> {
        let res = self.desc.camera.resolution;
        let mut out: Vec<Region> = Vec::new();
        for (i, r) in self.desc.regions.iter().enumerate() {
            let key = format!("region[{i}]");
            let n = &r.name;
            if n.is_empty()
                || !n
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
            {
                return Err(format!(
                    "{key}.name: expected letters, digits, `-` and `_`, found {n:?}"
                ));
            }
            if n == "image" {
                return Err(format!(
                    "{key}.name: `image` is reserved for the whole image; choose another name"
                ));
            }
            if out.iter().any(|o| &o.name == n) {
                return Err(format!("{key}.name: another region is already named {n:?}"));
            }
            for (axis, what) in [(0, "x"), (1, "y")] {
                if r.min[axis] >= r.max[axis] {
                    return Err(format!(
                        "{key}: expected min < max, found {what} from {} to {}",
                        r.min[axis], r.max[axis]
                    ));
                }
                if r.max[axis] > res[axis] {
                    return Err(format!(
                        "{key}.max: expected a rectangle inside camera.resolution {:?} (pixels of the scene's own resolution), found {what} up to {}",
                        res, r.max[axis]
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

    fn medium(&self, key: &str, m: &desc::MediumDesc) -> Result<Homogeneous, String> {
        let coef = |k: &str, s: &SpectrumDesc| {
            self.spectrum(&format!("{key}.{k}"), s, Some(Range::NonNegative))
        };
        let (sigma_a, sigma_s) = match (&m.sigma_a, &m.sigma_s, &m.albedo, &m.sigma_t) {
            (a, s, None, None) => (
                a.as_ref()
                    .map(|a| coef("sigma_a", a))
                    .transpose()?
                    .unwrap_or(Spectrum::Constant(0.0)),
                s.as_ref()
                    .map(|s| coef("sigma_s", s))
                    .transpose()?
                    .unwrap_or(Spectrum::Constant(0.0)),
            ),
            (None, None, Some(al), Some(t)) => {
                let albedo = self.spectrum(&format!("{key}.albedo"), al, Some(Range::Unit))?;
                let sigma_t = coef("sigma_t", t)?;
                let sa = combine(&albedo, &sigma_t, |al, st| (1.0 - al) * st)?;
                let ss = combine(&albedo, &sigma_t, |al, st| al * st)?;
                (sa, ss)
            }
            _ => {
                return Err(format!(
                "{key}: expected `sigma_a` and/or `sigma_s`, or `albedo` together with `sigma_t`"
            ))
            }
        };
        let dense = |k: &str, s: &Spectrum| -> Result<(), String> {
            let max = s.max_value();
            if max > MAX_COEFFICIENT {
                return Err(format!(
                    "{key}.{k}: expected a coefficient ≤ {MAX_COEFFICIENT:e} per scene unit (denser is opaque at any scale and overflows 32-bit floats), found a maximum of {max:e}"
                ));
            }
            Ok(())
        };
        match (&m.sigma_a, &m.sigma_t) {
            (_, Some(_)) => dense("sigma_t", &combine(&sigma_a, &sigma_s, |a, s| a + s)?)?,
            _ => {
                dense("sigma_a", &sigma_a)?;
                dense("sigma_s", &sigma_s)?;
            }
        }
        let g = m.g.unwrap_or(0.0);
        if !(g.is_finite() && g > -1.0 && g < 1.0) {
            return Err(format!("{key}.g: expected a number in (−1, 1), found {g}"));
        }
        let dye = match &m.dye {
            None => None,
            Some(d) => {
                let a = coef("dye.absorption", &d.absorption)?;
                let e = self.spectrum(
                    &format!("{key}.dye.emission"),
                    &d.emission,
                    Some(Range::NonNegative),
                )?;
                let c = d.concentration.unwrap_or(1.0);
                if !(c.is_finite() && c > 0.0) {
                    // Zero too: a dye at zero concentration does nothing (like one that
                    // absorbs nothing, which `Reradiation::from_dye` rejects).
                    return Err(format!(
                        "{key}.dye.concentration: expected a positive number, found {c}"
                    ));
                }
                if c * a.max_value() > MAX_COEFFICIENT {
                    let peak = f64::from(c) * f64::from(a.max_value());
                    let k = if c == 1.0 {
                        "absorption"
                    } else {
                        "concentration"
                    };
                    return Err(format!(
                        "{key}.dye.{k}: expected concentration × absorption ≤ {MAX_COEFFICIENT:e} per scene unit (denser is opaque at any scale and overflows 32-bit floats), found {c:e} × {:e} = {peak:.3e}",
                        a.max_value()
                    ));
                }
                let cell = dye_params(key, d.quantum_yield, d.cell_nm)?;
                let absorption = if c == 1.0 {
                    a
                } else {
                    Spectrum::Scaled(Box::new(a), c)
                };
                Some((absorption, e, d.quantum_yield, cell))
            }
        };
        let medium = Homogeneous::new(sigma_a, sigma_s, HenyeyGreenstein::new(g));
        match dye {
            None => Ok(medium),
            Some((a, e, qy, cell)) => medium
                .with_dye(&a, &e, qy, cell)
                .map_err(|e| format!("{key}.dye: {e}")),
        }
    }

    fn resolve(&self, file: &str) -> PathBuf {
        self.base.join(file)
    }

    fn meshes(
        &self,
        key: &str,
        s: &desc::ShapeDesc,
    ) -> Result<Vec<(String, shapes::TriMesh)>, String> {
        let need3 = |k: &str, v: Option<[f32; 3]>| -> Result<Vec3, String> {
            let v = v.ok_or_else(|| format!("{key}: missing key `{k}` for a {} shape", s.kind))?;
            check_vec(&format!("{key}.{k}"), v)
        };
        let unused = |keys: &[(&str, bool)]| -> Result<(), String> {
            for (k, present) in keys {
                if *present {
                    return Err(format!("{key}.{k}: not a key of a {} shape", s.kind));
                }
            }
            Ok(())
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
        match s.kind.as_str() {
            "obj" => {
                unused(&quad_keys)?;
                unused(&box_keys)?;
                unused(&sphere_keys)?;
                let file = s
                    .file
                    .as_ref()
                    .ok_or_else(|| format!("{key}: missing key `file` for an obj shape"))?;
                let objs = obj::load_obj(&self.resolve(file)).map_err(|e| format!("{key}.file: {e}"))?;
                let names: Vec<String> = objs.iter().map(|o| o.name.clone()).collect();
                let picked: Vec<_> = objs
                    .into_iter()
                    .filter(|o| s.object.as_ref().is_none_or(|n| &o.name == n))
                    .map(|o| {
                        (
                            o.name,
                            shapes::TriMesh {
                                positions: o.positions,
                                indices: o.indices,
                            },
                        )
                    })
                    .collect();
                if picked.is_empty() {
                    return Err(format!(
                        "{key}.object: {file} has no object named {:?} (objects: {})",
                        s.object.as_deref().unwrap_or(""),
                        list(names.iter())
                    ));
                }
                Ok(picked)
            }
            "quad" => {
                unused(&obj_keys)?;
                unused(&box_keys)?;
                unused(&sphere_keys)?;
                let (o, u, v) = (
                    need3("origin", s.origin)?,
                    need3("edge_u", s.edge_u)?,
                    need3("edge_v", s.edge_v)?,
                );
                if u.cross(v).length_squared() == 0.0 {
                    return Err(format!("{key}: edge_u and edge_v must not be parallel or zero"));
                }
                Ok(vec![(String::new(), shapes::quad(o, u, v))])
            }
            "box" => {
                unused(&obj_keys)?;
                unused(&quad_keys)?;
                unused(&sphere_keys)?;
                let (a, b) = (need3("min", s.min)?, need3("max", s.max)?);
                if !(a.cmplt(b).all()) {
                    return Err(format!("{key}: expected min < max on every axis, found min {a} max {b}"));
                }
                Ok(vec![(String::new(), shapes::cuboid(a, b))])
            }
            "sphere" => {
                unused(&obj_keys)?;
                unused(&quad_keys)?;
                unused(&box_keys)?;
                let c = need3("center", s.center)?;
                let r = s
                    .radius
                    .ok_or_else(|| format!("{key}: missing key `radius` for a sphere shape"))?;
                if !(r.is_finite() && r > 0.0) {
                    return Err(format!("{key}.radius: expected a positive number, found {r}"));
                }
                let stacks = s.stacks.unwrap_or(64);
                let slices = s.slices.unwrap_or(2 * stacks);
                if !(2..=4096).contains(&stacks) || !(3..=8192).contains(&slices) {
                    return Err(format!(
                        "{key}: expected stacks in 2..=4096 and slices in 3..=8192, found {stacks} and {slices}"
                    ));
                }
                Ok(vec![(String::new(), shapes::uv_sphere(c, r, stacks, slices))])
            }
            other => Err(format!(
                "{key}.type: expected one of \"obj\", \"quad\", \"box\", \"sphere\", found {other:?}"
            )),
        }
    }

    fn material(&mut self, key: &str, m: &desc::MaterialDesc) -> Result<Material, String> {
        let no = |k: &str, present: bool| -> Result<(), String> {
            if present {
                Err(format!("{key}.{k}: not a key of a {} material", m.kind))
            } else {
                Ok(())
            }
        };
        if m.kind != "fluorescent_diffuse" {
            no("dye", m.dye.is_some())?;
            no("matrix", m.matrix.is_some())?;
        }
        match m.kind.as_str() {
            "diffuse" => {
                no("ior", m.ior.is_some())?;
                no("ext_ior", m.ext_ior.is_some())?;
                let r = m
                    .reflectance
                    .as_ref()
                    .ok_or_else(|| format!("{key}: missing key `reflectance` for a diffuse material"))?;
                Ok(Material::Diffuse {
                    reflectance: self.spectrum(&format!("{key}.reflectance"), r, Some(Range::Unit))?,
                })
            }
            "mirror" => {
                no("ior", m.ior.is_some())?;
                no("ext_ior", m.ext_ior.is_some())?;
                let reflectance = match &m.reflectance {
                    Some(r) => self.spectrum(&format!("{key}.reflectance"), r, Some(Range::Unit))?,
                    None => Spectrum::Constant(1.0),
                };
                Ok(Material::Mirror { reflectance })
            }
            "dielectric" => {
                no("reflectance", m.reflectance.is_some())?;
                let ior = m
                    .ior
                    .as_ref()
                    .ok_or_else(|| format!("{key}: missing key `ior` for a dielectric material"))?;
                let ior = ior_from(&format!("{key}.ior"), ior)?;
                let ext_ior = m.ext_ior.unwrap_or(1.0);
                if !(ext_ior.is_finite() && ext_ior >= 1.0) {
                    return Err(format!("{key}.ext_ior: expected a number ≥ 1, found {ext_ior}"));
                }
                Ok(Material::Dielectric { ior, ext_ior })
            }
            "fluorescent_diffuse" => {
                no("ior", m.ior.is_some())?;
                no("ext_ior", m.ext_ior.is_some())?;
                let diagonal = match &m.reflectance {
                    Some(r) => Some(self.spectrum(&format!("{key}.reflectance"), r, Some(Range::Unit))?),
                    None => None,
                };
                let rr = match (&m.dye, &m.matrix) {
                    (Some(d), None) => {
                        let diagonal = diagonal.ok_or_else(|| {
                            format!("{key}: missing key `reflectance` (the surface's ordinary reflectance) next to `dye`")
                        })?;
                        let a = self.spectrum(&format!("{key}.dye.absorption"), &d.absorption, Some(Range::Unit))?;
                        let e = self.spectrum(&format!("{key}.dye.emission"), &d.emission, Some(Range::NonNegative))?;
                        let cell = dye_params(key, d.quantum_yield, d.cell_nm)?;
                        Reradiation::from_dye(diagonal, &a, &e, d.quantum_yield, cell)
                            .map_err(|e| format!("{key}.dye: {e}"))?
                    }
                    (None, Some(file)) => {
                        let path = self.resolve(file);
                        let (mut rr, report) =
                            Reradiation::from_csv(&path).map_err(|e| format!("{key}.matrix: {e}"))?;
                        let clamped = report.clamped_negative + report.clamped_anti_stokes;
                        if clamped > 0 {
                            self.warnings.push(format!(
                                "{key}.matrix: {}: set {} negative and {} anti-Stokes (emission ≤ excitation) entries to zero",
                                path.display(),
                                report.clamped_negative,
                                report.clamped_anti_stokes
                            ));
                        }
                        if let Some(d) = diagonal {
                            rr = rr.with_diagonal(d);
                        }
                        rr
                    }
                    _ => {
                        return Err(format!(
                            "{key}: expected exactly one of `dye = {{ ... }}` or `matrix = \"file.csv\"` for a fluorescent_diffuse material"
                        ))
                    }
                };
                for (l, total) in rr.energy_gain_rows() {
                    self.warnings.push(format!(
                        "{key}: re-radiation at {l} nm totals {total:.3} > 1 (the surface creates energy there)"
                    ));
                }
                Ok(Material::FluorescentDiffuse {
                    reradiation: std::sync::Arc::new(rr),
                })
            }
            other => Err(format!(
                "{key}.type: expected one of \"diffuse\", \"mirror\", \"dielectric\", \"fluorescent_diffuse\", found {other:?}"
            )),
        }
    }

    /// Turns a spectrum description into a spectrum, checking its values against `range`.
    fn spectrum(
        &self,
        key: &str,
        s: &SpectrumDesc,
        range: Option<Range>,
    ) -> Result<Spectrum, String> {
        let spec = match s {
            SpectrumDesc::Constant(v) => Spectrum::Constant(*v as f32),
            SpectrumDesc::Name(n) => {
                if let Some(sp) = self.spectra.get(n) {
                    sp.clone()
                } else if let Some(sp) = spectrum::illuminant(n) {
                    sp
                } else {
                    return Err(format!(
                        "{key}: no spectrum named {n:?} (named spectra: {}; illuminants: D65, A, F2, F11)",
                        list(self.desc.spectra.keys())
                    ));
                }
            }
            SpectrumDesc::Table(t) => self.spectrum_table(key, t)?,
        };
        check_range(key, &spec, range)?;
        Ok(spec)
    }

    fn spectrum_table(&self, key: &str, t: &desc::SpectrumTable) -> Result<Spectrum, String> {
        let kinds = [
            ("constant", t.constant.is_some()),
            ("blackbody", t.blackbody.is_some()),
            ("illuminant", t.illuminant.is_some()),
            ("csv", t.csv.is_some()),
            ("wavelengths", t.wavelengths.is_some()),
            ("narrow_band", t.narrow_band.is_some()),
        ];
        let given: Vec<&str> = kinds.iter().filter(|k| k.1).map(|k| k.0).collect();
        if given.len() != 1 {
            return Err(format!(
                "{key}: expected exactly one of constant, blackbody, illuminant, csv, wavelengths, narrow_band; found {}",
                if given.is_empty() { "none".to_string() } else { given.join(", ") }
            ));
        }
        let stray = |k: &str, present: bool, with: &str| -> Result<(), String> {
            if present && given[0] != with {
                Err(format!("{key}.{k}: only allowed together with `{with}`"))
            } else {
                Ok(())
            }
        };
        stray("normalise", t.normalise.is_some(), "blackbody")?;
        stray("column", t.column.is_some(), "csv")?;
        stray("values", t.values.is_some(), "wavelengths")?;
        stray("fwhm", t.fwhm.is_some(), "narrow_band")?;
        let spec = match given[0] {
            "constant" => Spectrum::Constant(t.constant.unwrap_or(0.0)),
            "blackbody" => {
                let k = t.blackbody.unwrap_or(0.0);
                if !(k.is_finite() && k > 0.0) {
                    return Err(format!(
                        "{key}.blackbody: expected a temperature in kelvin > 0, found {k}"
                    ));
                }
                let normalise = t.normalise.unwrap_or(true);
                let peak = spectrum::blackbody_peak_value(k);
                if normalise && !(peak.is_finite() && peak > 0.0) {
                    return Err(format!(
                        "{key}.blackbody: expected a temperature whose peak radiance, which normalises it, is a finite non-zero 32-bit number, found {k:e} K (peak {peak:e} W·sr⁻¹·m⁻²·nm⁻¹)"
                    ));
                }
                Spectrum::Blackbody {
                    kelvin: k,
                    normalise,
                }
            }
            "illuminant" => {
                let n = t.illuminant.as_deref().unwrap_or("");
                spectrum::illuminant(n).ok_or_else(|| {
                    format!("{key}.illuminant: expected one of D65, A, F2, F11, found {n:?}")
                })?
            }
            "csv" => {
                let file = t.csv.as_deref().unwrap_or("");
                let tab = spectrum::csv_column(&self.resolve(file), t.column.as_deref())
                    .map_err(|e| format!("{key}.csv: {e}"))?;
                Spectrum::Tabulated(tab)
            }
            "wavelengths" => {
                let w = t.wavelengths.clone().unwrap_or_default();
                let v = t
                    .values
                    .clone()
                    .ok_or_else(|| format!("{key}: missing key `values` next to `wavelengths`"))?;
                Spectrum::Tabulated(Tabulated::new(w, v).map_err(|e| format!("{key}: {e}"))?)
            }
            "narrow_band" => {
                let c = t.narrow_band.unwrap_or(0.0);
                let w = t
                    .fwhm
                    .ok_or_else(|| format!("{key}: missing key `fwhm` next to `narrow_band`"))?;
                if !(c.is_finite() && c > 0.0 && w.is_finite() && w > 0.0) {
                    return Err(format!(
                        "{key}: expected a positive centre and full width at half maximum (nm), found {c} and {w}"
                    ));
                }
                Spectrum::NarrowBand { centre: c, fwhm: w }
            }
            _ => unreachable!(),
        };
        Ok(match t.scale {
            Some(s) if !(s.is_finite() && s >= 0.0) => {
                return Err(format!(
                    "{key}.scale: expected a non-negative number, found {s}"
                ))
            }
            Some(s) if s != 1.0 => Spectrum::Scaled(Box::new(spec), s),
            _ => spec,
        })
    }
}

fn check_range(key: &str, spec: &Spectrum, range: Option<Range>) -> Result<(), String> {
    let Some(range) = range else { return Ok(()) };
    // Check on a 1 nm grid over the rendered range (tabulated data is checked where it
    // matters: the wavelengths the renderer can sample).
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    let mut at = (0.0, 0.0);
    for i in 0..=470 {
        let l = spectrum::LAMBDA_MIN + i as f32;
        let v = spec.eval(l);
        if !v.is_finite() {
            return Err(format!(
                "{key}: expected finite values, found {v} at {l} nm"
            ));
        }
        if v < lo {
            lo = v;
            at.0 = l;
        }
        if v > hi {
            hi = v;
            at.1 = l;
        }
    }
    // The grid can step over a band narrower than 1 nm: its analytic maximum cannot.
    let max = spec.max_value();
    if !max.is_finite() {
        return Err(format!(
            "{key}: expected finite values, found a maximum of {max}"
        ));
    }
    if max > hi {
        hi = max;
        at.1 = f32::NAN;
    }
    if lo < 0.0 {
        let what = match range {
            Range::Unit => "a reflectance in [0, 1]",
            Range::NonNegative => {
                if key.contains("emission.radiance") {
                    "a non-negative radiance"
                } else {
                    "non-negative values"
                }
            }
        };
        return Err(format!("{key}: expected {what}, found {lo} at {} nm", at.0));
    }
    if matches!(range, Range::Unit) && hi > 1.0 + 1e-6 {
        let at = if at.1.is_nan() {
            "as its maximum".to_string()
        } else {
            format!("at {} nm", at.1)
        };
        return Err(format!(
            "{key}: expected a reflectance in [0, 1], found {hi} {at} (energy would be created)"
        ));
    }
    Ok(())
}

fn ior_from(key: &str, d: &IorDesc) -> Result<Ior, String> {
    let ior = match d {
        IorDesc::Constant(n) => Ior::Constant(*n as f32),
        IorDesc::Table(t) => match (&t.cauchy, &t.sellmeier) {
            (Some([a, b]), None) => Ior::Cauchy { a: *a, b: *b },
            (None, Some(s)) => Ior::Sellmeier { b: s.b, c: s.c },
            _ => {
                return Err(format!(
                    "{key}: expected exactly one of `cauchy = [A, B]` or `sellmeier = {{ b = [..], c = [..] }}`"
                ))
            }
        },
    };
    for l in [spectrum::LAMBDA_MIN, 550.0, spectrum::LAMBDA_MAX] {
        let n = ior.eval(l);
        if !(n.is_finite() && n >= 1.0) {
            return Err(format!(
                "{key}: expected an index ≥ 1 over 360–830 nm, found {n} at {l} nm"
            ));
        }
    }
    Ok(ior)
}

/// Checks a dye's quantum yield and grid cell width; returns the cell width (default 2 nm).
fn dye_params(key: &str, quantum_yield: f32, cell_nm: Option<f32>) -> Result<f32, String> {
    if !(0.0..=1.0).contains(&quantum_yield) {
        return Err(format!(
            "{key}.dye.quantum_yield: expected a number in [0, 1], found {quantum_yield}"
        ));
    }
    let cell = cell_nm.unwrap_or(2.0);
    if !(cell.is_finite() && (0.5..=50.0).contains(&cell)) {
        return Err(format!(
            "{key}.dye.cell_nm: expected a width in [0.5, 50] nm, found {cell}"
        ));
    }
    Ok(cell)
}

/// A message on one line: control characters (say, a newline in a file name) escaped.
fn one_line(msg: &str) -> String {
    msg.chars()
        .flat_map(|c| {
            if c.is_control() {
                c.escape_default().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}

/// `f(a, b)` as a spectrum: exact for two constants, otherwise tabulated every nanometre
/// over the rendered range.
fn combine(a: &Spectrum, b: &Spectrum, f: impl Fn(f32, f32) -> f32) -> Result<Spectrum, String> {
    if let (Some(x), Some(y)) = (a.is_constant(), b.is_constant()) {
        return Ok(Spectrum::Constant(f(x, y)));
    }
    let w: Vec<f32> = (0..=470).map(|i| spectrum::LAMBDA_MIN + i as f32).collect();
    let v: Vec<f32> = w.iter().map(|&l| f(a.eval(l), b.eval(l))).collect();
    Ok(Spectrum::Tabulated(Tabulated::new(w, v)?))
}

fn list<'a>(names: impl Iterator<Item = &'a String>) -> String {
    let v: Vec<&str> = names.map(|s| s.as_str()).collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}
