//! Wavefront OBJ loading through tobj: triangulated, one mesh per object (`o`/`g` name
//! kept), with per-vertex normals (`vn`) and texture coordinates (`vt`) where the faces
//! reference them.
//!
//! tobj reports malformed input without line numbers, so a first pass checks the `v`,
//! `vn`, `vt` and `f` lines itself and names the line; tobj then does the real parse.
//!
//! A file whose faces reference neither normals nor texture coordinates is read exactly
//! as before they were supported (the same tobj options: positions only), so existing
//! scenes keep their meshes bit for bit. Otherwise tobj makes one vertex per distinct
//! `v/vt/vn` triple (`single_index`). Normals and texture coordinates are
//! all or nothing per file: if one face vertex references a `vn` (or a `vt`), every face
//! vertex of the file must, and the first that does not is an error naming its line.
//! Interpolating a normal that some vertices lack has no meaning, and guessing one (the
//! face normal) would hide a broken export.

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
    /// Per-vertex normals (indexed like `positions`), if the faces reference `vn`s and
    /// they were asked for.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per-vertex texture coordinates `(u, v)`, if the faces reference `vt`s.
    pub uvs: Option<Vec<[f32; 2]>>,
}

/// Loads every object of `path`; `normals: false` ignores the faces' `vn` references
/// (flat shading: they are neither checked for consistency nor read). Errors name the
/// file, the line and what was expected.
pub fn load_obj(path: &Path, normals: bool) -> Result<Vec<ObjMesh>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::file(path, None, format!("cannot read OBJ file: {e}")))?;
    let refs = validate(path, &text, normals)?;
    let normals = normals && refs.vn;
    // Without normals or texture coordinates: the options of the loader before they were
    // read (one vertex per position used), so that such files give the same meshes.
    let single_index = normals || refs.vt;
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index,
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
        // The validating pass makes every vertex carry a normal (texture coordinate) or
        // none; a count that still differs from the positions' is refused, not guessed.
        let per_vertex = |what: &str, n: usize| {
            Error::file(
                path,
                None,
                format!(
                    "object {:?} has {n} {what} for {} vertices after re-indexing",
                    m.name,
                    positions.len()
                ),
            )
        };
        let normals = match normals {
            false => None,
            true if mesh.normals.len() == mesh.positions.len() => Some(
                mesh.normals
                    .chunks_exact(3)
                    .map(|n| [n[0], n[1], n[2]])
                    .collect(),
            ),
            true => return Err(per_vertex("normals", mesh.normals.len() / 3)),
        };
        let uvs = match refs.vt {
            false => None,
            true if mesh.texcoords.len() / 2 == positions.len() => Some(
                mesh.texcoords
                    .chunks_exact(2)
                    .map(|t| [t[0], t[1]])
                    .collect(),
            ),
            true => return Err(per_vertex("texture coordinates", mesh.texcoords.len() / 2)),
        };
        out.push(ObjMesh {
            name: m.name,
            positions,
            indices,
            normals,
            uvs,
        });
    }
    if out.is_empty() {
        return Err(Error::file(path, None, "the OBJ file has no faces"));
    }
    Ok(out)
}

/// Whether the faces of a file reference texture coordinates and normals.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Refs {
    vt: bool,
    vn: bool,
}

/// Checks vertex, normal, texture coordinate and face lines, naming the first bad one;
/// returns what the faces reference. With `normals: false` a face's normal indices are
/// not looked at.
fn validate(path: &Path, text: &str, normals: bool) -> Result<Refs> {
    // Counts of `v`, `vt` and `vn` lines so far (face indices refer back to them).
    let (mut nv, mut nvt, mut nvn): (i64, i64, i64) = (0, 0, 0);
    // What the first face vertex referenced, and its line: every other must match.
    let mut first: Option<(Refs, usize)> = None;
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
        let finite = |vals: &[&str]| {
            vals.iter()
                .all(|v| v.parse::<f32>().is_ok_and(|x| x.is_finite()))
        };
        match tag {
            "v" => {
                let vals: Vec<&str> = words.collect();
                if vals.len() < 3 || vals.len() > 7 {
                    return Err(err("a vertex `v x y z`"));
                }
                if !finite(&vals[..3]) {
                    return Err(err("three finite numbers after `v`"));
                }
                nv += 1;
            }
            "vn" => {
                let vals: Vec<&str> = words.collect();
                if vals.len() != 3 || !finite(&vals) {
                    return Err(err("a normal `vn x y z` of three finite numbers"));
                }
                nvn += 1;
            }
            "vt" => {
                let vals: Vec<&str> = words.collect();
                if !(2..=3).contains(&vals.len()) || !finite(&vals) {
                    return Err(err(
                        "texture coordinates `vt u v` (or `vt u v w`) of finite numbers",
                    ));
                }
                nvt += 1;
            }
            "f" => {
                let refs: Vec<&str> = words.collect();
                if refs.len() < 3 {
                    return Err(err("a face with at least three vertices"));
                }
                for r in refs {
                    let parts: Vec<&str> = r.split('/').collect();
                    if parts.len() > 3 {
                        return Err(err("face vertices `v`, `v/vt`, `v/vt/vn` or `v//vn`"));
                    }
                    let index = |part: usize, what: &str, n: i64| -> Result<bool> {
                        let Some(s) = parts.get(part).filter(|s| !s.is_empty()) else {
                            return Ok(false);
                        };
                        let idx: i64 = s
                            .parse()
                            .map_err(|_| err(&format!("{what} indices (integers) in the face")))?;
                        let resolved = if idx < 0 { n + idx + 1 } else { idx };
                        if idx == 0 || resolved < 1 || resolved > n {
                            return Err(Error::file(
                                path,
                                Some(lineno),
                                format!(
                                    "face {what} index {idx} is out of range (1..={n} defined so far)"
                                ),
                            ));
                        }
                        Ok(true)
                    };
                    if !index(0, "vertex", nv)? {
                        return Err(err("vertex indices (integers) in the face"));
                    }
                    let has = Refs {
                        vt: index(1, "texture coordinate", nvt)?,
                        vn: normals && index(2, "normal", nvn)?,
                    };
                    match first {
                        None => first = Some((has, lineno)),
                        Some((want, at)) if want != has => {
                            let (tag, lacks, hint) = match want.vn != has.vn {
                                true => (
                                    "vn",
                                    !has.vn,
                                    " (or set `smooth = false` in the scene to ignore the normals)",
                                ),
                                false => ("vt", !has.vt, ""),
                            };
                            let (this, that) = match lacks {
                                true => ("has no", "has one"),
                                false => ("has a", "has none"),
                            };
                            return Err(Error::file(
                                path,
                                Some(lineno),
                                format!(
                                    "face vertex `{r}` {this} `{tag}` index but the face at line {at} {that}: every face vertex of the file must reference a `{tag}`, or none must{hint}"
                                ),
                            ));
                        }
                        Some(_) => {}
                    }
                }
            }
            _ => {}
        }
    }
    Ok(first.map(|(r, _)| r).unwrap_or_default())
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
        let m = load_obj(&p, true).unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!(m[0].name, "first");
        assert_eq!(m[0].indices.len(), 2);
        assert_eq!(m[1].name, "second");
        assert_eq!(m[1].indices.len(), 1);
    }

    #[test]
    fn errors_name_file_and_line() {
        let p = write("bad.obj", "v 0 0 0\nv 1 0 0\nv 1 x 0\nf 1 2 3\n");
        let e = load_obj(&p, true).unwrap_err().to_string();
        assert!(e.contains("bad.obj:3"), "{e}");
        let p = write("range.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 4\n");
        let e = load_obj(&p, true).unwrap_err().to_string();
        assert!(
            e.contains("range.obj:4") && e.contains("out of range"),
            "{e}"
        );
        let e = load_obj(Path::new("/nonexistent/x.obj"), true)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("/nonexistent/x.obj") && e.contains("cannot read"),
            "{e}"
        );
    }

    #[test]
    fn normals_and_texture_coordinates_are_per_vertex() {
        // A quad whose corners share positions with different normals in two faces.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nvn 0 0.6 0.8\n\
                    f 1/1/1 2/2/1 3/3/2\nf 1/1/1 3/3/2 4/4/2\n";
        let p = write("smooth.obj", text);
        let m = &load_obj(&p, true).unwrap()[0];
        let (n, t) = (m.normals.as_ref().unwrap(), m.uvs.as_ref().unwrap());
        assert_eq!(n.len(), m.positions.len());
        assert_eq!(t.len(), m.positions.len());
        for (k, &[a, b, c]) in m.indices.iter().enumerate() {
            for i in [a, b, c] {
                let (p, n, t) = (m.positions[i as usize], n[i as usize], t[i as usize]);
                // Each corner's texture coordinates are its position's x and y here, and
                // its normal the one its face gave it.
                assert_eq!(t, [p[0], p[1]], "triangle {k}");
                let want = if p == [1.0, 1.0, 0.0] || p == [0.0, 1.0, 0.0] {
                    [0.0, 0.6, 0.8]
                } else {
                    [0.0, 0.0, 1.0]
                };
                assert_eq!(n, want, "triangle {k} corner {p:?}");
            }
        }
        // `f v//vn`: normals without texture coordinates; `normals: false` drops them.
        let p = write(
            "vn.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",
        );
        let m = &load_obj(&p, true).unwrap()[0];
        assert_eq!(m.normals.as_deref(), Some(&[[0.0, 0.0, 1.0]; 3][..]));
        assert!(m.uvs.is_none());
        let m = &load_obj(&p, false).unwrap()[0];
        assert!(m.normals.is_none() && m.uvs.is_none());
    }

    #[test]
    fn files_without_normals_give_the_old_mesh() {
        // Vertices in an order the faces do not follow, one unused, an unused `vn`: what
        // the loader gave before normals were read (tobj, `single_index: false`, numbers
        // the positions in the order the faces first use them and drops the unused).
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\nf 4 3 1\nf 2 1 3\nvn 0 0 1\n";
        let p = write("flat.obj", text);
        let m = &load_obj(&p, true).unwrap()[0];
        assert_eq!(
            m.positions,
            [
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0]
            ]
        );
        assert_eq!(m.indices, [[0, 1, 2], [3, 2, 1]]);
        assert!(m.normals.is_none() && m.uvs.is_none());
    }

    #[test]
    fn normal_and_texture_lines_and_references_are_checked() {
        let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\n";
        let bad = |name: &str, tail: &str, normals: bool| {
            let p = write(name, &format!("{base}{tail}"));
            load_obj(&p, normals).unwrap_err().to_string()
        };
        let e = bad("vn.obj", "vn 0 x 1\nf 1 2 3\n", true);
        assert!(e.contains("vn.obj:6") && e.contains("vn x y z"), "{e}");
        let e = bad("vt.obj", "vt 0\nf 1 2 3\n", true);
        assert!(e.contains("vt.obj:6") && e.contains("vt u v"), "{e}");
        let e = bad("vnref.obj", "f 1//1 2//2 3//1\n", true);
        assert!(
            e.contains("vnref.obj:6") && e.contains("normal index 2 is out of range"),
            "{e}"
        );
        let e = bad("vtref.obj", "f 1/1 2/-2 3/1\n", true);
        assert!(
            e.contains("vtref.obj:6") && e.contains("texture coordinate index -2"),
            "{e}"
        );
        let e = bad("slashes.obj", "f 1/1/1/1 2 3\n", true);
        assert!(e.contains("slashes.obj:6"), "{e}");
        // Some face vertices with normals, some without: the first odd one is named.
        let e = bad("mixed.obj", "f 1//1 2//1 3//1\nf 1//1 2 3//1\n", true);
        assert!(
            e.contains("mixed.obj:7") && e.contains("`2` has no `vn`") && e.contains("line 6"),
            "{e}"
        );
        let e = bad("mixed_vt.obj", "f 1 2 3\nf 1/1 2/1 3/1\n", true);
        assert!(e.contains("mixed_vt.obj:7") && e.contains("`vt`"), "{e}");
        // Without normals asked for, their references are not looked at.
        let p = write(
            "mixed_ok.obj",
            &format!("{base}f 1//1 2//1 3//1\nf 1//1 2 3//1\n"),
        );
        let m = load_obj(&p, false).unwrap();
        assert!(m[0].normals.is_none());
    }

    #[test]
    fn cornell_boxes_keep_their_triangles_and_gain_front_facing_normals() {
        // Their faces reference `vn`: read with normals (re-indexed) or without (the old
        // path), the triangles are the same, bit for bit.
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/data/cornell-box");
        for name in ["cbox_smallbox.obj", "cbox_largebox.obj"] {
            let with = load_obj(&dir.join(name), true).unwrap();
            let without = load_obj(&dir.join(name), false).unwrap();
            assert_eq!(with.len(), without.len());
            for (a, b) in with.iter().zip(&without) {
                assert_eq!(a.positions, b.positions, "{name}");
                assert_eq!(a.indices, b.indices, "{name}");
                assert!(b.normals.is_none());
                let n = a.normals.as_ref().unwrap();
                for t in &a.indices {
                    let [p0, p1, p2] = t.map(|i| glam::Vec3::from(a.positions[i as usize]));
                    let ng = (p1 - p0).cross(p2 - p0).normalize();
                    for i in t {
                        assert!(ng.dot(glam::Vec3::from(n[*i as usize])) > 0.99, "{name}");
                    }
                }
            }
        }
    }
}
