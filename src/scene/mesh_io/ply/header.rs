//! The PLY header: format, elements and their typed properties.

use crate::echo::echo;
use crate::scene::mesh_io::fail::{column, fail_at, Fail};
use std::str::SplitAsciiWhitespace;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::scene::mesh_io) enum Ty {
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

    pub(in crate::scene::mesh_io) fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }

    pub(super) fn is_float(self) -> bool {
        matches!(self, Ty::F32 | Ty::F64)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::scene::mesh_io) enum Kind {
    Scalar(Ty),
    /// Count type, item type.
    List(Ty, Ty),
}

#[derive(Debug)]
pub(in crate::scene::mesh_io) struct Property {
    pub(super) name: String,
    pub(in crate::scene::mesh_io) kind: Kind,
    pub(super) line: usize,
}

#[derive(Debug)]
pub(in crate::scene::mesh_io) struct Element {
    pub(super) name: String,
    pub(in crate::scene::mesh_io) count: usize,
    pub(in crate::scene::mesh_io) props: Vec<Property>,
    pub(super) line: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::scene::mesh_io) enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

pub(in crate::scene::mesh_io) struct Header {
    pub(in crate::scene::mesh_io) format: Format,
    pub(in crate::scene::mesh_io) elements: Vec<Element>,
    /// Byte offset of the body.
    pub(in crate::scene::mesh_io) body: usize,
    /// Line number of the body's first line.
    pub(super) body_line: usize,
}

pub(in crate::scene::mesh_io) fn parse_header(data: &[u8]) -> Result<Header, Fail> {
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
            "format" => format = Some(parse_format(text, words.next(), line)?),
            "comment" | "obj_info" => {}
            "element" => elements.push(parse_element(text, words, line)?),
            "property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(fail_at(line, 1, "`property` before any `element`"));
                };
                el.props.push(parse_property(text, words, line)?);
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

/// 1-based column of `word` in `text`, or 1 for a word that is missing.
fn column_or_start(text: &str, word: Option<&str>) -> usize {
    word.map_or(1, |w| column(text, w))
}

/// The format named by `word`, the word after `format` on header line `line`.
fn parse_format(text: &str, word: Option<&str>, line: usize) -> Result<Format, Fail> {
    Ok(match word {
        Some("ascii") => Format::Ascii,
        Some("binary_little_endian") => Format::BinaryLe,
        Some("binary_big_endian") => Format::BinaryBe,
        other => {
            return Err(fail_at(
                line,
                column_or_start(text, word),
                format!("unsupported PLY format {}", echo(other.unwrap_or(""))),
            ))
        }
    })
}

/// An `element <name> <count>` line, from the words after `element`.
fn parse_element(
    text: &str,
    mut words: SplitAsciiWhitespace,
    line: usize,
) -> Result<Element, Fail> {
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
    Ok(Element {
        name: name.to_string(),
        count,
        props: Vec::new(),
        line,
    })
}

/// A `property <type> <name>` or `property list <count type> <item type>
/// <name>` line, from the words after `property`.
fn parse_property(
    text: &str,
    mut words: SplitAsciiWhitespace,
    line: usize,
) -> Result<Property, Fail> {
    let ty = |s: Option<&str>| {
        Ty::parse(s.unwrap_or("")).ok_or_else(|| {
            fail_at(
                line,
                column_or_start(text, s),
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
                column_or_start(text, word),
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
    Ok(Property {
        name: name.to_string(),
        kind,
        line,
    })
}

#[cfg(test)]
mod tests {
    use crate::scene::mesh_io::load_mesh;
    use crate::scene::mesh_io::test_support::{err, temp_path};

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
}
