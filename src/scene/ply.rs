//! PLY (Stanford polygon file) meshes: ASCII and binary, little- and big-endian.
//!
//! What is read: element `vertex` with properties `x`, `y`, `z` (any scalar type),
//! optionally `nx`, `ny`, `nz` (all three or none) and texture coordinates under the
//! first complete pair of `u`/`v`, `s`/`t`, `texture_u`/`texture_v`,
//! `texture_s`/`texture_t`; element `face` with a list property `vertex_indices` (or
//! `vertex_index`) of integers, any count and index types. Polygons become triangle
//! fans `(0, k, k+1)`, which keeps their winding (counter-clockwise seen from the front,
//! as in OBJ). Every other element and property is read past and dropped.
//!
//! The parser is written here rather than taken from a crate: it is short, needs no
//! dependency, and can say where a file is wrong — the header line, or the element and
//! record (and, in ASCII, the line) of bad data, the face and index of an index out of
//! range — in one line, which is what the scene loader's errors promise. It never
//! panics and allocates no more than the file's size justifies, whatever the header
//! claims. Strictness over guessing: values that do not fit their type, a record with
//! more or fewer values than its properties, bytes after the last element, faces with
//! fewer than three vertices and non-finite positions, normals or texture coordinates
//! are errors.

use super::shapes::TriMesh;
use crate::error::Error;
use crate::Result;
use std::path::Path;

/// Reads the PLY file at `path` as one triangle mesh.
pub fn load_ply(path: &Path) -> Result<TriMesh> {
    let bytes = std::fs::read(path)
        .map_err(|e| Error::file(path, None, format!("cannot read PLY file: {e}")))?;
    parse(path, &bytes)
}

/// Parses the bytes of a PLY file; `path` names it in errors.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<TriMesh> {
    let header = Header::parse(path, bytes)?;
    let data = &bytes[header.data_start..];
    let n = data.len();
    match header.format {
        Format::Ascii => read_body(path, &header, &mut Ascii::new(data, header.end_line), n),
        Format::BinaryLe => read_body(path, &header, &mut Binary::new(data, false), n),
        Format::BinaryBe => read_body(path, &header, &mut Binary::new(data, true), n),
    }
}

/// How the data after the header is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

/// A scalar type of the PLY header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    /// The type of a header name, old (`uchar`) or sized (`uint8`).
    fn from_name(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }

    /// The range of an integer type (`None` for floating point).
    fn int_range(self) -> Option<(i64, i64)> {
        Some(match self {
            Ty::I8 => (i8::MIN.into(), i8::MAX.into()),
            Ty::U8 => (0, u8::MAX.into()),
            Ty::I16 => (i16::MIN.into(), i16::MAX.into()),
            Ty::U16 => (0, u16::MAX.into()),
            Ty::I32 => (i32::MIN.into(), i32::MAX.into()),
            Ty::U32 => (0, u32::MAX.into()),
            Ty::F32 | Ty::F64 => return None,
        })
    }
}

/// A property: a scalar, or a list (a count, then that many items).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Scalar(Ty),
    List { count: Ty, item: Ty },
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
    /// Its header line.
    line: usize,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
    /// Its header line.
    line: usize,
}

impl Element {
    fn find(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|p| p.name == name)
    }
}

#[derive(Debug)]
struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Where the data starts, in bytes.
    data_start: usize,
    /// The line of `end_header`.
    end_line: usize,
}

/// At most this much of a bad line goes into a message.
fn shown(line: &str) -> String {
    let mut s: String = line.chars().take(60).collect();
    if s.len() < line.len() {
        s.push('…');
    }
    format!("{s:?}")
}

impl Header {
    fn parse(path: &Path, bytes: &[u8]) -> Result<Header> {
        let at = |line: usize, what: String| Error::file(path, Some(line), what);
        let mut format = None;
        let mut elements: Vec<Element> = Vec::new();
        let (mut pos, mut lineno) = (0usize, 0usize);
        loop {
            if pos >= bytes.len() {
                return Err(at(
                    lineno.max(1),
                    "the PLY header has no `end_header` line before the end of the file".into(),
                ));
            }
            let end = bytes[pos..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(bytes.len(), |i| pos + i);
            let raw = &bytes[pos..end];
            pos = end + 1;
            lineno += 1;
            let Ok(line) = std::str::from_utf8(raw) else {
                return Err(at(
                    lineno,
                    "expected a header line of text (is `end_header` missing?)".into(),
                ));
            };
            let line = line.trim();
            if lineno == 1 {
                if line != "ply" {
                    return Err(at(
                        1,
                        format!(
                            "expected `ply` (a PLY file's first line), found {}",
                            shown(line)
                        ),
                    ));
                }
                continue;
            }
            let words: Vec<&str> = line.split_whitespace().collect();
            let bad = |expected: &str| {
                at(
                    lineno,
                    format!("expected {expected}, found {}", shown(line)),
                )
            };
            match words.first().copied() {
                None | Some("comment") | Some("obj_info") => {}
                Some("format") => {
                    let f = match words.get(1).copied() {
                        Some("ascii") => Format::Ascii,
                        Some("binary_little_endian") => Format::BinaryLe,
                        Some("binary_big_endian") => Format::BinaryBe,
                        _ => {
                            return Err(bad(
                                "`format ascii 1.0`, `format binary_little_endian 1.0` or `format binary_big_endian 1.0`",
                            ))
                        }
                    };
                    if words.len() != 3 || words[2] != "1.0" {
                        return Err(bad("format version 1.0"));
                    }
                    if format.replace(f).is_some() {
                        return Err(at(lineno, "a second `format` line".into()));
                    }
                }
                Some("element") => {
                    let (Some(name), Some(count), 3) = (words.get(1), words.get(2), words.len())
                    else {
                        return Err(bad("`element NAME COUNT`"));
                    };
                    let Ok(count) = count.parse::<u64>() else {
                        return Err(bad("a record count (an integer ≥ 0) after the element name"));
                    };
                    if elements.iter().any(|e| e.name == *name) {
                        return Err(at(lineno, format!("a second `element {name}`")));
                    }
                    elements.push(Element {
                        name: name.to_string(),
                        count,
                        props: Vec::new(),
                        line: lineno,
                    });
                }
                Some("property") => {
                    let ty = |s: &str| {
                        Ty::from_name(s).ok_or_else(|| {
                            at(
                                lineno,
                                format!("unknown property type `{s}` (expected char, uchar, short, ushort, int, uint, float, double or int8 … float64)"),
                            )
                        })
                    };
                    let (kind, name) = match words[1..] {
                        ["list", count, item, name] => {
                            let count = ty(count)?;
                            if count.int_range().is_none() {
                                return Err(bad("an integer type for a list's count"));
                            }
                            (Kind::List { count, item: ty(item)? }, name)
                        }
                        [t, name] if t != "list" => (Kind::Scalar(ty(t)?), name),
                        _ => return Err(bad("`property TYPE NAME` or `property list COUNT_TYPE ITEM_TYPE NAME`")),
                    };
                    let Some(element) = elements.last_mut() else {
                        return Err(at(lineno, "a property before any `element`".into()));
                    };
                    if element.find(name).is_some() {
                        return Err(at(
                            lineno,
                            format!("a second property `{name}` in element {}", element.name),
                        ));
                    }
                    element.props.push(Property {
                        name: name.to_string(),
                        kind,
                        line: lineno,
                    });
                }
                Some("end_header") => {
                    let Some(format) = format else {
                        return Err(at(lineno, "no `format` line before `end_header`".into()));
                    };
                    return Ok(Header {
                        format,
                        elements,
                        data_start: pos.min(bytes.len()),
                        end_line: lineno,
                    });
                }
                Some(_) => {
                    return Err(bad(
                        "a header line (`format`, `element`, `property`, `comment`, `obj_info` or `end_header`)",
                    ))
                }
            }
        }
    }
}

/// What a property of the vertex or face element is used for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Skip,
    Position(usize),
    Normal(usize),
    Uv(usize),
    Indices,
}

/// The roles of the vertex element's properties, and whether it has normals and uvs.
fn vertex_roles(path: &Path, e: &Element) -> Result<(Vec<Role>, bool, bool)> {
    let mut roles = vec![Role::Skip; e.props.len()];
    let scalar = |i: usize| -> Result<usize> {
        let p = &e.props[i];
        match p.kind {
            Kind::Scalar(_) => Ok(i),
            Kind::List { .. } => Err(Error::file(
                path,
                Some(p.line),
                format!(
                    "expected a scalar type for vertex property `{}`, found a list",
                    p.name
                ),
            )),
        }
    };
    // All of `names` (then their indices) or none; a part is an error at the element.
    let group = |names: &[&str]| -> Result<Option<Vec<usize>>> {
        let found: Vec<Option<usize>> = names.iter().map(|n| e.find(n)).collect();
        if found.iter().all(Option::is_some) {
            return found
                .into_iter()
                .flatten()
                .map(scalar)
                .collect::<Result<_>>()
                .map(Some);
        }
        Ok(None)
    };
    let Some(pos) = group(&["x", "y", "z"])? else {
        return Err(Error::file(
            path,
            Some(e.line),
            "expected properties x, y and z in element vertex",
        ));
    };
    for (k, &i) in pos.iter().enumerate() {
        roles[i] = Role::Position(k);
    }
    let normals = group(&["nx", "ny", "nz"])?;
    if normals.is_none() {
        if let Some(n) = ["nx", "ny", "nz"].iter().find(|n| e.find(n).is_some()) {
            return Err(Error::file(
                path,
                Some(e.line),
                format!("element vertex has `{n}` but not all of nx, ny and nz"),
            ));
        }
    }
    for (k, &i) in normals.iter().flatten().enumerate() {
        roles[i] = Role::Normal(k);
    }
    const UV: [[&str; 2]; 4] = [
        ["u", "v"],
        ["s", "t"],
        ["texture_u", "texture_v"],
        ["texture_s", "texture_t"],
    ];
    let mut uvs = None;
    for pair in UV {
        if let Some(found) = group(&pair)? {
            uvs = Some(found);
            break;
        }
    }
    if uvs.is_none() {
        if let Some(n) = UV.iter().flatten().find(|n| e.find(n).is_some()) {
            return Err(Error::file(
                path,
                Some(e.line),
                format!("element vertex has texture coordinate `{n}` without its pair (u/v, s/t, texture_u/texture_v, texture_s/texture_t)"),
            ));
        }
    }
    for (k, &i) in uvs.iter().flatten().enumerate() {
        roles[i] = Role::Uv(k);
    }
    Ok((roles, normals.is_some(), uvs.is_some()))
}

/// The roles of the face element's properties: its index list.
fn face_roles(path: &Path, e: &Element) -> Result<Vec<Role>> {
    let mut roles = vec![Role::Skip; e.props.len()];
    let Some(i) = e.find("vertex_indices").or_else(|| e.find("vertex_index")) else {
        return Err(Error::file(
            path,
            Some(e.line),
            "expected a list property `vertex_indices` (or `vertex_index`) in element face",
        ));
    };
    let p = &e.props[i];
    match p.kind {
        Kind::List { item, .. } if item.int_range().is_some() => roles[i] = Role::Indices,
        _ => {
            return Err(Error::file(
                path,
                Some(p.line),
                format!(
                    "expected `property list COUNT_TYPE INDEX_TYPE {}` with integer types",
                    p.name
                ),
            ))
        }
    }
    Ok(roles)
}

/// A reader of values from the data: the place of a problem is the caller's to add.
trait Source {
    /// Starts a record.
    fn begin(&mut self) -> std::result::Result<(), String>;
    /// The next value, of type `ty`, exactly (every type fits in an f64).
    fn value(&mut self, ty: Ty) -> std::result::Result<f64, String>;
    /// Ends a record.
    fn end(&mut self) -> std::result::Result<(), String>;
    /// Checks that nothing follows the last element.
    fn finish(&mut self) -> std::result::Result<(), String>;
    /// The line of the current record, in an ASCII file.
    fn line(&self) -> Option<usize>;
}

/// Records as lines of whitespace-separated numbers.
struct Ascii<'a> {
    data: &'a [u8],
    pos: usize,
    /// The line at `pos`.
    line: usize,
    /// The line of the record being read.
    record_line: usize,
}

impl<'a> Ascii<'a> {
    fn new(data: &'a [u8], end_line: usize) -> Ascii<'a> {
        Ascii {
            data,
            pos: 0,
            line: end_line + 1,
            record_line: end_line + 1,
        }
    }

    /// Skips blanks other than line ends.
    fn skip_blanks(&mut self) {
        while let Some(&b) = self.data.get(self.pos) {
            if b == b'\n' || !b.is_ascii_whitespace() {
                break;
            }
            self.pos += 1;
        }
    }
}

impl Source for Ascii<'_> {
    fn begin(&mut self) -> std::result::Result<(), String> {
        loop {
            self.skip_blanks();
            match self.data.get(self.pos) {
                None => return Err("the data ends before this record (truncated file?)".into()),
                Some(b'\n') => {
                    self.pos += 1;
                    self.line += 1;
                }
                Some(_) => break,
            }
        }
        self.record_line = self.line;
        Ok(())
    }

    fn value(&mut self, ty: Ty) -> std::result::Result<f64, String> {
        self.skip_blanks();
        let start = self.pos;
        while self
            .data
            .get(self.pos)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        if start == self.pos {
            return Err("the line ends before this value (fewer values than properties)".into());
        }
        let token = String::from_utf8_lossy(&self.data[start..self.pos]);
        match ty.int_range() {
            Some((lo, hi)) => match token.parse::<i64>() {
                Ok(x) if (lo..=hi).contains(&x) => Ok(x as f64),
                _ => Err(format!(
                    "expected an integer in {lo}..={hi}, found {}",
                    shown(&token)
                )),
            },
            None => token
                .parse::<f64>()
                .map_err(|_| format!("expected a number, found {}", shown(&token))),
        }
    }

    fn end(&mut self) -> std::result::Result<(), String> {
        self.skip_blanks();
        match self.data.get(self.pos) {
            None => Ok(()),
            Some(b'\n') => {
                self.pos += 1;
                self.line += 1;
                Ok(())
            }
            Some(_) => Err("more values on the line than the element has properties".into()),
        }
    }

    fn finish(&mut self) -> std::result::Result<(), String> {
        while let Some(&b) = self.data.get(self.pos) {
            if !b.is_ascii_whitespace() {
                self.record_line = self.line;
                return Err("data after the last element's records".into());
            }
            self.line += usize::from(b == b'\n');
            self.pos += 1;
        }
        Ok(())
    }

    fn line(&self) -> Option<usize> {
        Some(self.record_line)
    }
}

/// Records as packed values of the header's types.
struct Binary<'a> {
    data: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl<'a> Binary<'a> {
    fn new(data: &'a [u8], big_endian: bool) -> Binary<'a> {
        Binary {
            data,
            pos: 0,
            big_endian,
        }
    }

    fn take<const N: usize>(&mut self) -> std::result::Result<[u8; N], String> {
        let bytes: [u8; N] = self
            .data
            .get(self.pos..self.pos + N)
            .and_then(|b| b.try_into().ok())
            .ok_or_else(|| {
                format!(
                    "the data ends at byte {} of {} after the header (truncated file?)",
                    self.pos,
                    self.data.len()
                )
            })?;
        self.pos += N;
        Ok(bytes)
    }
}

macro_rules! decode {
    ($self:ident, $t:ty) => {{
        let b = $self.take::<{ std::mem::size_of::<$t>() }>()?;
        let x = if $self.big_endian {
            <$t>::from_be_bytes(b)
        } else {
            <$t>::from_le_bytes(b)
        };
        x as f64
    }};
}

impl Source for Binary<'_> {
    fn begin(&mut self) -> std::result::Result<(), String> {
        Ok(())
    }

    fn value(&mut self, ty: Ty) -> std::result::Result<f64, String> {
        Ok(match ty {
            Ty::I8 => decode!(self, i8),
            Ty::U8 => decode!(self, u8),
            Ty::I16 => decode!(self, i16),
            Ty::U16 => decode!(self, u16),
            Ty::I32 => decode!(self, i32),
            Ty::U32 => decode!(self, u32),
            Ty::F32 => decode!(self, f32),
            Ty::F64 => decode!(self, f64),
        })
    }

    fn end(&mut self) -> std::result::Result<(), String> {
        Ok(())
    }

    fn finish(&mut self) -> std::result::Result<(), String> {
        match self.data.len() - self.pos {
            0 => Ok(()),
            n => Err(format!(
                "{n} bytes of data after the last element's records"
            )),
        }
    }

    fn line(&self) -> Option<usize> {
        None
    }
}

/// `v` in 32-bit floats, if every value is finite there.
fn finite<const N: usize>(v: [f64; N]) -> Option<[f32; N]> {
    let f = v.map(|x| x as f32);
    f.iter().all(|x| x.is_finite()).then_some(f)
}

/// Reads every element's records after the header (`len` bytes of data).
fn read_body(path: &Path, h: &Header, src: &mut impl Source, len: usize) -> Result<TriMesh> {
    let end = Some(h.end_line);
    let Some(vertex) = h.elements.iter().find(|e| e.name == "vertex") else {
        return Err(Error::file(
            path,
            end,
            "the PLY header has no `element vertex`",
        ));
    };
    let nv = vertex.count;
    if nv > u64::from(u32::MAX) {
        return Err(Error::file(
            path,
            Some(vertex.line),
            format!("{nv} vertices are more than 32-bit indices can address"),
        ));
    }
    let (vroles, has_normals, has_uvs) = vertex_roles(path, vertex)?;
    let face = h.elements.iter().find(|e| e.name == "face");
    let froles = match face {
        Some(f) => face_roles(path, f)?,
        None => Vec::new(),
    };
    if face.is_none_or(|f| f.count == 0) {
        return Err(Error::file(path, None, "the PLY file has no faces"));
    }
    // Never reserve more than the data could hold (a record takes at least a byte).
    let room = nv.min(len as u64) as usize;
    let mut m = TriMesh {
        positions: Vec::with_capacity(room),
        indices: Vec::new(),
        normals: has_normals.then(|| Vec::with_capacity(room)),
        uvs: has_uvs.then(|| Vec::with_capacity(room)),
    };
    let mut polygon: Vec<u32> = Vec::new();
    for e in &h.elements {
        let roles: &[Role] = match e.name.as_str() {
            "vertex" => &vroles,
            "face" => &froles,
            _ => &[],
        };
        if e.props.is_empty() {
            continue;
        }
        for r in 0..e.count {
            // Where a problem is (the record, the property) and what it is.
            let fail = |line: Option<usize>, prop: Option<&Property>, what: String| {
                let prop = prop
                    .map(|p| format!(", property {}", p.name))
                    .unwrap_or_default();
                Error::file(
                    path,
                    line,
                    format!(
                        "element {} record {r} (of {}, counting from 0){prop}: {what}",
                        e.name, e.count
                    ),
                )
            };
            src.begin().map_err(|w| fail(src.line(), None, w))?;
            let (mut p, mut n, mut t) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 2]);
            polygon.clear();
            for (i, prop) in e.props.iter().enumerate() {
                let role = roles.get(i).copied().unwrap_or(Role::Skip);
                match prop.kind {
                    Kind::Scalar(ty) => {
                        let x = src.value(ty).map_err(|w| fail(src.line(), Some(prop), w))?;
                        match role {
                            Role::Position(k) => p[k] = x,
                            Role::Normal(k) => n[k] = x,
                            Role::Uv(k) => t[k] = x,
                            Role::Skip | Role::Indices => {}
                        }
                    }
                    Kind::List { count, item } => {
                        let c = src
                            .value(count)
                            .map_err(|w| fail(src.line(), Some(prop), w))?;
                        if c < 0.0 {
                            let w = format!("a negative list length {c}");
                            return Err(fail(src.line(), Some(prop), w));
                        }
                        // `c` is an integer: the count's type is.
                        for _ in 0..c as u64 {
                            let x = src
                                .value(item)
                                .map_err(|w| fail(src.line(), Some(prop), w))?;
                            if role != Role::Indices {
                                continue;
                            }
                            if !(0.0..nv as f64).contains(&x) {
                                return Err(Error::file(
                                    path,
                                    src.line(),
                                    format!(
                                        "face {r} has vertex index {x}, out of range (the file has {nv} vertices, 0..{nv})"
                                    ),
                                ));
                            }
                            polygon.push(x as u32);
                        }
                    }
                }
            }
            src.end().map_err(|w| fail(src.line(), None, w))?;
            let not_finite = |what: &str, v: &[f64]| {
                let w = format!("{what} {v:?} is not finite in 32-bit floats");
                fail(src.line(), None, w)
            };
            match e.name.as_str() {
                "vertex" => {
                    m.positions
                        .push(finite(p).ok_or_else(|| not_finite("the position", &p))?);
                    if let Some(normals) = &mut m.normals {
                        normals.push(finite(n).ok_or_else(|| not_finite("the normal", &n))?);
                    }
                    if let Some(uvs) = &mut m.uvs {
                        let w = "the texture coordinate";
                        uvs.push(finite(t).ok_or_else(|| not_finite(w, &t))?);
                    }
                }
                "face" => {
                    if polygon.len() < 3 {
                        let w = format!("{} vertices, expected at least 3", polygon.len());
                        return Err(fail(src.line(), None, w));
                    }
                    let a = polygon[0];
                    m.indices
                        .extend(polygon.windows(2).skip(1).map(|w| [a, w[0], w[1]]));
                }
                _ => {}
            }
        }
    }
    src.finish().map_err(|w| Error::file(path, src.line(), w))?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A header for `format` followed by `body` (elements and properties).
    fn header(format: &str, body: &str) -> String {
        format!("ply\nformat {format} 1.0\ncomment made by a test\n{body}end_header\n")
    }

    /// The records (each a list of typed values) after `header`, in `format`.
    fn encode(format: &str, body: &str, records: &[Vec<(Ty, f64)>]) -> Vec<u8> {
        let mut out = header(format, body).into_bytes();
        for r in records {
            if format == "ascii" {
                let words: Vec<String> = r
                    .iter()
                    .map(|&(ty, x)| match ty.int_range() {
                        Some(_) => format!("{}", x as i64),
                        None => format!("{x}"),
                    })
                    .collect();
                out.extend(words.join(" ").bytes());
                out.push(b'\n');
                continue;
            }
            let be = format == "binary_big_endian";
            for &(ty, x) in r {
                macro_rules! put {
                    ($t:ty) => {{
                        let v = x as $t;
                        out.extend(if be { v.to_be_bytes() } else { v.to_le_bytes() })
                    }};
                }
                match ty {
                    Ty::I8 => put!(i8),
                    Ty::U8 => put!(u8),
                    Ty::I16 => put!(i16),
                    Ty::U16 => put!(u16),
                    Ty::I32 => put!(i32),
                    Ty::U32 => put!(u32),
                    Ty::F32 => put!(f32),
                    Ty::F64 => put!(f64),
                }
            }
        }
        out
    }

    /// Elements and properties of the test mesh: a vertex element with extra scalar and
    /// list properties, an extra element before the faces and one after, and faces with
    /// properties around their index list.
    const BODY: &str = "element vertex 5
property float x
property float y
property double z
property uchar red
property float nx
property float ny
property float nz
property list uchar int extra
property float s
property float t
element edge 2
property list ushort uint pair
property short weight
element face 2
property int flags
property list uchar uint vertex_indices
property uchar tag
element material 1
property float shine
";

    const POSITIONS: [[f32; 3]; 5] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.5],
        [0.0, 1.0, 0.25],
        [-1.0, 0.5, -2.0],
    ];

    fn records() -> Vec<Vec<(Ty, f64)>> {
        use Ty::*;
        let mut r = Vec::new();
        for (i, p) in POSITIONS.iter().enumerate() {
            let i = i as f64;
            let mut v = vec![(F32, p[0] as f64), (F32, p[1] as f64), (F64, p[2] as f64)];
            v.push((U8, 200.0));
            v.extend([(F32, 0.0), (F32, -i), (F32, 1.0)]);
            // A list of i values.
            v.push((U8, i));
            v.extend((0..i as usize).map(|k| (I32, -(k as f64))));
            v.extend([(F32, i / 8.0), (F32, 1.0 - i / 4.0)]);
            r.push(v);
        }
        r.push(vec![(U16, 2.0), (U32, 0.0), (U32, 1.0), (I16, -3.0)]);
        r.push(vec![(U16, 0.0), (I16, 7.0)]);
        let face = |idx: &[f64]| {
            let mut f = vec![(I32, -1.0), (U8, idx.len() as f64)];
            f.extend(idx.iter().map(|&k| (U32, k)));
            f.push((U8, 9.0));
            f
        };
        r.push(face(&[0.0, 1.0, 2.0, 3.0]));
        r.push(face(&[0.0, 3.0, 4.0]));
        r.push(vec![(F32, 0.5)]);
        r
    }

    const FORMATS: [&str; 3] = ["ascii", "binary_little_endian", "binary_big_endian"];

    fn parse_bytes(bytes: &[u8]) -> Result<TriMesh> {
        parse(Path::new("test.ply"), bytes)
    }

    fn err(bytes: &[u8]) -> String {
        parse_bytes(bytes).unwrap_err().to_string()
    }

    fn ascii(body: &str, data: &str) -> Vec<u8> {
        let mut b = header("ascii", body).into_bytes();
        b.extend(data.bytes());
        b
    }

    #[test]
    fn every_format_gives_the_same_mesh_with_extra_elements_skipped() {
        for f in FORMATS {
            let m =
                parse_bytes(&encode(f, BODY, &records())).unwrap_or_else(|e| panic!("{f}: {e}"));
            assert_eq!(m.positions, POSITIONS, "{f}");
            // The quad becomes the fan (0, 1, 2), (0, 2, 3); the triangle stays.
            assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]], "{f}");
            let normals: Vec<[f32; 3]> = (0..5).map(|i| [0.0, -(i as f32), 1.0]).collect();
            assert_eq!(m.normals.as_ref(), Some(&normals), "{f}");
            let uvs: Vec<[f32; 2]> = (0..5)
                .map(|i| [i as f32 / 8.0, 1.0 - i as f32 / 4.0])
                .collect();
            assert_eq!(m.uvs.as_ref(), Some(&uvs), "{f}");
        }
    }

    #[test]
    fn polygons_are_fans_and_names_vary() {
        let body = "element vertex 6\nproperty float x\nproperty float y\nproperty float z\nproperty float texture_u\nproperty float texture_v\nelement face 1\nproperty list uint8 int32 vertex_index\n";
        let data =
            "0 0 0 0 0\n1 0 0 1 0\n2 1 0 1 1\n1 2 0 0 1\n0 2 0 0 0\n-1 1 0 1 1\n6 0 1 2 3 4 5\n";
        let m = parse_bytes(&ascii(body, data)).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]);
        assert!(m.normals.is_none());
        assert_eq!(m.uvs.unwrap()[2], [1.0, 1.0]);
        // u/v, and no texture coordinates at all.
        let body = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\n";
        let m = parse_bytes(&ascii(
            body,
            "0 0 0 .5 .25\n1 0 0 0 0\n0 1 0 0 0\n3 0 1 2\n",
        ))
        .unwrap();
        assert_eq!(m.uvs.unwrap()[0], [0.5, 0.25]);
        let body = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n";
        let m = parse_bytes(&ascii(body, "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")).unwrap();
        assert!(m.normals.is_none() && m.uvs.is_none());
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn errors_name_the_header_line_or_the_record() {
        let tri = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n";
        let data = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        // Header: the line is the one to blame.
        let e = err(&ascii(tri, data).replace_first(b"ascii", b"binary"));
        assert!(e.starts_with("test.ply:2:") && e.contains("format"), "{e}");
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n");
        assert!(e.contains("end_header"), "{e}");
        let e = err(&ascii(
            &tri.replace("property float y", "property real y"),
            data,
        ));
        assert!(e.starts_with("test.ply:6:") && e.contains("`real`"), "{e}");
        let e = err(&ascii(&tri.replace("property float z\n", ""), data));
        assert!(
            e.starts_with("test.ply:4:") && e.contains("x, y and z"),
            "{e}"
        );
        let e = err(b"plx\nformat ascii 1.0\nend_header\n");
        assert!(e.starts_with("test.ply:1:"), "{e}");
        let e = err(&ascii(&tri.replace("vertex_indices", "corners"), data));
        assert!(e.contains("vertex_indices"), "{e}");
        let e = err(&ascii(
            &tri.replace(
                "property float z\n",
                "property float z\nproperty float nx\n",
            ),
            data,
        ));
        assert!(e.contains("nx"), "{e}");
        // No faces: no face element, or none in it.
        let no_face = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
        let e = err(&ascii(no_face, "0 0 0\n1 0 0\n0 1 0\n"));
        assert!(e.contains("has no faces"), "{e}");
        let e = err(&ascii(
            &tri.replace("face 1", "face 0"),
            "0 0 0\n1 0 0\n0 1 0\n",
        ));
        assert!(e.contains("has no faces"), "{e}");
        // Data: the record (and in ASCII the line).
        let e = err(&ascii(tri, "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"));
        assert!(
            e.starts_with("test.ply:14:") && e.contains("face 0") && e.contains("index 3"),
            "{e}"
        );
        let e = err(&ascii(tri, "0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"));
        assert!(
            e.starts_with("test.ply:12:") && e.contains("record 1") && e.contains("property y"),
            "{e}"
        );
        let e = err(&ascii(tri, "0 0 0\n1 0\n0 1 0\n3 0 1 2\n"));
        assert!(
            e.starts_with("test.ply:12:") && e.contains("property z"),
            "{e}"
        );
        let e = err(&ascii(tri, "0 0 0\n1 0 0 0\n0 1 0\n3 0 1 2\n"));
        assert!(e.contains("more values"), "{e}");
        let e = err(&ascii(tri, "0 0 0\n1 0 0\n0 1 0\n2 0 1\n"));
        assert!(e.contains("at least 3"), "{e}");
        let e = err(&ascii(tri, "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n7\n"));
        assert!(e.contains("after the last element"), "{e}");
        let e = err(&ascii(tri, "0 0 0\n1e39 0 0\n0 1 0\n3 0 1 2\n"));
        assert!(e.contains("not finite"), "{e}");
        let e = err(&ascii(tri, "0 0 0\n1 0 0\n"));
        assert!(e.contains("record 2") && e.contains("ends"), "{e}");
        for f in &FORMATS[1..] {
            let full = encode(f, BODY, &records());
            let e = err(&full[..full.len() - 6]);
            assert!(
                e.contains("element face record 1") && e.contains("truncated"),
                "{f}: {e}"
            );
            let mut more = full.clone();
            more.push(0);
            assert!(err(&more).contains("1 bytes of data after"), "{f}");
        }
    }

    trait ReplaceFirst {
        fn replace_first(&self, from: &[u8], to: &[u8]) -> Vec<u8>;
    }

    impl ReplaceFirst for Vec<u8> {
        fn replace_first(&self, from: &[u8], to: &[u8]) -> Vec<u8> {
            let i = self.windows(from.len()).position(|w| w == from).unwrap();
            [&self[..i], to, &self[i + from.len()..]].concat()
        }
    }

    /// Truncated and mutated files: errors or meshes whose indices are in range, never
    /// a panic.
    #[test]
    fn fuzz_never_panics() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let check = |bytes: &[u8]| {
            if let Ok(m) = parse_bytes(bytes) {
                let n = m.positions.len();
                assert!(m.indices.iter().flatten().all(|&i| (i as usize) < n));
                assert!(m.normals.as_ref().is_none_or(|v| v.len() == n));
                assert!(m.uvs.as_ref().is_none_or(|v| v.len() == n));
            }
        };
        for f in FORMATS {
            let full = encode(f, BODY, &records());
            for len in 0..full.len() {
                check(&full[..len]);
            }
            for _ in 0..3000 {
                let mut b = full.clone();
                for _ in 0..1 + next() % 3 {
                    let i = (next() % b.len() as u64) as usize;
                    // Digits and header words matter most: mutate into bytes of the file.
                    b[i] = match next() % 3 {
                        0 => next() as u8,
                        1 => b"0123456789 \n-.e"[(next() % 15) as usize],
                        _ => full[(next() % full.len() as u64) as usize],
                    };
                }
                check(&b);
            }
        }
    }
}
