//! Wavefront OBJ loading through tobj: triangulated, one mesh per object (`o`/`g` name kept),
//! positions only.
//!
//! tobj reports malformed input without line numbers, so a first pass checks the `v` and
//! `f` lines itself and names the line; tobj then does the real parse.

use crate::error::{Detail, Error};
use crate::Result;
use std::path::Path;

/// One object of an OBJ file as triangles.
#[derive(Debug, Clone)]
pub struct ObjMesh {
    /// The object's name (`o` or `g`), or `""` when the file has none.
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Triangles as indices into `positions`.
    pub indices: Vec<[u32; 3]>,
}

/// Loads every object of `path`. Errors name the file, the line and what was expected.
pub fn load_obj(path: &Path) -> Result<Vec<ObjMesh>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::file(path, None, format!("cannot read OBJ file: {e}")))?;
    validate(path, &text)?;
    // Positions only: with `single_index: false` tobj keeps the position indices as they
    // are (no re-indexing map, no vertices duplicated where normals or texture
    // coordinates differ).
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = std::io::BufReader::new(text.as_bytes());
    // Materials are the scene file's business; ignore .mtl references.
    let (models, _) =
        tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed))
            .map_err(|e| Error::file(path, None, format!("malformed OBJ file: {e}")))?;
    drop(reader);
    drop(text); // the models own their data: free the file's text before converting
    let mut out = Vec::with_capacity(models.len());
    for m in models {
        let mesh = m.mesh;
        let positions: Vec<[f32; 3]> = mesh
            .positions
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect();
        let indices: Vec<[u32; 3]> = mesh
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        if indices.is_empty() {
            continue;
        }
        out.push(ObjMesh {
            name: m.name,
            positions,
            indices,
        });
    }
    if out.is_empty() {
        return Err(Error::file(path, None, "the OBJ file has no faces"));
    }
    Ok(out)
}

/// Checks vertex and face lines, naming the first bad one.
fn validate(path: &Path, text: &str) -> Result<()> {
    let mut nv: i64 = 0;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        let lineno = i + 1;
        let mut words = line.split_whitespace();
        let Some(tag) = words.next() else { continue };
        let err = |expected: &str| {
            Error::file(
                path,
                Some(lineno),
                Detail::expected(expected, format!("{:?}", raw.trim())),
            )
        };
        match tag {
            "v" => {
                let vals: Vec<&str> = words.collect();
                if vals.len() < 3 || vals.len() > 7 {
                    return Err(err("a vertex `v x y z`"));
                }
                for v in &vals[..3] {
                    match v.parse::<f32>() {
                        Ok(x) if x.is_finite() => {}
                        _ => return Err(err("three finite numbers after `v`")),
                    }
                }
                nv += 1;
            }
            "f" => {
                let refs: Vec<&str> = words.collect();
                if refs.len() < 3 {
                    return Err(err("a face with at least three vertices"));
                }
                for r in refs {
                    let first = r.split('/').next().unwrap_or("");
                    let idx: i64 = first
                        .parse()
                        .map_err(|_| err("vertex indices (integers) in the face"))?;
                    let resolved = if idx < 0 { nv + idx + 1 } else { idx };
                    if idx == 0 || resolved < 1 || resolved > nv {
                        return Err(Error::file(
                            path,
                            Some(lineno),
                            format!(
                                "face index {idx} is out of range (1..={nv} vertices defined so far)"
                            ),
                        ));
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("stokes-obj-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn loads_quads_triangulated_with_names() {
        let p = write(
            "two.obj",
            "o first\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\no second\nv 0 0 1\nv 1 0 1\nv 1 1 1\nf -3 -2 -1\n",
        );
        let m = load_obj(&p).unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!(m[0].name, "first");
        assert_eq!(m[0].indices.len(), 2);
        assert_eq!(m[1].name, "second");
        assert_eq!(m[1].indices.len(), 1);
    }

    #[test]
    fn errors_name_file_and_line() {
        let p = write("bad.obj", "v 0 0 0\nv 1 0 0\nv 1 x 0\nf 1 2 3\n");
        let e = load_obj(&p).unwrap_err().to_string();
        assert!(e.contains("bad.obj:3"), "{e}");
        let p = write("range.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 4\n");
        let e = load_obj(&p).unwrap_err().to_string();
        assert!(
            e.contains("range.obj:4") && e.contains("out of range"),
            "{e}"
        );
        let e = load_obj(Path::new("/nonexistent/x.obj"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("/nonexistent/x.obj") && e.contains("cannot read"),
            "{e}"
        );
    }
}
