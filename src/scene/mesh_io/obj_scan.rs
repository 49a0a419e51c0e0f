//! A pass over an OBJ file's statements that finds what `tobj` drops
//! silently or reports without a line, and counts what luz does not use.

use super::fail::{column, fail_at, show, Fail};
use super::groups::GroupsBuilder;
use std::str::SplitWhitespace;

/// The most distinct unused keywords counted: a file of random keywords
/// must not grow the list without end.
const MAX_UNUSED_KEYWORDS: usize = 32;

/// What a scan saw besides errors.
#[derive(Default)]
pub(super) struct Seen {
    /// The statements luz does not use, by keyword.
    pub(super) unused: Vec<(String, usize)>,
    /// The `usemtl` and `mtllib` statements.
    pub(super) groups: GroupsBuilder,
    /// The triangles of the faces so far, fan-triangulated.
    pub(super) triangles: usize,
}

/// Finds the line of the first malformed statement: a `v` of fewer than 3
/// numbers, a face of fewer than 3 vertices, an index (of a vertex, texture
/// coordinate or normal) that is 0 or past those defined so far, a
/// `usemtl` without a name; with `numbers`, also a `v` or `vt` number that
/// does not parse or is not finite (`tobj` reports none of these with a
/// line). Records what else it sees into `seen`. Linear in the text.
pub(super) fn scan_obj(text: &str, numbers: bool, seen: &mut Seen) -> Option<Fail> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    for (no, line) in text.lines().enumerate() {
        let no = no + 1;
        // `tobj` splits at Unicode white space, the vertical tab included.
        let mut words = line.split_whitespace();
        let kw = words.clone().next();
        // What follows the keyword: names may hold spaces.
        let rest = || kw.map_or("", |kw| line[column(line, kw) - 1 + kw.len()..].trim());
        match words.next() {
            Some("v") => {
                if words.clone().count() < 3 {
                    return Some(fail_at(no, 1, "vertex position needs 3 numbers"));
                }
                if numbers {
                    if let Some(f) = check_floats(line, no, words, "vertex coordinate", 3) {
                        return Some(f);
                    }
                }
                nv += 1;
            }
            Some("vt") => {
                if numbers {
                    if let Some(f) = check_floats(line, no, words, "texture coordinate", 2) {
                        return Some(f);
                    }
                }
                nvt += 1;
            }
            Some("vn") => {
                if words.clone().count() < 3 {
                    return Some(fail_at(no, 1, "vertex normal needs 3 numbers"));
                }
                if numbers {
                    if let Some(f) = check_floats(line, no, words, "vertex normal", 3) {
                        return Some(f);
                    }
                }
                nvn += 1;
            }
            Some("f") => {
                let corners = words.clone().count();
                if let Some(f) = check_face(line, no, words, [nv, nvt, nvn]) {
                    return Some(f);
                }
                seen.triangles += corners - 2;
            }
            Some("usemtl") => {
                if rest().is_empty() {
                    return Some(fail_at(no, 1, "`usemtl` needs a material name"));
                }
                seen.groups.use_material(seen.triangles, rest(), no);
            }
            Some("mtllib") => seen.groups.library(rest(), no),
            Some("l") => {
                // `tobj` reads a line of three or more points as a polygon.
                seen.triangles += words.count().saturating_sub(2);
                count_unused(&mut seen.unused, "l");
            }
            Some(kw) if !kw.starts_with('#') => count_unused(&mut seen.unused, kw),
            _ => {}
        }
    }
    None
}

/// Counts one statement of keyword `kw` into `unused`.
fn count_unused(unused: &mut Vec<(String, usize)>, kw: &str) {
    if let Some(i) = unused.iter().position(|(k, _)| k == kw) {
        unused[i].1 += 1;
    } else if unused.len() < MAX_UNUSED_KEYWORDS {
        unused.push((kw.to_string(), 1));
    }
}

/// Fails at the first of the `need` first `words` of `line` (line `no`)
/// that is not a finite number; `what` names them.
fn check_floats(
    line: &str,
    no: usize,
    words: SplitWhitespace,
    what: &str,
    need: usize,
) -> Option<Fail> {
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
}

/// Fails at the first malformed corner of the face `words` of `line` (line
/// `no`), with the counts of vertices, texture coordinates and normals so
/// far.
fn check_face(
    line: &str,
    no: usize,
    words: SplitWhitespace,
    [nv, nvt, nvn]: [i64; 3],
) -> Option<Fail> {
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
                        format!("face: corner `{}` has no vertex index", show(c.as_bytes())),
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
    None
}

#[cfg(test)]
mod tests {
    use crate::scene::mesh_io::test_support::{err, load_str};

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

    /// A vertical tab separates words for `tobj`, though it is not ASCII
    /// white space: the scan must see the statements `tobj` reads.
    #[test]
    fn vertical_tab_separates_words_as_in_tobj() {
        let e = err("o.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n\x0bf 1 2 4\n");
        assert!(
            e.starts_with(":4:8: face: vertex index `4` is out of range"),
            "{e}"
        );
        // Found by `fuzz_props::obj_mutated`: a quad and a face after a
        // vertical tab make three triangles, as the scan counts them.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
            f 1/1 2/2 3/3 4/4\n\u{b}f -1 -2 -3\n";
        let mesh = load_str("t.obj", text).unwrap();
        assert_eq!(mesh.indices.len(), 3);
    }
}
