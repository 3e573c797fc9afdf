//! What a kind's parser ([`crate::bsdf::Material::from_desc`],
//! [`crate::medium::Homogeneous::from_desc`], [`crate::light::Emitter::from_desc`],
//! [`super::shapes::meshes`], [`crate::spectrum::Spectrum::from_desc`]) needs from the
//! rest of the scene file: the named spectra, the directory relative file names start
//! from, and a place for warnings.

use crate::error::Key;
use crate::spectrum::Spectrum;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The state of a scene file being loaded, shared by the parsers of its parts.
#[derive(Debug, Default)]
pub struct Context {
    /// The directory of the scene file: relative file names start here.
    base: PathBuf,
    /// The `[spectra]` entries resolved so far, by name.
    spectra: BTreeMap<String, Spectrum>,
    /// The names of every `[spectra]` entry, for messages.
    spectrum_names: Vec<String>,
    /// Things worth telling the user that are not errors, each `key: what`.
    warnings: Vec<String>,
}

impl Context {
    /// A context for a scene file in directory `base` whose `[spectra]` has `names`.
    pub fn new(base: &Path, names: Vec<String>) -> Context {
        Context {
            base: base.to_path_buf(),
            spectrum_names: names,
            ..Context::default()
        }
    }

    /// A file named in the scene, relative to the scene file's directory.
    pub fn resolve(&self, file: &str) -> PathBuf {
        self.base.join(file)
    }

    /// The named spectrum `name`, if resolved.
    pub fn named(&self, name: &str) -> Option<&Spectrum> {
        self.spectra.get(name)
    }

    /// Whether `name` is resolved.
    pub fn has_named(&self, name: &str) -> bool {
        self.spectra.contains_key(name)
    }

    /// Records the named spectrum `name`.
    pub fn add_named(&mut self, name: &str, spectrum: Spectrum) {
        self.spectra.insert(name.to_string(), spectrum);
    }

    /// The names of every `[spectra]` entry, `a, b` (or `none`).
    pub fn spectrum_names(&self) -> String {
        list(self.spectrum_names.iter())
    }

    /// A warning about the value at `key`.
    pub fn warn(&mut self, key: &Key, what: impl std::fmt::Display) {
        self.warnings.push(format!("{key}: {what}"));
    }

    /// The warnings so far, in order.
    pub fn into_warnings(self) -> Vec<String> {
        self.warnings
    }
}

/// `a, b, c`, or `none`: names for messages.
pub fn list<'a>(names: impl Iterator<Item = &'a String>) -> String {
    let v: Vec<&str> = names.map(|s| s.as_str()).collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

/// Fails with `not a key of a {kind} {what}` for the first key in `keys` that is present:
/// a key that belongs to another kind of material, shape or spectrum.
pub fn reject_keys(
    key: &Key,
    kind: &str,
    what: &str,
    keys: &[(&str, bool)],
) -> Result<(), crate::error::KeyError> {
    match keys.iter().find(|(_, present)| *present) {
        Some((k, _)) => Err(key.field(k).error(format!("not a key of a {kind} {what}"))),
        None => Ok(()),
    }
}
