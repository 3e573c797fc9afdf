//! `stokes info`: what a scene holds and which methods a render of it will use.

use super::Scene;
use crate::method::{default_tracking, Axis};
use std::fmt::Write as _;

impl Scene {
    /// A report of the scene: camera and render defaults, meshes, lights, materials, and
    /// what the spectral, fluorescence, media and region settings will do.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let mut line = |text: String| {
            s.push_str(&text);
            s.push('\n');
        };
        line(format!("scene       {}", self.path.display()));
        line(format!(
            "camera      {}x{}, render defaults: {} spp, max depth {}, seed {}",
            self.camera.width,
            self.camera.height,
            self.render.spp,
            self.render.max_depth,
            self.render.seed
        ));
        line(format!(
            "geometry    {} meshes, {} triangles",
            self.geometries.len(),
            self.triangle_count()
        ));
        for g in &self.geometries {
            let m = g
                .material
                .map(|m| self.material_names[m as usize].as_str())
                .unwrap_or("(none)");
            line(format!(
                "  {:<40} {:>8} triangles  material {m}",
                g.name, g.triangles
            ));
        }
        line(self.lights_line());
        line(format!("materials   {}", self.material_names.join(", ")));
        line(self.textures_line());
        line(format!(
            "spectral    hwss (4 wavelengths per path){}{}",
            if self.has_dispersion() {
                "; a dispersive dielectric splits the 4 wavelengths: --dispersion drop keeps the hero only, --dispersion split continues all four as single-wavelength paths"
            } else {
                ""
            },
            if self.has_rough_dispersion() {
                "; a dispersive rough dielectric keeps all 4 (each wavelength its own BTDF and pdf; --dispersion does not apply to it)"
            } else {
                ""
            }
        ));
        line(self.fluorescence_line());
        line(self.media_line());
        if self.regions.is_empty() {
            line("regions     none (stokes converge measures the whole image)".into());
        }
        for r in &self.regions {
            line(format!(
                "region      {}: pixels [{}, {}) x [{}, {}) of {}x{} (stokes converge reports it)",
                r.name, r.min[0], r.max[0], r.min[1], r.max[1], r.resolution[0], r.resolution[1]
            ));
        }
        s
    }

    /// The textures: each image's size and memory, and the checkerboards.
    fn textures_line(&self) -> String {
        use crate::bsdf::Material;
        let image = |name: &str, file: &str, w: usize, h: usize, bytes: usize| {
            format!("{name}: {file} ({w}x{h}, {:.1} KiB)", bytes as f64 / 1024.0)
        };
        let scalar = |what: String, t: &crate::texture::scalar::ScalarTexture| match t.image() {
            Some(img) => Some(image(&what, &img.file, img.width, img.height, img.memory())),
            None => t.varies().then(|| format!("{what}: a checkerboard")),
        };
        let mut items = Vec::new();
        for (m, name) in self.materials.iter().zip(&self.material_names) {
            let (texture, strength, alpha) = match m {
                Material::TexturedDiffuse { texture } | Material::TexturedMirror { texture } => {
                    (Some(texture.as_ref()), None, None)
                }
                Material::FluorescentDiffuse { map: Some(map), .. } => {
                    (map.diagonal.as_ref(), Some(&map.strength), None)
                }
                Material::Coated(c) => match c.map() {
                    Some(map) => (map.diagonal.as_ref(), Some(&map.strength), None),
                    None => continue,
                },
                Material::RoughDielectric { alpha_map, .. }
                | Material::Conductor { alpha_map, .. } => (None, None, alpha_map.as_deref()),
                _ => continue,
            };
            match texture.map(|t| t.image()) {
                Some(Some(img)) => {
                    items.push(image(name, &img.file, img.width, img.height, img.memory()))
                }
                Some(None) => items.push(format!("{name}: a checkerboard")),
                None => {}
            }
            items.extend(strength.and_then(|s| scalar(format!("{name} dye strength"), s)));
            items.extend(alpha.and_then(|a| scalar(format!("{name} roughness"), a)));
        }
        if let Some(map) = self.lights.environment_map() {
            items.push(format!(
                "environment map ({}x{}, {:.1} KiB)",
                map.width,
                map.height,
                map.memory() as f64 / 1024.0
            ));
        }
        match items.is_empty() {
            true => "textures    none".into(),
            false => format!("textures    {}", items.join("; ")),
        }
    }

    /// The lights by kind.
    fn lights_line(&self) -> String {
        use crate::light::DeltaKind;
        let l = &self.lights;
        let shapes = l.emitters.len() - l.delta.len() - usize::from(l.environment.is_some());
        let mut kinds = Vec::new();
        if shapes > 0 {
            kinds.push(format!("{shapes} area ({} triangles)", l.triangles.len()));
        }
        let count = |f: fn(&DeltaKind) -> bool| l.delta.iter().filter(|d| f(&d.kind)).count();
        for (n, what) in [
            (count(|k| matches!(k, DeltaKind::Point { .. })), "point"),
            (count(|k| matches!(k, DeltaKind::Spot { .. })), "spot"),
            (
                count(|k| matches!(k, DeltaKind::Directional { .. })),
                "directional",
            ),
        ] {
            if n > 0 {
                kinds.push(format!("{n} {what}"));
            }
        }
        match l.environment.as_ref().map(|e| e.map.is_some()) {
            Some(true) => kinds.push("1 environment map".into()),
            Some(false) => kinds.push("1 constant environment".into()),
            None => {}
        }
        if kinds.is_empty() {
            kinds.push("none".into());
        }
        format!("lights      {}", kinds.join(", "))
    }

    fn fluorescence_line(&self) -> String {
        let where_ = match (self.has_fluorescence(), self.has_fluorescent_media()) {
            (false, false) => {
                return "fluorescence none: plain HWSS, no shift sampling (--shifting has no effect)".into()
            }
            (true, true) => "surfaces and media",
            (true, false) => "surfaces",
            (false, true) => "media",
        };
        format!("fluorescence yes ({where_}): fluorescent HWSS, --shifting independent (default) or constant; --spectral mono for one wavelength per path")
    }

    fn media_line(&self) -> String {
        if !self.has_media() {
            return "media       none: no distance tracking".into();
        }
        let (t, why) = default_tracking(self);
        let mut s = String::new();
        let _ = write!(
            s,
            "media       {} ({}); default tracking {}: {why}",
            self.medium_names.join(", "),
            if self.has_fluorescent_media() {
                "fluorescent"
            } else {
                "not fluorescent"
            },
            t.name()
        );
        s
    }
}
