//! The body of an ascii PLY: whitespace-separated values, record after
//! record, with errors at their line and column.

use super::builder::Builder;
use super::header::{Element, Kind, Property};
use super::numbers::{parse_float, parse_int};
use super::plan::Role;
use super::trailing;
use crate::scene::mesh_io::fail::{fail_at, short, show, Fail};

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

/// Reads the ascii body `data`, whose first line is line `first_line` of
/// the file.
pub(super) fn ascii_body(
    data: &[u8],
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
            record(&mut t, el, roles, r, is_vertex, out)?;
        }
    }
    if t.next().is_some() {
        let Fail { msg, .. } = trailing(0, elements, false);
        return Err(t.fail(msg));
    }
    Ok(())
}

/// Reads record `r` of `el`, a vertex when `is_vertex`.
fn record(
    t: &mut Tokens,
    el: &Element,
    roles: &[Role],
    r: usize,
    is_vertex: bool,
    out: &mut Builder,
) -> Result<(), Fail> {
    let mut v = [0f32; 5];
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
fn list(
    t: &mut Tokens,
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
fn word<'a>(t: &mut Tokens<'a>, el: &Element, prop: &Property, r: usize) -> Result<&'a [u8], Fail> {
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
fn expected(t: &Tokens, el: &Element, prop: &Property, what: &str, w: &[u8]) -> Fail {
    t.fail(format!(
        "{} property `{}`: expected {what}, found `{}`",
        short(&el.name),
        short(&prop.name),
        show(w)
    ))
}

#[cfg(test)]
mod tests {
    use crate::scene::mesh_io::test_support::{check_example, err, load_str, ply, ASCII};

    #[test]
    fn ascii_ply_with_skipped_lists_and_quads() {
        check_example(&load_str("a.ply", ASCII).unwrap());
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
    fn elements_without_properties_take_no_time() {
        let text = ply("0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").replace(
            "end_header",
            "element nothing 18000000000000000000\nend_header",
        );
        let m = load_str("e.ply", &text).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }
}
