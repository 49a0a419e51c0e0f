//! Triangle-mesh files: PLY (ascii, binary little/big endian, optionally
//! gzipped) through a hand-written parser, and Wavefront OBJ through `tobj`.
//!
//! The PLY parser reads the whole (decompressed) file into memory and walks it
//! once. On the ascii Stanford bunny it takes about 6 ms where `ply-rs-bw`
//! takes about 160 ms (release; the cross-check test prints both), and it
//! reports errors with the line (ascii) or the record (binary) where they
//! happen.
//!
//! Polygons are fan-triangulated. Elements and properties the renderer does
//! not use (normals, colours, confidence, ...) are skipped, and so are
//! degenerate triangles; both are summed up in one note per file (see
//! [`read_mesh`]). A file that contradicts its header or the format (data
//! after the declared elements, a face of two vertices, an index of 0) is an
//! error with its line or byte offset. A gzipped PLY is inflated no further
//! than the largest body its header's counts allow.

use crate::echo::echo;
use crate::geometry::Mesh;
use crate::location::line_column;
use crate::math::{Vec2, Vec3};
use std::io::Read;
use std::path::{Path, PathBuf};

/// Why a mesh file could not be loaded. Every message starts with the path,
/// then the place: line and column in text (`bunny.ply:12:7: ...`), the byte
/// offset in a binary body (`bunny.ply: byte 4096: ...`; of the decompressed
/// data for a gzipped file).
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{}: {source}", .path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}:{line}:{column}: {msg}", .path.display())]
    AtLine {
        path: PathBuf,
        line: usize,
        column: usize,
        msg: String,
    },
    #[error("{}: byte {offset}: {msg}", .path.display())]
    AtByte {
        path: PathBuf,
        offset: usize,
        msg: String,
    },
    #[error("{}: {msg}", .path.display())]
    Invalid { path: PathBuf, msg: String },
}

/// Loads a `.ply`, `.ply.gz`, `.obj` or `.obj.gz` file (gzip is recognised by
/// its magic bytes, whatever the name).
pub fn load_mesh(path: &Path) -> Result<Mesh, MeshError> {
    read_mesh(path).map(|(mesh, _)| mesh)
}

/// [`load_mesh`], with the notes on what of the file luz did not use (data
/// it does not read, triangles it dropped, and why): empty for a file read
/// whole. The path must be a regular file.
pub fn read_mesh(path: &Path) -> Result<(Mesh, Vec<String>), MeshError> {
    let data = crate::location::read_regular_file(path).map_err(|source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_mesh_noted(&data, path)
}

/// Parses the contents of a mesh file; `path` picks the format by its
/// extension, as in [`load_mesh`], and names the file in errors.
pub fn parse_mesh(data: &[u8], path: &Path) -> Result<Mesh, MeshError> {
    parse_mesh_noted(data, path).map(|(mesh, _)| mesh)
}

/// [`parse_mesh`] with the notes of [`read_mesh`].
pub fn parse_mesh_noted(data: &[u8], path: &Path) -> Result<(Mesh, Vec<String>), MeshError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let is_ply = name.ends_with(".ply");
    let parse: fn(&[u8]) -> Result<Noted, Fail> = if is_ply {
        parse_ply
    } else if name.ends_with(".obj") {
        parse_obj
    } else {
        return Err(MeshError::Invalid {
            path: path.to_path_buf(),
            msg: "unsupported mesh format: expected a .ply, .ply.gz or .obj file".into(),
        });
    };
    if !data.starts_with(&[0x1f, 0x8b]) {
        return parse(data).map_err(|f| f.at(path));
    }
    let gzip = |e: std::io::Error| MeshError::Invalid {
        path: path.to_path_buf(),
        msg: format!("gzip: {e}"),
    };
    let mut decoder = flate2::read::MultiGzDecoder::new(data);
    let mut out = Vec::new();
    if is_ply {
        inflate_ply(&mut decoder, &mut out).map_err(|e| match e {
            Inflate::Gzip(e) => gzip(e),
            Inflate::Fail(f) => f.at(path),
        })?;
    } else {
        out.reserve(data.len().saturating_mul(4));
        decoder.read_to_end(&mut out).map_err(gzip)?;
    }
    parse(&out).map_err(|f| f.at(path))
}

/// A mesh with the notes on what of its file luz did not use.
type Noted = (Mesh, Vec<String>);

/// The most bytes a PLY header may take before `end_header`.
const MAX_PLY_HEADER: usize = 1 << 20;

/// The most bytes one ascii value (with its separator) may take, for the
/// bound on an ascii body: `-1.2345678901234567e-123` is 24.
const MAX_ASCII_VALUE: usize = 64;

enum Inflate {
    Gzip(std::io::Error),
    Fail(Fail),
}

/// Inflates a gzipped PLY into `out`: the header first (at most
/// [`MAX_PLY_HEADER`] bytes), then no more of the body than its declared
/// elements can take ([`max_body`]) and one byte: a file that goes on past
/// that is an error at the byte where the declared data must end, found
/// before the rest is inflated (a 2 MB file of zeros inflated to 1 GB
/// before it was refused).
fn inflate_ply(decoder: &mut impl Read, out: &mut Vec<u8>) -> Result<(), Inflate> {
    let mut chunk = vec![0u8; 64 << 10];
    let header = loop {
        let n = decoder.read(&mut chunk).map_err(Inflate::Gzip)?;
        out.extend_from_slice(&chunk[..n]);
        let complete = out
            .windows(11)
            .position(|w| w == b"end_header\n" || w == b"end_header\r")
            .is_some();
        if n == 0 || complete || out.len() > MAX_PLY_HEADER {
            // A broken header is reported by the parser, from what is here.
            match parse_header(out) {
                Ok(h) => break h,
                Err(_) => return Ok(()),
            }
        }
    };
    let limit = header.body.saturating_add(max_body(&header));
    if out.len() <= limit {
        let left = (limit - out.len()) as u64 + 1;
        decoder.take(left).read_to_end(out).map_err(Inflate::Gzip)?;
    }
    if out.len() > limit {
        return Err(Inflate::Fail(trailing(limit, &header.elements, true)));
    }
    Ok(())
}

/// The most bytes a body can hold for the header's counts: per record, the
/// sizes of its scalars and of its lists at the longest their count type
/// allows (binary), or [`MAX_ASCII_VALUE`] per value (ascii).
fn max_body(header: &Header) -> usize {
    let value = |ty: Ty| match header.format {
        Format::Ascii => MAX_ASCII_VALUE,
        _ => ty.size(),
    };
    let max_items = |ty: Ty| -> usize {
        match ty {
            Ty::I8 => i8::MAX as usize,
            Ty::U8 => u8::MAX as usize,
            Ty::I16 => i16::MAX as usize,
            Ty::U16 => u16::MAX as usize,
            Ty::I32 => i32::MAX as usize,
            _ => u32::MAX as usize,
        }
    };
    header.elements.iter().fold(0usize, |total, el| {
        let record = el.props.iter().fold(0usize, |r, p| match p.kind {
            Kind::Scalar(ty) => r.saturating_add(value(ty)),
            Kind::List(ct, it) => r
                .saturating_add(value(ct))
                .saturating_add(max_items(ct).saturating_mul(value(it))),
        });
        total.saturating_add(record.saturating_mul(el.count))
    })
}

/// The error of data after the last element the header declares, at byte
/// `at` (of the decompressed data when `inflated`).
fn trailing(at: usize, elements: &[Element], inflated: bool) -> Fail {
    let declared: Vec<String> = elements
        .iter()
        .map(|e| format!("{} {}", e.count, echo(&e.name)))
        .collect();
    let why = if inflated {
        " (decompression stopped here: the counts allow no more)"
    } else {
        ""
    };
    fail_byte(
        at,
        format!(
            "the data goes on after the last element the header declares ({}){why}",
            declared.join(", ")
        ),
    )
}

/// Where in a file a failure is.
#[derive(Clone, Copy, Debug)]
enum Loc {
    /// 1-based line and column (in bytes) of text.
    Text(usize, usize),
    /// Offset from the start of the file.
    Byte(usize),
}

/// A parse failure before the path is attached.
#[derive(Debug)]
struct Fail {
    at: Option<Loc>,
    msg: String,
}

impl Fail {
    fn at(self, path: &Path) -> MeshError {
        let path = path.to_path_buf();
        let msg = self.msg;
        match self.at {
            Some(Loc::Text(line, column)) => MeshError::AtLine {
                path,
                line,
                column,
                msg,
            },
            Some(Loc::Byte(offset)) => MeshError::AtByte { path, offset, msg },
            None => MeshError::Invalid { path, msg },
        }
    }
}

/// A failure about the whole file, with no one place to point at.
fn fail(msg: impl Into<String>) -> Fail {
    Fail {
        at: None,
        msg: msg.into(),
    }
}

fn fail_at(line: usize, column: usize, msg: impl Into<String>) -> Fail {
    Fail {
        at: Some(Loc::Text(line, column)),
        msg: msg.into(),
    }
}

fn fail_byte(offset: usize, msg: impl Into<String>) -> Fail {
    Fail {
        at: Some(Loc::Byte(offset)),
        msg: msg.into(),
    }
}

/// 1-based column of `word`, a slice of `line`.
fn column(line: &str, word: &str) -> usize {
    word.as_ptr() as usize - line.as_ptr() as usize + 1
}

/// A name from the header for a message: itself, or [`echo`]'s shortened
/// form when long.
fn short(name: &str) -> std::borrow::Cow<'_, str> {
    if name.len() <= 60 {
        name.into()
    } else {
        echo(name).into()
    }
}

/// A token for an error message: lossy UTF-8, cut short when long.
fn show(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(tok);
    if s.chars().count() > 40 {
        format!("{}...", s.chars().take(40).collect::<String>())
    } else {
        s.into_owned()
    }
}

/// Appends the fan triangulation of `poly`, face number `face`.
fn push_polygon(poly: &[u32], face: usize, out: &mut Vec<[u32; 3]>) -> Result<(), String> {
    if poly.len() < 3 {
        return Err(format!(
            "face {face} has {} vertices; a face needs at least 3",
            poly.len()
        ));
    }
    for i in 1..poly.len() - 1 {
        out.push([poly[0], poly[i], poly[i + 1]]);
    }
    Ok(())
}

fn check_finite(p: Vec3, uv: Option<Vec2>, vertex: usize) -> Result<(), String> {
    if !p.is_finite() {
        return Err(format!(
            "vertex {vertex}: coordinates must be finite, got ({}, {}, {})",
            p.x, p.y, p.z
        ));
    }
    if let Some(uv) = uv {
        if !uv.is_finite() {
            return Err(format!(
                "vertex {vertex}: texture coordinates must be finite, got ({}, {})",
                uv.x, uv.y
            ));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// PLY header

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
    fn parse(s: &str) -> Option<Ty> {
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

    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, Ty::F32 | Ty::F64)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Scalar(Ty),
    /// Count type, item type.
    List(Ty, Ty),
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
    line: usize,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
    line: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the body.
    body: usize,
    /// Line number of the body's first line.
    body_line: usize,
}

fn parse_header(data: &[u8]) -> Result<Header, Fail> {
    let mut pos = 0;
    let mut line = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        if pos >= data.len() {
            return Err(fail_at(line.max(1), 1, "header has no `end_header` line"));
        }
        let end = data[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(data.len(), |i| pos + i);
        let raw = &data[pos..end];
        pos = end + 1;
        line += 1;
        let text = std::str::from_utf8(raw).map_err(|e| {
            fail_at(
                line,
                e.valid_up_to() + 1,
                "header line is not text (is the `end_header` line missing?)",
            )
        })?;
        let mut words = text.split_ascii_whitespace();
        let at = |word: Option<&str>| word.map_or(1, |w| column(text, w));
        let kw = words.next();
        if line == 1 {
            if kw != Some("ply") || words.next().is_some() {
                return Err(fail_at(
                    1,
                    1,
                    "not a PLY file: the first line must be `ply`",
                ));
            }
            continue;
        }
        let Some(kw) = kw else { continue };
        match kw {
            "format" => {
                let word = words.next();
                format = Some(match word {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::BinaryLe,
                    Some("binary_big_endian") => Format::BinaryBe,
                    other => {
                        return Err(fail_at(
                            line,
                            at(word),
                            format!("unsupported PLY format {}", echo(other.unwrap_or(""))),
                        ))
                    }
                });
            }
            "comment" | "obj_info" => {}
            "element" => {
                let (Some(name), Some(count)) = (words.next(), words.next()) else {
                    return Err(fail_at(line, 1, "expected `element <name> <count>`"));
                };
                let count = count.parse::<usize>().map_err(|_| {
                    fail_at(
                        line,
                        column(text, count),
                        format!(
                            "element {}: expected a count, found {}",
                            echo(name),
                            echo(count)
                        ),
                    )
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                    line,
                });
            }
            "property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(fail_at(line, 1, "`property` before any `element`"));
                };
                let ty = |s: Option<&str>| {
                    Ty::parse(s.unwrap_or("")).ok_or_else(|| {
                        fail_at(
                            line,
                            at(s),
                            format!("unknown property type {}", echo(s.unwrap_or(""))),
                        )
                    })
                };
                let first = words.next();
                let kind = if first == Some("list") {
                    let word = words.next();
                    let count = ty(word)?;
                    if count.is_float() {
                        return Err(fail_at(
                            line,
                            at(word),
                            "a list count must have an integer type",
                        ));
                    }
                    Kind::List(count, ty(words.next())?)
                } else {
                    Kind::Scalar(ty(first)?)
                };
                let Some(name) = words.next() else {
                    return Err(fail_at(line, 1, "property has no name"));
                };
                el.props.push(Property {
                    name: name.to_string(),
                    kind,
                    line,
                });
            }
            "end_header" => break,
            _ => {
                return Err(fail_at(
                    line,
                    1,
                    format!("unknown header keyword {}", echo(kw)),
                ))
            }
        }
    }
    let format = format.ok_or_else(|| fail_at(2, 1, "header has no `format` line"))?;
    Ok(Header {
        format,
        elements,
        body: pos.min(data.len()),
        body_line: line + 1,
    })
}

// ---------------------------------------------------------------------------
// PLY body

/// What a property is used for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Skip,
    /// Position component 0..3 or texture coordinate 3..5.
    Value(usize),
    Indices,
}

/// How to read a PLY body.
struct Plan {
    /// Per element, the role of each property.
    roles: Vec<Vec<Role>>,
    has_uv: bool,
    /// The indices of the `vertex` and `face` elements.
    vertex: usize,
    face: usize,
}

/// The plan for a header's elements. `end_line` is the line of
/// `end_header`, where a missing element is reported.
fn plan(elements: &[Element], end_line: usize) -> Result<Plan, Fail> {
    let mut roles: Vec<Vec<Role>> = elements
        .iter()
        .map(|e| vec![Role::Skip; e.props.len()])
        .collect();
    let vi = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| fail_at(end_line, 1, "the header declares no `vertex` element"))?;
    let fi = elements
        .iter()
        .position(|e| e.name == "face")
        .ok_or_else(|| {
            fail_at(
                end_line,
                1,
                "the header declares no `face` element (a point cloud is not a mesh)",
            )
        })?;
    let vertex = &elements[vi];
    if vertex.count > u32::MAX as usize {
        return Err(fail_at(
            vertex.line,
            1,
            "too many vertices for 32-bit indices",
        ));
    }
    let find = |name: &str| -> Result<Option<usize>, Fail> {
        match vertex.props.iter().position(|p| p.name == name) {
            Some(i) if matches!(vertex.props[i].kind, Kind::List(..)) => Err(fail_at(
                vertex.props[i].line,
                1,
                format!("vertex property `{name}` must be a scalar, not a list"),
            )),
            other => Ok(other),
        }
    };
    for (c, name) in ["x", "y", "z"].into_iter().enumerate() {
        let i = find(name)?.ok_or_else(|| {
            fail_at(
                vertex.line,
                1,
                format!("the `vertex` element has no `{name}` property"),
            )
        })?;
        roles[vi][i] = Role::Value(c);
    }
    let mut has_uv = false;
    for (u, v) in [
        ("u", "v"),
        ("s", "t"),
        ("texture_u", "texture_v"),
        ("texture_s", "texture_t"),
    ] {
        if let (Some(iu), Some(iv)) = (find(u)?, find(v)?) {
            roles[vi][iu] = Role::Value(3);
            roles[vi][iv] = Role::Value(4);
            has_uv = true;
            break;
        }
    }
    let face = &elements[fi];
    let i = face
        .props
        .iter()
        .position(|p| p.name == "vertex_indices" || p.name == "vertex_index")
        .ok_or_else(|| {
            fail_at(
                face.line,
                1,
                "the `face` element has no `vertex_indices` (or `vertex_index`) property",
            )
        })?;
    match face.props[i].kind {
        Kind::List(_, item) if !item.is_float() => roles[fi][i] = Role::Indices,
        _ => {
            return Err(fail_at(
                face.props[i].line,
                1,
                format!(
                    "face property `{}` must be a list of integers",
                    face.props[i].name
                ),
            ))
        }
    }
    Ok(Plan {
        roles,
        has_uv,
        vertex: vi,
        face: fi,
    })
}

fn parse_ply(data: &[u8]) -> Result<Noted, Fail> {
    let header = parse_header(data)?;
    let Plan {
        roles,
        has_uv,
        vertex,
        face,
    } = plan(&header.elements, header.body_line - 1)?;
    let body = &data[header.body..];
    let nv = header.elements[vertex].count;
    let (nf, face_line) = (header.elements[face].count, header.elements[face].line);
    // Counts come from the file; never reserve more than the body could hold.
    let mut out = Builder {
        positions: Vec::with_capacity(nv.min(body.len() / 3)),
        uvs: has_uv.then(|| Vec::with_capacity(nv.min(body.len() / 5))),
        indices: Vec::with_capacity(nf.min(body.len() / 4)),
        nv: nv as u32,
        poly: Vec::new(),
    };
    match header.format {
        Format::Ascii => ascii_body(body, header.body_line, &header.elements, &roles, &mut out)?,
        Format::BinaryLe => {
            binary_body::<false>(data, header.body, &header.elements, &roles, &mut out)?
        }
        Format::BinaryBe => {
            binary_body::<true>(data, header.body, &header.elements, &roles, &mut out)?
        }
    }
    let triangles = out.indices.len();
    let dropped = drop_degenerate(&out.positions, &mut out.indices);
    if out.indices.is_empty() {
        return Err(fail_at(face_line, 1, no_faces(triangles)));
    }
    // What of the file luz leaves unread.
    let mut unused = Vec::new();
    for (i, (el, roles)) in header.elements.iter().zip(&roles).enumerate() {
        if i != vertex && i != face {
            unused.push(format!("element {} ({})", echo(&el.name), el.count));
            continue;
        }
        for (p, role) in el.props.iter().zip(roles) {
            if *role == Role::Skip {
                unused.push(format!("{} property {}", short(&el.name), echo(&p.name)));
            }
        }
    }
    let mut notes = Vec::new();
    if !unused.is_empty() {
        notes.push(format!("not used: {}", summarize(&unused)));
    }
    if dropped > 0 {
        notes.push(dropped_note(dropped, triangles));
    }
    let mesh = Mesh {
        positions: out.positions,
        indices: out.indices,
        uvs: out.uvs,
    };
    Ok((mesh, notes))
}

/// A list for a note, cut after the first few items.
fn summarize(items: &[String]) -> String {
    const SHOWN: usize = 8;
    let mut s = items[..items.len().min(SHOWN)].join(", ");
    if items.len() > SHOWN {
        s.push_str(&format!(" and {} more", items.len() - SHOWN));
    }
    s
}

fn dropped_note(dropped: usize, triangles: usize) -> String {
    format!("dropped {dropped} of {triangles} triangles, degenerate (no area)")
}

struct Builder {
    positions: Vec<Vec3>,
    uvs: Option<Vec<Vec2>>,
    indices: Vec<[u32; 3]>,
    nv: u32,
    poly: Vec<u32>,
}

impl Builder {
    fn vertex(&mut self, v: [f32; 5]) -> Result<(), String> {
        let p = Vec3::new(v[0], v[1], v[2]);
        let uv = Vec2::new(v[3], v[4]);
        check_finite(p, self.uvs.is_some().then_some(uv), self.positions.len())?;
        self.positions.push(p);
        if let Some(uvs) = &mut self.uvs {
            uvs.push(uv);
        }
        Ok(())
    }

    #[inline]
    fn index(&mut self, i: i64, face: usize) -> Result<(), String> {
        if i < 0 || i >= self.nv as i64 {
            return Err(format!(
                "face {face}: vertex index {i} is out of range ({} vertices)",
                self.nv
            ));
        }
        self.poly.push(i as u32);
        Ok(())
    }

    fn end_face(&mut self, face: usize) -> Result<(), String> {
        let r = push_polygon(&self.poly, face, &mut self.indices);
        self.poly.clear();
        r
    }
}

/// Whitespace-separated tokens with line numbers.
struct Tokens<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
    /// Offset of the current line's first byte.
    line_start: usize,
    /// Offset of the last token (of the end, once there are no more).
    start: usize,
}

impl<'a> Tokens<'a> {
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let d = self.data;
        let mut i = self.pos;
        while i < d.len() && d[i].is_ascii_whitespace() {
            if d[i] == b'\n' {
                self.line += 1;
                self.line_start = i + 1;
            }
            i += 1;
        }
        self.start = i;
        if i == d.len() {
            self.pos = i;
            return None;
        }
        while i < d.len() && !d[i].is_ascii_whitespace() {
            i += 1;
        }
        self.pos = i;
        Some(&d[self.start..i])
    }

    /// Line and column of the last token.
    fn loc(&self) -> (usize, usize) {
        (self.line, self.start - self.line_start + 1)
    }

    /// A failure at the last token.
    fn fail(&self, msg: impl Into<String>) -> Fail {
        let (line, column) = self.loc();
        fail_at(line, column, msg)
    }
}

fn parse_int(tok: &[u8]) -> Option<i64> {
    let (neg, digits) = match tok.first()? {
        b'-' => (true, &tok[1..]),
        b'+' => (false, &tok[1..]),
        _ => (false, tok),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut v: i64 = 0;
    for &b in digits {
        if !b.is_ascii_digit() {
            return None;
        }
        v = v * 10 + (b - b'0') as i64;
    }
    Some(if neg { -v } else { v })
}

/// Clinger's fast path: a decimal whose digits and power of ten are both
/// exact in the target type converts with one correctly rounded operation.
/// That covers nearly every number in scanned meshes (`-0.0378297`); the rest
/// go to the standard library.
#[inline]
fn fast_float(tok: &[u8], ty: Ty) -> Option<f32> {
    const P32: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];
    const P64: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let (neg, s) = match tok.first()? {
        b'-' => (true, &tok[1..]),
        b'+' => (false, &tok[1..]),
        _ => (false, tok),
    };
    let (mut m, mut e, mut digits, mut i) = (0u64, 0i32, 0, 0);
    while i < s.len() && s[i].is_ascii_digit() {
        m = m * 10 + (s[i] - b'0') as u64;
        digits += 1;
        i += 1;
    }
    if i < s.len() && s[i] == b'.' {
        i += 1;
        while i < s.len() && s[i].is_ascii_digit() {
            m = m * 10 + (s[i] - b'0') as u64;
            e -= 1;
            digits += 1;
            i += 1;
        }
    }
    if digits == 0 || digits > 18 {
        return None;
    }
    if i < s.len() && s[i] | 0x20 == b'e' {
        let x = parse_int(&s[i + 1..]).filter(|x| x.abs() < 1000)?;
        e += x as i32;
        i = s.len();
    }
    if i != s.len() {
        return None;
    }
    let v = if ty == Ty::F64 {
        if m > 1 << 53 || e.unsigned_abs() > 22 {
            return None;
        }
        let p = P64[e.unsigned_abs() as usize];
        (if e < 0 { m as f64 / p } else { m as f64 * p }) as f32
    } else {
        if m > 1 << 24 || e.unsigned_abs() > 10 {
            return None;
        }
        let p = P32[e.unsigned_abs() as usize];
        if e < 0 {
            m as f32 / p
        } else {
            m as f32 * p
        }
    };
    Some(if neg { -v } else { v })
}

fn parse_float(tok: &[u8], ty: Ty) -> Option<f32> {
    if let Some(v) = fast_float(tok, ty) {
        return Some(v);
    }
    let s = std::str::from_utf8(tok).ok()?;
    if ty == Ty::F64 {
        s.parse::<f64>().ok().map(|v| v as f32)
    } else {
        s.parse::<f32>().ok()
    }
}

fn ascii_body<'a>(
    data: &'a [u8],
    first_line: usize,
    elements: &[Element],
    roles: &[Vec<Role>],
    out: &mut Builder,
) -> Result<(), Fail> {
    let mut t = Tokens {
        data,
        pos: 0,
        line: first_line,
        line_start: 0,
        start: 0,
    };
    for (el, roles) in elements.iter().zip(roles) {
        // Records without properties take no text: a count of 1e19 (found by
        // fuzzing) would otherwise loop over nothing for ever.
        if el.props.is_empty() {
            continue;
        }
        let is_vertex = roles.contains(&Role::Value(0));
        for r in 0..el.count {
            let mut v = [0f32; 5];
            // Where the record's values start, for a non-finite vertex.
            let mut at = None;
            for (prop, &role) in el.props.iter().zip(roles) {
                let word = |t: &mut Tokens<'a>| -> Result<&'a [u8], Fail> {
                    t.next().ok_or_else(|| {
                        t.fail(format!(
                            "file ends early: {} {r} of {}, property `{}` is missing",
                            short(&el.name),
                            el.count,
                            short(&prop.name)
                        ))
                    })
                };
                match (prop.kind, role) {
                    (Kind::Scalar(_), Role::Skip) => {
                        word(&mut t)?;
                    }
                    (Kind::Scalar(ty), Role::Value(c)) => {
                        let w = word(&mut t)?;
                        at.get_or_insert(t.loc());
                        v[c] = parse_float(w, ty).ok_or_else(|| {
                            t.fail(format!(
                                "{} property `{}`: expected a number, found `{}`",
                                short(&el.name),
                                short(&prop.name),
                                show(w)
                            ))
                        })?;
                    }
                    (Kind::List(..), role) => {
                        let w = word(&mut t)?;
                        let n = parse_int(w).filter(|&n| n >= 0).ok_or_else(|| {
                            t.fail(format!(
                                "{} property `{}`: expected a list length, found `{}`",
                                short(&el.name),
                                short(&prop.name),
                                show(w)
                            ))
                        })?;
                        for _ in 0..n {
                            let w = word(&mut t)?;
                            if role == Role::Indices {
                                let i = parse_int(w).ok_or_else(|| {
                                    t.fail(format!(
                                        "{} property `{}`: expected an integer, found `{}`",
                                        short(&el.name),
                                        short(&prop.name),
                                        show(w)
                                    ))
                                })?;
                                out.index(i, r).map_err(|m| t.fail(m))?;
                            }
                        }
                        if role == Role::Indices {
                            out.end_face(r).map_err(|m| t.fail(m))?;
                        }
                    }
                    (Kind::Scalar(_), Role::Indices) => unreachable!("checked by plan"),
                }
            }
            if is_vertex {
                out.vertex(v).map_err(|m| {
                    let (line, column) = at.unwrap_or(t.loc());
                    fail_at(line, column, m)
                })?;
            }
        }
    }
    if t.next().is_some() {
        let Fail { msg, .. } = trailing(0, elements, false);
        return Err(t.fail(msg));
    }
    Ok(())
}

#[inline(always)]
fn bytes<const N: usize, const BE: bool>(b: &[u8]) -> [u8; N] {
    let mut a: [u8; N] = b[..N].try_into().unwrap();
    if BE {
        a.reverse();
    }
    a
}

/// Reads a scalar as f64 from the start of `b` (which holds at least its size).
#[inline(always)]
fn get<const BE: bool>(b: &[u8], ty: Ty) -> f64 {
    match ty {
        Ty::I8 => b[0] as i8 as f64,
        Ty::U8 => b[0] as f64,
        Ty::I16 => i16::from_le_bytes(bytes::<2, BE>(b)) as f64,
        Ty::U16 => u16::from_le_bytes(bytes::<2, BE>(b)) as f64,
        Ty::I32 => i32::from_le_bytes(bytes::<4, BE>(b)) as f64,
        Ty::U32 => u32::from_le_bytes(bytes::<4, BE>(b)) as f64,
        Ty::F32 => f32::from_le_bytes(bytes::<4, BE>(b)) as f64,
        Ty::F64 => f64::from_le_bytes(bytes::<8, BE>(b)),
    }
}

/// Reads an integer scalar from the start of `b`.
#[inline(always)]
fn get_int<const BE: bool>(b: &[u8], ty: Ty) -> i64 {
    match ty {
        Ty::I8 => b[0] as i8 as i64,
        Ty::U8 => b[0] as i64,
        Ty::I16 => i16::from_le_bytes(bytes::<2, BE>(b)) as i64,
        Ty::U16 => u16::from_le_bytes(bytes::<2, BE>(b)) as i64,
        Ty::I32 => i32::from_le_bytes(bytes::<4, BE>(b)) as i64,
        Ty::U32 => u32::from_le_bytes(bytes::<4, BE>(b)) as i64,
        Ty::F32 | Ty::F64 => unreachable!("integer types are checked by the header"),
    }
}

/// Reads the binary body of `data`, which starts at offset `body`.
fn binary_body<const BE: bool>(
    data: &[u8],
    body: usize,
    elements: &[Element],
    roles: &[Vec<Role>],
    out: &mut Builder,
) -> Result<(), Fail> {
    let mut pos = body;
    for (el, roles) in elements.iter().zip(roles) {
        let truncated = |r: usize, pos: usize| {
            fail_byte(
                pos,
                format!(
                    "file ends early: {} {r} of {} is cut off ({} bytes in all)",
                    short(&el.name),
                    el.count,
                    data.len()
                ),
            )
        };
        let is_vertex = roles.contains(&Role::Value(0));
        if let Some(stride) = el.props.iter().try_fold(0usize, |s, p| match p.kind {
            Kind::Scalar(ty) => Some(s + ty.size()),
            Kind::List(..) => None,
        }) {
            // Fixed-size records: check the length once, then read at offsets.
            let left = data.len() - pos;
            let need = stride.checked_mul(el.count);
            if need.is_none_or(|n| n > left) {
                let r = left / stride.max(1);
                return Err(truncated(r, pos + r * stride));
            }
            let need = need.unwrap_or(0);
            if is_vertex {
                let mut fields = Vec::new();
                let mut off = 0;
                for (p, &role) in el.props.iter().zip(roles) {
                    let Kind::Scalar(ty) = p.kind else {
                        unreachable!()
                    };
                    if let Role::Value(c) = role {
                        fields.push((off, ty, c));
                    }
                    off += ty.size();
                }
                if stride > 0 {
                    let all_f32 = fields.iter().all(|f| f.1 == Ty::F32);
                    for (k, rec) in data[pos..pos + need].chunks_exact(stride).enumerate() {
                        let mut v = [0f32; 5];
                        if all_f32 {
                            for &(o, _, c) in &fields {
                                v[c] = f32::from_le_bytes(bytes::<4, BE>(&rec[o..]));
                            }
                        } else {
                            for &(o, ty, c) in &fields {
                                v[c] = get::<BE>(&rec[o..], ty) as f32;
                            }
                        }
                        out.vertex(v).map_err(|m| fail_byte(pos + k * stride, m))?;
                    }
                }
            }
            pos += need;
            continue;
        }
        // Records with lists.
        for r in 0..el.count {
            let record = pos;
            let mut v = [0f32; 5];
            for (p, &role) in el.props.iter().zip(roles) {
                match p.kind {
                    Kind::Scalar(ty) => {
                        let b = data
                            .get(pos..pos + ty.size())
                            .ok_or_else(|| truncated(r, pos))?;
                        if let Role::Value(c) = role {
                            v[c] = get::<BE>(b, ty) as f32;
                        }
                        pos += ty.size();
                    }
                    Kind::List(ct, it) => {
                        let b = data
                            .get(pos..pos + ct.size())
                            .ok_or_else(|| truncated(r, pos))?;
                        let n = get_int::<BE>(b, ct);
                        if n < 0 {
                            return Err(fail_byte(
                                pos,
                                format!(
                                    "{} {r}: property `{}` has negative length {n}",
                                    short(&el.name),
                                    short(&p.name)
                                ),
                            ));
                        }
                        pos += ct.size();
                        let items = (n as usize)
                            .checked_mul(it.size())
                            .and_then(|len| data.get(pos..pos.checked_add(len)?))
                            .ok_or_else(|| truncated(r, pos))?;
                        let at = pos;
                        pos += items.len();
                        if role == Role::Indices {
                            let size = it.size();
                            let bad = |k: usize| move |m| fail_byte(at + k * size, m);
                            if it == Ty::I32 || it == Ty::U32 {
                                for (k, c) in items.chunks_exact(4).enumerate() {
                                    let b = bytes::<4, BE>(c);
                                    let i = if it == Ty::I32 {
                                        i32::from_le_bytes(b) as i64
                                    } else {
                                        u32::from_le_bytes(b) as i64
                                    };
                                    out.index(i, r).map_err(bad(k))?;
                                }
                            } else {
                                for (k, c) in items.chunks_exact(size).enumerate() {
                                    out.index(get_int::<BE>(c, it), r).map_err(bad(k))?;
                                }
                            }
                            out.end_face(r).map_err(|m| fail_byte(record, m))?;
                        }
                    }
                }
            }
            if is_vertex {
                out.vertex(v).map_err(|m| fail_byte(record, m))?;
            }
        }
    }
    if pos < data.len() {
        let mut f = trailing(pos, elements, false);
        f.msg = format!("{} bytes: {}", data.len() - pos, f.msg);
        return Err(f);
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// OBJ

fn parse_obj(data: &[u8]) -> Result<Noted, Fail> {
    let text = std::str::from_utf8(data).map_err(|e| {
        let (line, column) = line_column(data, e.valid_up_to());
        fail_at(line, column, "the file is not UTF-8 text")
    })?;
    // tobj drops faces of two vertices and reports bad indices without a
    // line: one linear pass over the statements first, numbers unparsed.
    let mut unused = Vec::new();
    if let Some(f) = scan_obj(text, false, &mut unused) {
        return Err(f);
    }
    // Single index, fan-triangulated, points and lines dropped.
    let opts = tobj::GPU_LOAD_OPTIONS;
    // Materials are not used; don't go looking for the .mtl file.
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| {
        scan_obj(text, true, &mut Vec::new()).unwrap_or_else(|| fail(format!("OBJ: {e}")))
    })?;
    let any_uv = models.iter().any(|m| !m.mesh.texcoords.is_empty());
    let with_uv = any_uv
        && models
            .iter()
            .all(|m| m.mesh.texcoords.len() / 2 == m.mesh.positions.len() / 3);
    let mut mesh = Mesh {
        uvs: with_uv.then(Vec::new),
        ..Default::default()
    };
    for m in &models {
        let m = &m.mesh;
        let base = mesh.positions.len();
        let n = m.positions.len() / 3;
        if base + n > u32::MAX as usize {
            return Err(fail("too many vertices for 32-bit indices"));
        }
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        if let Some(uvs) = &mut mesh.uvs {
            uvs.extend(m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], t[1])));
        }
        for t in m.indices.chunks_exact(3) {
            let tri = [t[0], t[1], t[2]];
            if tri.iter().any(|&i| i as usize >= n) {
                return Err(scan_obj(text, true, &mut Vec::new())
                    .unwrap_or_else(|| fail("OBJ: face vertex index out of range")));
            }
            mesh.indices.push(tri.map(|i| i + base as u32));
        }
    }
    let bad = mesh
        .positions
        .iter()
        .position(|p| !p.is_finite())
        .or_else(|| {
            mesh.uvs
                .as_ref()
                .and_then(|uvs| uvs.iter().position(|t| !t.is_finite()))
        });
    if let Some(i) = bad {
        let uv = mesh.uvs.as_ref().map(|u| u[i]);
        let msg = check_finite(mesh.positions[i], uv, i).unwrap_err();
        return Err(scan_obj(text, true, &mut Vec::new()).unwrap_or_else(|| fail(msg)));
    }
    let triangles = mesh.indices.len();
    let dropped = drop_degenerate(&mesh.positions, &mut mesh.indices);
    if mesh.indices.is_empty() {
        // tobj drops malformed faces silently: name the first one if any,
        // else point at the end of the file, where faces were still expected.
        let (line, column) = line_column(text.as_bytes(), text.len());
        let at_end = fail_at(line, column, no_faces(triangles));
        return Err(match triangles {
            0 => scan_obj(text, true, &mut Vec::new()).unwrap_or(at_end),
            _ => at_end,
        });
    }
    let mut notes = Vec::new();
    if !unused.is_empty() {
        let items: Vec<String> = unused
            .iter()
            .map(|(kw, n): &(String, usize)| format!("{} ({n})", echo(kw)))
            .collect();
        notes.push(format!("not used: {}", summarize(&items)));
    }
    if any_uv && !with_uv {
        notes.push("texture coordinates dropped: not every face has them".into());
    }
    if dropped > 0 {
        notes.push(dropped_note(dropped, triangles));
    }
    Ok((mesh, notes))
}

fn no_faces(triangles: usize) -> String {
    match triangles {
        0 => "the file has no faces".into(),
        n => format!("all {n} triangles are degenerate (collinear vertices)"),
    }
}

/// Whether the triangle's vertices are collinear to f32 precision: a
/// repeated vertex, or |e1 × e2| ≤ 1e-6 |e1| |e2| (an angle under 1e-6 rad
/// at `a`). Such a triangle has no area to render and no reliable normal,
/// yet intersection tests still report hits on it: the extremes suite
/// measured zero or random normals and self-hits on both backends when a
/// mesh kept them.
///
/// A triangle whose f32 cross product underflows to zero (edges of 1e-20)
/// is degenerate too, whatever its shape: its normal would be zero and the
/// intersection tests never hit it ([`crate::geometry::has_zero_area`]).
pub(crate) fn is_degenerate(p @ [a, b, c]: [Vec3; 3]) -> bool {
    if crate::geometry::has_zero_area(p) {
        return true;
    }
    // In f64, so no finite f32 coordinates overflow.
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    e1.cross(e2).length() <= 1e-6 * e1.length() * e2.length()
}

/// Drops the degenerate triangles (see [`is_degenerate`]). Most meshes have
/// none, so a parallel search comes first and the (serial) removal runs
/// only when it finds one. Returns how many it dropped.
pub(crate) fn drop_degenerate(positions: &[Vec3], indices: &mut Vec<[u32; 3]>) -> usize {
    use rayon::prelude::*;
    let degenerate = |t: &[u32; 3]| is_degenerate(t.map(|i| positions[i as usize]));
    let before = indices.len();
    if indices.par_iter().with_min_len(4096).any(degenerate) {
        indices.retain(|t| !degenerate(t));
    }
    before - indices.len()
}

/// Finds the line of the first malformed statement: a `v` of fewer than 3
/// numbers, a face of fewer than 3 vertices, an index (of a vertex, texture
/// coordinate or normal) that is 0 or past those defined so far; with
/// `numbers`, also a `v` or `vt` number that does not parse or is not
/// finite (`tobj` reports none of these with a line). Counts the statements
/// luz does not use into `unused`, by keyword. Linear in the text.
fn scan_obj(text: &str, numbers: bool, unused: &mut Vec<(String, usize)>) -> Option<Fail> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    let mut note = |kw: &str| {
        if let Some(i) = unused.iter().position(|(k, _)| k == kw) {
            unused[i].1 += 1;
        } else if unused.len() < 32 {
            // A file of random keywords must not grow the list without end.
            unused.push((kw.to_string(), 1));
        }
    };
    for (no, line) in text.lines().enumerate() {
        let no = no + 1;
        let mut words = line.split_ascii_whitespace();
        let floats = |words: std::str::SplitAsciiWhitespace, what: &str, need: usize| {
            for (k, w) in words.take(need).enumerate() {
                match w.parse::<f32>() {
                    Ok(x) if x.is_finite() => {}
                    Ok(_) => {
                        return Some(fail_at(
                            no,
                            column(line, w),
                            format!("{what} {k}: must be finite, got `{w}`"),
                        ))
                    }
                    Err(_) => {
                        return Some(fail_at(
                            no,
                            column(line, w),
                            format!(
                                "{what} {k}: expected a number, found `{}`",
                                show(w.as_bytes())
                            ),
                        ))
                    }
                }
            }
            None
        };
        match words.next() {
            Some("v") => {
                if words.clone().count() < 3 {
                    return Some(fail_at(no, 1, "vertex position needs 3 numbers"));
                }
                if numbers {
                    if let Some(f) = floats(words, "vertex coordinate", 3) {
                        return Some(f);
                    }
                }
                nv += 1;
            }
            Some("vt") => {
                if numbers {
                    if let Some(f) = floats(words, "texture coordinate", 2) {
                        return Some(f);
                    }
                }
                nvt += 1;
            }
            Some("vn") => {
                nvn += 1;
                note("vn");
            }
            Some("f") => {
                if words.clone().count() < 3 {
                    return Some(fail_at(no, 1, "a face needs at least 3 vertices"));
                }
                for c in words {
                    let mut parts = c.split('/');
                    for (what, count, required) in [
                        ("vertex", nv, true),
                        ("texture coordinate", nvt, false),
                        ("normal", nvn, false),
                    ] {
                        let part = parts.next().filter(|p| !p.is_empty());
                        let Some(p) = part else {
                            if required {
                                return Some(fail_at(
                                    no,
                                    column(line, c),
                                    format!(
                                        "face: corner `{}` has no vertex index",
                                        show(c.as_bytes())
                                    ),
                                ));
                            }
                            continue;
                        };
                        let ok = p.parse::<i64>().ok().filter(|&i| {
                            let i = if i < 0 { count + i + 1 } else { i };
                            i >= 1 && i <= count
                        });
                        if ok.is_none() {
                            return Some(fail_at(
                                no,
                                column(line, p),
                                format!(
                                    "face: {what} index `{}` is out of range ({count} so far)",
                                    show(p.as_bytes())
                                ),
                            ));
                        }
                    }
                }
            }
            Some(kw) if !kw.starts_with('#') => note(kw),
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn assets() -> PathBuf {
        std::env::var_os("LUZ_ASSETS")
            .map(PathBuf::from)
            .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/assets"))
    }

    fn temp_path(name: &str) -> PathBuf {
        static N: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "luz-mesh-io-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    fn write(name: &str, data: &[u8]) -> PathBuf {
        let path = temp_path(name);
        std::fs::write(&path, data).unwrap();
        path
    }

    fn load_str(name: &str, text: &str) -> Result<Mesh, MeshError> {
        load_mesh(&write(name, text.as_bytes()))
    }

    /// The error message, checked to start with the file's path.
    fn err(name: &str, data: &[u8]) -> String {
        let path = write(name, data);
        let e = load_mesh(&path).expect_err("should fail").to_string();
        let prefix = path.display().to_string();
        assert!(e.starts_with(&prefix), "{e}");
        e[prefix.len()..].to_string()
    }

    const ASCII: &str = "ply\r
format ascii 1.0\r
comment made by hand\r
element vertex 5\r
property float x\r
property double y\r
property int z\r
property list uchar float extra\r
property float s\r
property float t\r
element face 2\r
property uchar flags\r
property list uchar int vertex_indices\r
property list int float weights\r
element edge 1\r
property list uchar int ends\r
end_header\r
0 0 0 2 7 8 0 0\r
1 0 0 0 1 0\r
1 1.5 0 1 9 1 1\r
0 1 -2 0 0 1\r
0.5e1 2.5e-1 7 3 1 2 3 0.5 0.5\r
1 4 0 1 2 3 1 0.5\r
0 3 0 2 4 0\r
2 1 2\r
";

    fn check_example(m: &Mesh) {
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[2], Vec3::new(1.0, 1.5, 0.0));
        assert_eq!(m.positions[3], Vec3::new(0.0, 1.0, -2.0));
        assert_eq!(m.positions[4], Vec3::new(5.0, 0.25, 7.0));
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3], [0, 2, 4]]);
        let uvs = m.uvs.as_ref().expect("uvs");
        assert_eq!(uvs[1], Vec2::new(1.0, 0.0));
        assert_eq!(uvs[4], Vec2::new(0.5, 0.5));
    }

    #[test]
    fn ascii_ply_with_skipped_lists_and_quads() {
        check_example(&load_str("a.ply", ASCII).unwrap());
    }

    /// The ASCII example as binary, with the same types.
    fn binary_example(be: bool, cut: usize) -> Vec<u8> {
        let format = if be {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        };
        let header = ASCII.replace("format ascii", &format!("format {format}"));
        let header = &header[..header.find("end_header").unwrap() + 12];
        let mut out = header.as_bytes().to_vec();
        let mut put = |b: &[u8]| {
            let mut b = b.to_vec();
            if be {
                b.reverse();
            }
            out.extend_from_slice(&b);
        };
        let verts: [([f32; 3], &[f32], [f32; 2]); 5] = [
            ([0.0, 0.0, 0.0], &[7.0, 8.0], [0.0, 0.0]),
            ([1.0, 0.0, 0.0], &[], [1.0, 0.0]),
            ([1.0, 1.5, 0.0], &[9.0], [1.0, 1.0]),
            ([0.0, 1.0, -2.0], &[], [0.0, 1.0]),
            ([5.0, 0.25, 7.0], &[1.0, 2.0, 3.0], [0.5, 0.5]),
        ];
        for (p, extra, uv) in verts {
            put(&p[0].to_le_bytes());
            put(&(p[1] as f64).to_le_bytes());
            put(&(p[2] as i32).to_le_bytes());
            put(&[extra.len() as u8]);
            for e in extra {
                put(&e.to_le_bytes());
            }
            put(&uv[0].to_le_bytes());
            put(&uv[1].to_le_bytes());
        }
        let faces: [(&[i32], &[f32]); 2] = [(&[0, 1, 2, 3], &[0.5]), (&[0, 2, 4], &[])];
        for (idx, w) in faces {
            put(&[1]);
            put(&[idx.len() as u8]);
            for i in idx {
                put(&i.to_le_bytes());
            }
            put(&(w.len() as i32).to_le_bytes());
            for x in w {
                put(&x.to_le_bytes());
            }
        }
        put(&[2]);
        put(&1i32.to_le_bytes());
        put(&2i32.to_le_bytes());
        out.truncate(out.len() - cut);
        out
    }

    #[test]
    fn binary_ply_both_endians() {
        for be in [false, true] {
            let path = write("b.ply", &binary_example(be, 0));
            check_example(&load_mesh(&path).unwrap());
        }
    }

    #[test]
    fn fast_path_layout_and_index_types() {
        // float xyz + uchar/uint lists (the common layout), and ushort/short
        // indices through the general path, big endian.
        for (ct, it, be) in [
            ("uchar", "uint", false),
            ("uchar", "int", true),
            ("ushort", "short", true),
            ("uint", "uchar", false),
        ] {
            let fmt = if be { "big" } else { "little" };
            let mut data = format!(
                "ply\nformat binary_{fmt}_endian 1.0\nelement vertex 4\nproperty float x\n\
                 property float y\nproperty float z\nelement face 1\n\
                 property list {ct} {it} vertex_index\nend_header\n"
            )
            .into_bytes();
            let mut put = |b: &[u8]| {
                let mut b = b.to_vec();
                if be {
                    b.reverse();
                }
                data.extend_from_slice(&b);
            };
            for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
                for c in p {
                    put(&c.to_le_bytes());
                }
            }
            let sized = |ty: &str, v: u32| -> Vec<u8> {
                match ty {
                    "uchar" => vec![v as u8],
                    "ushort" | "short" => (v as u16).to_le_bytes().to_vec(),
                    _ => v.to_le_bytes().to_vec(),
                }
            };
            put(&sized(ct, 4));
            for i in [3, 2, 1, 0] {
                put(&sized(it, i));
            }
            let m = load_mesh(&write("f.ply", &data)).unwrap();
            assert_eq!(m.indices, vec![[3, 2, 1], [3, 1, 0]], "{ct} {it} {fmt}");
            assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0));
            assert!(m.uvs.is_none());
        }
    }

    #[test]
    fn gzipped_ply() {
        use flate2::write::GzEncoder;
        use std::io::Write;
        for data in [ASCII.as_bytes().to_vec(), binary_example(false, 0)] {
            let mut gz = GzEncoder::new(Vec::new(), flate2::Compression::default());
            gz.write_all(&data).unwrap();
            let path = write("z.ply.gz", &gz.finish().unwrap());
            check_example(&load_mesh(&path).unwrap());
        }
        let e = err("bad.ply.gz", &[0x1f, 0x8b, 8, 0, 1, 2]);
        assert!(e.contains("gzip"), "{e}");
    }

    #[test]
    fn obj_with_uvs_merged_across_objects() {
        let text = "mtllib missing.mtl\no a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                    vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n\
                    o b\nv 0 0 1\nv 1 0 1\nv 1 1 1\nvt 0.5 0.5\nf -3/1 -2/2 -1/5\n";
        let m = load_str("q.obj", text).unwrap();
        assert_eq!(m.indices.len(), 3);
        assert_eq!(m.positions.len(), 7);
        let uvs = m.uvs.as_ref().expect("uvs");
        assert_eq!(uvs.len(), 7);
        for t in &m.indices {
            for &i in t {
                assert!((i as usize) < m.positions.len());
            }
        }
        // The second object's triangle refers to its own vertices.
        let [a, b, c] = m.indices[2];
        assert_eq!(m.positions[a as usize], Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(m.positions[b as usize], Vec3::new(1.0, 0.0, 1.0));
        assert_eq!(m.positions[c as usize], Vec3::new(1.0, 1.0, 1.0));
        assert_eq!(uvs[c as usize], Vec2::new(0.5, 0.5));
        // Fan triangulation of the quad keeps its area.
        let area: f32 = (0..2).map(|i| m.triangle_area(i)).sum();
        assert!((area - 1.0).abs() < 1e-6);
        // Without vt on every vertex there are no uvs.
        let m = load_str("n.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert!(m.uvs.is_none());
    }

    fn ply(body: &str) -> String {
        format!(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
             end_header\n{body}"
        )
    }

    #[test]
    fn ascii_errors_name_line_and_field() {
        let e = err("e.ply", ply("0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n").as_bytes());
        assert_eq!(
            e,
            ":11:3: vertex property `y`: expected a number, found `abc`"
        );
        let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n3 0 1 x\n").as_bytes());
        assert!(
            e.starts_with(":13:7: face property `vertex_indices`: expected an integer"),
            "{e}"
        );
        let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n").as_bytes());
        assert_eq!(
            e,
            ":13:7: face 0: vertex index 3 is out of range (3 vertices)"
        );
        let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n").as_bytes());
        assert!(e.contains("vertex index -1 is out of range"), "{e}");
        let e = err("e.ply", ply("0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n").as_bytes());
        assert!(
            e.starts_with(":11:1: vertex 1: coordinates must be finite"),
            "{e}"
        );
        let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n").as_bytes());
        assert!(
            e.starts_with(":12:1: vertex 2: coordinates must be finite"),
            "{e}"
        );
        let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n3 0 1").as_bytes());
        assert!(e.starts_with(":13:6: file ends early: face 0 of 1"), "{e}");
        let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n2 0 1\n").as_bytes());
        assert!(e.contains(":13:5: face 0 has 2 vertices"), "{e}");
    }

    #[test]
    fn header_errors() {
        let e = err("h.ply", b"ply\nformat ascii 1.0\nelement vertex 0\n");
        assert!(e.contains("no `end_header`"), "{e}");
        let e = err(
            "h.ply",
            b"ply\nformat binary_middle_endian 1.0\nend_header\n",
        );
        assert_eq!(e, ":2:8: unsupported PLY format `binary_middle_endian`");
        let e = err("h.ply", b"solid cube\nend_header\n");
        assert!(e.starts_with(":1:1: not a PLY file"), "{e}");
        let e = err(
            "h.ply",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty flt x\nend_header\n",
        );
        assert_eq!(e, ":4:10: unknown property type `flt`");
        let e = err(
            "h.ply",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
        );
        assert!(e.contains("no `face` element"), "{e}");
        let e = err(
            "h.ply",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n0 0\n",
        );
        assert!(
            e.contains(":3:1: the `vertex` element has no `z` property"),
            "{e}"
        );
        let e = err("h.stl", b"solid\n");
        assert!(e.contains("unsupported mesh format"), "{e}");
        let missing = temp_path("missing.ply");
        let e = load_mesh(&missing).unwrap_err().to_string();
        assert!(e.starts_with(&missing.display().to_string()), "{e}");
    }

    #[test]
    fn elements_without_properties_take_no_time() {
        let text = ply("0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").replace(
            "end_header",
            "element nothing 18000000000000000000\nend_header",
        );
        let m = load_str("e.ply", &text).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn zero_faces_is_an_error() {
        let text = ply("0 0 0\n1 0 0\n0 1 0\n").replace("face 1", "face 0");
        let e = err("z.ply", text.as_bytes());
        assert_eq!(e, ":7:1: the file has no faces");
        let e = err("z.obj", b"v 0 0 0\nv 1 0 0\n");
        assert_eq!(e, ":3:1: the file has no faces");
        let e = err("d.ply", ply("0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n").as_bytes());
        assert_eq!(
            e,
            ":7:1: all 1 triangles are degenerate (collinear vertices)"
        );
    }

    #[test]
    fn binary_errors() {
        for be in [false, true] {
            for cut in [1, 5, 20, 60, 150, 200] {
                let e = err("t.ply", &binary_example(be, cut));
                assert!(
                    e.starts_with(": byte ") && e.contains(": file ends early"),
                    "{e}"
                );
            }
        }
        let e = err("t.ply", &binary_example(false, 60));
        assert!(e.contains("vertex 4 of 5"), "{e}");
        // Index 4 -> 9 in the last face.
        let mut data = binary_example(false, 0);
        let at = data.len() - 9 - 4 - 4;
        data[at..at + 4].copy_from_slice(&9i32.to_le_bytes());
        let e = err("t.ply", &data);
        assert_eq!(
            e,
            format!(": byte {at}: face 1: vertex index 9 is out of range (5 vertices)")
        );
        // A NaN x in vertex 1.
        let mut data = binary_example(false, 0);
        let body = data.windows(10).position(|w| w == b"end_header").unwrap() + 12;
        let record = body + 4 + 8 + 4 + 1 + 8 + 8;
        data[record..record + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        let e = err("t.ply", &data);
        assert!(
            e.starts_with(&format!(
                ": byte {record}: vertex 1: coordinates must be finite"
            )),
            "{e}"
        );
    }

    #[test]
    fn obj_errors_name_the_line() {
        let e = err("o.obj", b"v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n");
        assert!(
            e.starts_with(":2:5: vertex coordinate 1: expected a number, found `x`"),
            "{e}"
        );
        let e = err("o.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n");
        assert!(
            e.starts_with(":5:7: face: vertex index `4` is out of range"),
            "{e}"
        );
        let e = err("o.obj", b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
        assert!(
            e.starts_with(":2:7: vertex coordinate 2: must be finite"),
            "{e}"
        );
    }

    /// Every truncation and many byte corruptions give a result or an
    /// error, never a panic.
    #[test]
    fn damaged_files_never_panic() {
        let files = [
            ASCII.as_bytes().to_vec(),
            binary_example(false, 0),
            binary_example(true, 0),
        ];
        for data in &files {
            for n in 0..data.len() {
                let _ = parse_ply(&data[..n]);
            }
            let mut x = 0x9e37_79b9_7f4a_7c15u64;
            for _ in 0..5000 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let mut d = data.clone();
                let i = (x % d.len() as u64) as usize;
                d[i] = (x >> 32) as u8;
                let _ = parse_ply(&d);
            }
        }
    }

    #[test]
    fn fast_float_matches_std() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let digits = (x % 9) as usize;
            let int = (x >> 8) % 1_000_000;
            let frac = (x >> 30) % 10u64.pow(digits as u32);
            let sign = if x & 1 == 1 { "-" } else { "" };
            let exp = match (x >> 60) % 3 {
                0 => String::new(),
                1 => format!("e{}", (x >> 40) % 12),
                _ => format!("E-{}", (x >> 40) % 12),
            };
            let s = format!("{sign}{int}.{frac:0digits$}{exp}");
            let s = s.replace(".e", "e").replace(".E", "E");
            let s = s.trim_end_matches('.');
            let want32 = s.parse::<f32>().unwrap();
            let want64 = s.parse::<f64>().unwrap() as f32;
            assert_eq!(parse_float(s.as_bytes(), Ty::F32), Some(want32), "{s}");
            assert_eq!(parse_float(s.as_bytes(), Ty::F64), Some(want64), "{s}");
        }
        for bad in ["", "-", ".", "1.2.3", "1e", "e5", "0x10", "1,5", "--1"] {
            assert_eq!(parse_float(bad.as_bytes(), Ty::F32), None, "{bad}");
        }
        assert_eq!(
            parse_float(b"-0", Ty::F32).map(f32::to_bits),
            Some((-0f32).to_bits())
        );
        assert_eq!(parse_float(b"1.", Ty::F32), Some(1.0));
        assert_eq!(parse_float(b".5", Ty::F32), Some(0.5));
    }

    /// The hand-written parser against `ply-rs-bw` on the full bunny: same
    /// numbers, and the timings that justify not using the crate.
    #[test]
    fn bunny_matches_ply_rs_bw() {
        use ply_rs_bw::{parser::Parser, ply::DefaultElement, ply::Property};
        let path = assets().join("stanford/bunny/bun_zipper.ply");
        if !path.exists() {
            eprintln!("skipping: {} not present", path.display());
            return;
        }
        let t = std::time::Instant::now();
        let mesh = load_mesh(&path).unwrap();
        let ours = t.elapsed();
        assert_eq!(mesh.positions.len(), 35_947);
        assert_eq!(mesh.indices.len(), 69_451);

        let t = std::time::Instant::now();
        let mut f = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
        let ply = Parser::<DefaultElement>::new().read_ply(&mut f).unwrap();
        let theirs = t.elapsed();
        eprintln!(
            "bunny: luz {:.1} ms, ply-rs-bw {:.1} ms",
            ours.as_secs_f64() * 1e3,
            theirs.as_secs_f64() * 1e3
        );
        let num = |p: &Property| match p {
            Property::Float(x) => *x,
            other => panic!("unexpected {other:?}"),
        };
        for (v, p) in ply.payload["vertex"].iter().zip(&mesh.positions) {
            assert_eq!(Vec3::new(num(&v["x"]), num(&v["y"]), num(&v["z"])), *p);
        }
        let mut tris = Vec::new();
        for f in &ply.payload["face"] {
            let Property::ListInt(l) = &f["vertex_indices"] else {
                panic!("unexpected {:?}", f["vertex_indices"]);
            };
            let l: Vec<u32> = l.iter().map(|&i| i as u32).collect();
            push_polygon(&l, 0, &mut tris).unwrap();
        }
        assert_eq!(tris, mesh.indices);
    }

    #[test]
    fn all_assets_load() {
        let dir = assets();
        let cases = [
            ("stanford/bunny/bun_zipper.ply", 35_947, 69_451),
            ("stanford/bunny/bun_zipper_res2.ply", 8_171, 16_301),
            ("stanford/bunny/bun_zipper_res3.ply", 1_889, 3_851),
            ("stanford/bunny/bun_zipper_res4.ply", 453, 948),
            ("stanford/bunny/stanford-bunny.obj", 0, 69_451),
            ("stanford/dragon/dragon_vrip_res2.ply.gz", 100_250, 202_520),
            ("stanford/dragon/dragon_vrip_res3.ply", 22_998, 47_794),
            ("stanford/dragon/dragon_vrip_res4.ply", 5_205, 11_102),
            ("stanford/armadillo/armadillo.obj", 0, 29_170),
            ("stanford/lucy/lucy.ply", 49_987, 99_970),
            ("spot/spot_triangulated.obj", 0, 5_856),
            ("spot/spot_quadrangulated.obj", 0, 5_856),
            ("spot/spot_control_mesh.obj", 0, 372),
            ("teapot/teapot.obj", 0, 6_320),
            ("cornell-box/CornellBox-Original.obj", 0, 36),
        ];
        for (file, verts, tris) in cases {
            let path = dir.join(file);
            if !path.exists() {
                eprintln!("skipping {}: not present", path.display());
                continue;
            }
            // Best of three, so the timing is not the page cache's.
            let mut best = f64::INFINITY;
            let mut mesh = Mesh::default();
            for _ in 0..3 {
                let t = std::time::Instant::now();
                mesh = load_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
                best = best.min(t.elapsed().as_secs_f64() * 1e3);
            }
            eprintln!(
                "{file}: {} vertices, {} triangles, uv {}, {best:.2} ms",
                mesh.positions.len(),
                mesh.indices.len(),
                mesh.uvs.is_some(),
            );
            if verts > 0 {
                assert_eq!(mesh.positions.len(), verts, "{file}");
            }
            assert_eq!(mesh.indices.len(), tris, "{file}");
            if file.starts_with("spot") {
                assert!(mesh.uvs.is_some(), "{file}");
            }
        }
    }
}
