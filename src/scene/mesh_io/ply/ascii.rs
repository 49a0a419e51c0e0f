//! The body of an ascii PLY: whitespace-separated values, record after
//! record, with errors at their line and column.
//!
//! A large body is read in parallel chunks cut at line ends, on the
//! assumption that every line holds one record, as PLY writers write them:
//! a chunk's first record is then the number of lines before it. A chunk
//! that finds the assumption broken (a record over two lines, two on one,
//! a blank line among them) or any error it cannot be sure the serial read
//! would meet first gives up, and the whole body is read serially, so the
//! mesh and every error are the serial read's. An error in a value (a bad
//! number, an index out of range, a face of two vertices) at a line where
//! every line before held one record is the serial read's error at the
//! same line and column, and is reported from the chunk.

use super::builder::Builder;
use super::header::{Element, Kind, Property};
use super::numbers::{parse_float, parse_int};
use super::plan::{Role, Vertex};
use super::trailing;
use crate::meter::Step;
use crate::scene::mesh_io::chunks::{line_chunks, lines_before, CHUNK_BYTES};
use crate::scene::mesh_io::fail::{fail_at, short, show, Fail};

/// Whitespace-separated tokens with line numbers; with `LINES`, the tokens
/// of one line at a time: a `\n` ends them as the end of the data does.
pub(super) struct Tokens<'a, const LINES: bool> {
    data: &'a [u8],
    pub(super) pos: usize,
    pub(super) line: usize,
    /// Offset of the current line's first byte.
    pub(super) line_start: usize,
    /// Offset of the last token (of the end, once there are no more).
    start: usize,
    /// Whether `next` found no more tokens (with `LINES`: on this line).
    pub(super) ended: bool,
}

impl<'a, const LINES: bool> Tokens<'a, LINES> {
    fn new(data: &'a [u8], line: usize) -> Self {
        Self::resumed(data, 0, line, 0)
    }

    /// The tokens of `data` from offset `pos` on, which is on line `line`,
    /// starting at offset `line_start`.
    pub(super) fn resumed(data: &'a [u8], pos: usize, line: usize, line_start: usize) -> Self {
        Tokens {
            data,
            pos,
            line,
            line_start,
            start: pos,
            ended: false,
        }
    }

    #[inline]
    pub(super) fn next(&mut self) -> Option<&'a [u8]> {
        let d = self.data;
        let mut i = self.pos;
        while i < d.len() && d[i].is_ascii_whitespace() {
            if d[i] == b'\n' {
                if LINES {
                    break;
                }
                self.line += 1;
                self.line_start = i + 1;
            }
            i += 1;
        }
        self.start = i;
        if i == d.len() || LINES && d[i] == b'\n' {
            self.pos = i;
            self.ended = true;
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
    pub(super) fn fail(&self, msg: impl Into<String>) -> Fail {
        let (line, column) = self.loc();
        fail_at(line, column, msg)
    }

    /// The failure of a token after the last of `elements`' records.
    pub(super) fn trailing(&self, elements: &[Element]) -> Fail {
        let Fail { msg, .. } = trailing(0, elements, false);
        self.fail(msg)
    }
}

/// Reads the ascii body `data`, whose first line is line `first_line` of
/// the file: in parallel chunks when it is large.
pub(super) fn ascii_body(
    data: &[u8],
    first_line: usize,
    elements: &[Element],
    roles: &[Vec<Role>],
    out: &mut Builder,
) -> Result<(), Fail> {
    chunked_body(data, first_line, elements, roles, out, CHUNK_BYTES)
}

/// [`ascii_body`] with chunks of about `chunk_bytes`.
fn chunked_body(
    data: &[u8],
    first_line: usize,
    elements: &[Element],
    roles: &[Vec<Role>],
    out: &mut Builder,
    chunk_bytes: usize,
) -> Result<(), Fail> {
    if data.len() > chunk_bytes {
        if let Some(r) = parallel_body(data, first_line, elements, roles, out, chunk_bytes) {
            return r;
        }
    }
    serial_body(data, first_line, elements, roles, out)
}

/// Reads the ascii body `data` token after token, as one stream.
fn serial_body(
    data: &[u8],
    first_line: usize,
    elements: &[Element],
    roles: &[Vec<Role>],
    out: &mut Builder,
) -> Result<(), Fail> {
    let mut t = Tokens::<false>::new(data, first_line);
    for (el, roles) in elements.iter().zip(roles) {
        // Records without properties take no text: a count of 1e19 (found by
        // fuzzing) would otherwise loop over nothing for ever.
        if el.props.is_empty() {
            continue;
        }
        let is_vertex = roles.contains(&Role::Value(0));
        for r in 0..el.count {
            record(&mut t, el, roles, r, is_vertex, out)?;
        }
    }
    if t.next().is_some() {
        return Err(t.trailing(elements));
    }
    Ok(())
}

/// What a chunk read.
enum Chunk {
    Read(Builder),
    /// The serial read's error, at a line after lines of one record each.
    Failed(Fail),
    /// Not one record per line, or an end the serial read must judge.
    Irregular,
}

/// The elements whose records take text, in order: (element, its index,
/// the number of records before it).
struct Layout<'e> {
    elements: Vec<(&'e Element, usize, usize)>,
    /// Records in all, saturated.
    total: usize,
    /// The `vertex` element's place in `elements`, if it has records.
    vertex: Option<usize>,
}

impl<'e> Layout<'e> {
    fn new(elements: &'e [Element], roles: &[Vec<Role>]) -> Self {
        let (mut list, mut total, mut vertex) = (Vec::new(), 0usize, None);
        for (i, (el, roles)) in elements.iter().zip(roles).enumerate() {
            if el.props.is_empty() || el.count == 0 {
                continue;
            }
            if roles.contains(&Role::Value(0)) {
                vertex = Some(list.len());
            }
            list.push((el, i, total));
            total = total.saturating_add(el.count);
        }
        Layout {
            elements: list,
            total,
            vertex,
        }
    }

    /// The place in `elements` of the element holding record `o` (< total).
    fn element_of(&self, o: usize) -> usize {
        self.elements.partition_point(|&(_, _, before)| before <= o) - 1
    }

    /// How many vertex records come before record `o`.
    fn vertices_before(&self, o: usize) -> usize {
        self.vertex.map_or(0, |k| {
            let (el, _, before) = self.elements[k];
            o.saturating_sub(before).min(el.count)
        })
    }
}

/// Reads `data` in parallel chunks of one record per line, or `None` when
/// the serial read must decide.
fn parallel_body(
    data: &[u8],
    first_line: usize,
    elements: &[Element],
    roles: &[Vec<Role>],
    out: &mut Builder,
    chunk_bytes: usize,
) -> Option<Result<(), Fail>> {
    use rayon::prelude::*;
    let layout = Layout::new(elements, roles);
    let chunks = line_chunks(data, chunk_bytes);
    let before = lines_before(data, &chunks);
    let lines = before.last().copied().unwrap_or(0)
        + super::super::chunks::newlines(&data[chunks.last()?.clone()])
        + (data.last() != Some(&b'\n')) as usize;
    if lines < layout.total {
        // The file ends early (or holds records over several lines).
        return None;
    }
    let progress = Step::current();
    let read: Vec<Chunk> = chunks
        .par_iter()
        .zip(&before)
        .map(|(range, &o)| {
            progress.advance(range.len());
            read_chunk(&data[range.clone()], first_line + o, o, &layout, roles, out)
        })
        .collect();
    let mut parts = Vec::with_capacity(read.len());
    for c in read {
        match c {
            Chunk::Read(b) => parts.push(b),
            Chunk::Failed(f) => return Some(Err(f)),
            Chunk::Irregular => return None,
        }
    }
    for part in parts {
        out.append(part);
    }
    Some(Ok(()))
}

/// Reads the lines of `data`, a chunk whose first line is line `line` of
/// the file and holds record `first` (counting the records of all elements
/// with text); `out` gives the counts and what to read.
fn read_chunk(
    data: &[u8],
    line: usize,
    first: usize,
    layout: &Layout,
    roles: &[Vec<Role>],
    out: &Builder,
) -> Chunk {
    let mut t = Tokens::<true>::new(data, line);
    let lines = super::super::chunks::newlines(data) + (data.last() != Some(&b'\n')) as usize;
    let ours = |o: usize| o.min(layout.total);
    let (first_vertex, end_vertex) = (
        layout.vertices_before(first),
        layout.vertices_before(ours(first + lines)),
    );
    let vertices = end_vertex - first_vertex;
    let mut part = out.part(first_vertex, vertices, lines - vertices.min(lines));
    let mut k = match first < layout.total {
        true => layout.element_of(first),
        false => layout.elements.len(),
    };
    let mut o = first;
    while t.pos < data.len() {
        if k == layout.elements.len() {
            // After the last record: only blank lines, else the serial read
            // reports the data after the declared elements.
            if t.next().is_some() {
                return Chunk::Irregular;
            }
        } else {
            let (el, i, before) = layout.elements[k];
            let r = o - before;
            let roles = &roles[i];
            let is_vertex = Some(k) == layout.vertex;
            while t.pos < data.len() && data[t.pos] != b'\n' && data[t.pos].is_ascii_whitespace() {
                t.pos += 1;
            }
            if t.pos == data.len() || data[t.pos] == b'\n' {
                // A blank line among the records.
                return Chunk::Irregular;
            }
            if let Err(f) = record(&mut t, el, roles, r, is_vertex, &mut part) {
                return match t.ended {
                    true => Chunk::Irregular,
                    false => Chunk::Failed(f),
                };
            }
            if t.next().is_some() {
                // More on the line than one record.
                return Chunk::Irregular;
            }
            o += 1;
            if r + 1 == el.count {
                k += 1;
            }
        }
        // At the `\n` (or the end): on to the next line.
        t.pos += 1;
        t.line += 1;
        t.line_start = t.pos;
        t.ended = false;
    }
    Chunk::Read(part)
}

/// Reads record `r` of `el`, a vertex when `is_vertex`.
pub(super) fn record<const LINES: bool>(
    t: &mut Tokens<LINES>,
    el: &Element,
    roles: &[Role],
    r: usize,
    is_vertex: bool,
    out: &mut Builder,
) -> Result<(), Fail> {
    let mut v = Vertex::default();
    // Where the record's values start, for a non-finite vertex.
    let mut at = None;
    for (prop, &role) in el.props.iter().zip(roles) {
        match (prop.kind, role) {
            (Kind::Scalar(_), Role::Skip) => {
                word(t, el, prop, r)?;
            }
            (Kind::Scalar(ty), Role::Value(c)) => {
                let w = word(t, el, prop, r)?;
                at.get_or_insert(t.loc());
                v[c] = parse_float(w, ty).ok_or_else(|| expected(t, el, prop, "a number", w))?;
            }
            (Kind::List(..), role) => list(t, el, prop, role, r, out)?,
            (Kind::Scalar(_), Role::Indices) => unreachable!("checked by plan"),
        }
    }
    if is_vertex {
        out.vertex(v).map_err(|m| {
            let (line, column) = at.unwrap_or(t.loc());
            fail_at(line, column, m)
        })?;
    }
    Ok(())
}

/// Reads the list `prop` of record `r` of `el`: a face's vertex indices
/// into `out`, or skipped.
fn list<const LINES: bool>(
    t: &mut Tokens<LINES>,
    el: &Element,
    prop: &Property,
    role: Role,
    r: usize,
    out: &mut Builder,
) -> Result<(), Fail> {
    let w = word(t, el, prop, r)?;
    let n = parse_int(w)
        .filter(|&n| n >= 0)
        .ok_or_else(|| expected(t, el, prop, "a list length", w))?;
    for _ in 0..n {
        let w = word(t, el, prop, r)?;
        if role == Role::Indices {
            let i = parse_int(w).ok_or_else(|| expected(t, el, prop, "an integer", w))?;
            out.index(i, r).map_err(|m| t.fail(m))?;
        }
    }
    if role == Role::Indices {
        out.end_face(r).map_err(|m| t.fail(m))?;
    }
    Ok(())
}

/// The next token, which must be there: a value of `prop` in record `r` of
/// `el`.
fn word<'a, const LINES: bool>(
    t: &mut Tokens<'a, LINES>,
    el: &Element,
    prop: &Property,
    r: usize,
) -> Result<&'a [u8], Fail> {
    t.next().ok_or_else(|| {
        t.fail(format!(
            "file ends early: {} {r} of {}, property `{}` is missing",
            short(&el.name),
            el.count,
            short(&prop.name)
        ))
    })
}

/// The failure of token `w` of `prop`, which is not `what`.
fn expected<const LINES: bool>(
    t: &Tokens<LINES>,
    el: &Element,
    prop: &Property,
    what: &str,
    w: &[u8],
) -> Fail {
    t.fail(format!(
        "{} property `{}`: expected {what}, found `{}`",
        short(&el.name),
        short(&prop.name),
        show(w)
    ))
}

#[cfg(test)]
#[path = "ascii_tests.rs"]
mod tests;
