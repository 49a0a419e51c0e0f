//! OBJ files read in parallel chunks cut at line ends, for the statements
//! whose meaning luz's scan and `tobj` agree on: `v x y z`, `vt u v ...`,
//! `vn x y z ...`, faces of at least three corners `v`, `v/vt`, `v//vn` or
//! `v/vt/vn` with indices in range, `o` and `g` (which end `tobj`'s
//! models), `usemtl` with a name, `mtllib`, comments and keywords neither
//! uses.
//!
//! The mesh is `tobj`'s (`GPU_LOAD_OPTIONS`) merged as [`super::obj`]
//! merges it: per model, one vertex per distinct (v, vt, vn) in the order
//! of first use, fan triangles. Anything else (an error, `l`, `v` with a
//! weight or colours, a non-finite number, non-ASCII text outside a
//! comment, more than 32 unused keywords in a chunk) gives `None`, and the
//! file is read the serial way, which gives today's mesh or error.

use super::chunks::line_chunks;
use super::obj_merge::{build, groups};
use super::ply::{parse_float, Ty};
use super::MeshFile;
use crate::math::{PackedVec3, Vec2};
use crate::meter::Step;

/// No texture coordinate or normal at a corner.
pub(super) const MISSING: u32 = u32::MAX;

/// The most distinct unused keywords a chunk may count (as `scan_obj`).
pub(super) const MAX_UNUSED_KEYWORDS: usize = 32;

/// What one chunk read.
#[derive(Default)]
pub(super) struct Part {
    pub(super) positions: Vec<PackedVec3>,
    pub(super) texcoords: Vec<Vec2>,
    pub(super) normals: Vec<PackedVec3>,
    /// Per triangle, the position index of each corner, and the texture
    /// coordinate and normal indices once a corner has one.
    pub(super) tri_v: Vec<[u32; 3]>,
    pub(super) tri_vt: Option<Vec<[u32; 3]>>,
    pub(super) tri_vn: Option<Vec<[u32; 3]>>,
    /// The triangle counts at which an `o` or `g` came.
    pub(super) breaks: Vec<usize>,
    /// The `usemtl` and `mtllib` statements, in order.
    pub(super) groups: Vec<GroupStatement>,
    pub(super) unused: Vec<(String, usize)>,
    /// Per kind (v, vt, vn), the most a positive index goes past the
    /// chunk's own count so far: the chunk's start must be at least that.
    need: [i64; 3],
}

/// A `usemtl` or `mtllib` statement of a chunk, on the line that starts at
/// byte `at` of the chunk.
pub(super) enum GroupStatement {
    Use {
        triangle: usize,
        at: usize,
        name: String,
    },
    Library {
        at: usize,
        name: String,
    },
}

enum Outcome {
    /// Boxed: a chunk's part is large and the outcomes are moved about.
    Read(Box<Part>),
    /// A relative index, with the counts before the chunk unknown: the
    /// chunk's counts of v, vt, vn, to read it again once they are.
    Again([usize; 3]),
    /// The serial reader must decide.
    Bail,
}

/// Why a line stopped the chunk.
enum Stop {
    Relative,
    Bail,
}

/// Words of the line at `i` of `d`, up to its `\n`.
struct Cursor<'a> {
    d: &'a [u8],
    i: usize,
}

impl<'a> Cursor<'a> {
    #[inline]
    fn word(&mut self) -> Option<&'a [u8]> {
        let d = self.d;
        let mut i = self.i;
        while i < d.len() && d[i] != b'\n' && d[i].is_ascii_whitespace() {
            i += 1;
        }
        if i == d.len() || d[i] == b'\n' {
            self.i = i;
            return None;
        }
        let start = i;
        while i < d.len() && !d[i].is_ascii_whitespace() {
            i += 1;
        }
        self.i = i;
        Some(&d[start..i])
    }

    /// Past the `\n` that ends the line.
    #[inline]
    fn end_line(&mut self) {
        let d = self.d;
        while self.i < d.len() && d[self.i] != b'\n' {
            self.i += 1;
        }
        self.i = (self.i + 1).min(d.len());
    }
}

/// A finite f32 as `tobj` reads it (`f32::from_str`, which
/// [`parse_float`] matches), or stop.
#[inline]
fn float(w: Option<&[u8]>) -> Result<f32, Stop> {
    let x = w.and_then(|w| parse_float(w, Ty::F32)).ok_or(Stop::Bail)?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(Stop::Bail)
    }
}

/// An index as both `scan_obj` (`i64`) and `tobj` (`isize`) parse it.
#[inline]
fn integer(w: &[u8]) -> Option<i64> {
    let (neg, digits) = match w.first()? {
        b'-' => (true, &w[1..]),
        b'+' => (false, &w[1..]),
        _ => (false, w),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut v = 0i64;
    for &b in digits {
        if !b.is_ascii_digit() {
            return None;
        }
        v = v * 10 + (b - b'0') as i64;
    }
    Some(if neg { -v } else { v })
}

/// Counts one statement of keyword `kw` (ASCII) into `unused`.
fn count_unused(unused: &mut Vec<(String, usize)>, kw: &[u8]) -> Result<(), Stop> {
    if let Some(e) = unused.iter_mut().find(|(k, _)| k.as_bytes() == kw) {
        e.1 += 1;
    } else if unused.len() < MAX_UNUSED_KEYWORDS {
        unused.push((String::from_utf8_lossy(kw).into_owned(), 1));
    } else {
        return Err(Stop::Bail);
    }
    Ok(())
}

/// Reads chunk `d`; `start` holds the counts of v, vt and vn before it
/// when known.
fn read_chunk(d: &[u8], start: Option<[usize; 3]>) -> Outcome {
    // Outside comments, `tobj`'s Unicode words are `scan_obj`'s ASCII words
    // only in ASCII text without vertical tabs.
    let plain = d.is_ascii() && !d.contains(&0x0b);
    if !plain && std::str::from_utf8(d).is_err() {
        return Outcome::Bail;
    }
    let mut p = Part::default();
    let mut c = Cursor { d, i: 0 };
    let mut counting = false;
    let mut counts = [0usize; 3];
    while c.i < d.len() {
        let line_start = c.i;
        let Some(kw) = c.word() else {
            c.end_line();
            continue;
        };
        if kw[0] == b'#' {
            c.end_line();
            continue;
        }
        if !plain {
            let end = d[line_start..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(d.len(), |k| line_start + k);
            let line = &d[line_start..end];
            if !line.is_ascii() || line.contains(&0x0b) {
                return Outcome::Bail;
            }
        }
        if counting {
            match kw {
                b"v" => counts[0] += 1,
                b"vt" => counts[1] += 1,
                b"vn" => counts[2] += 1,
                _ => {}
            }
            c.end_line();
            continue;
        }
        match statement(&mut c, kw, line_start, start, &mut p) {
            Ok(()) => {}
            Err(Stop::Bail) => return Outcome::Bail,
            Err(Stop::Relative) => {
                counting = true;
                counts = [p.positions.len(), p.texcoords.len(), p.normals.len()];
                // The line is a face: it counts nothing.
            }
        }
        c.end_line();
    }
    if counting {
        Outcome::Again(counts)
    } else {
        Outcome::Read(Box::new(p))
    }
}

/// Reads the statement of keyword `kw` on the line at byte `line_start`,
/// the cursor after the keyword.
#[inline]
fn statement(
    c: &mut Cursor,
    kw: &[u8],
    line_start: usize,
    start: Option<[usize; 3]>,
    p: &mut Part,
) -> Result<(), Stop> {
    match kw {
        b"v" => {
            let v = PackedVec3::new(float(c.word())?, float(c.word())?, float(c.word())?);
            if c.word().is_some() {
                // A weight, colours or anything else: `tobj` reads them.
                return Err(Stop::Bail);
            }
            p.positions.push(v);
        }
        b"vt" => {
            p.texcoords
                .push(Vec2::new(float(c.word())?, float(c.word())?));
        }
        b"vn" => {
            // A normal that is not finite is the serial reader's error.
            p.normals.push(PackedVec3::new(
                float(c.word())?,
                float(c.word())?,
                float(c.word())?,
            ));
        }
        b"f" => face(c, start, p)?,
        b"o" | b"g" => {
            p.breaks.push(p.tri_v.len());
            count_unused(&mut p.unused, kw)?;
        }
        b"l" => return Err(Stop::Bail),
        b"usemtl" | b"mtllib" => group_statement(c, kw, line_start, p)?,
        _ => count_unused(&mut p.unused, kw)?,
    }
    Ok(())
}

/// A `usemtl` or `mtllib` statement, as [`statement`] reads it: rare, so
/// kept out of the loop over the file's lines.
#[cold]
#[inline(never)]
fn group_statement(c: &mut Cursor, kw: &[u8], line_start: usize, p: &mut Part) -> Result<(), Stop> {
    let d = c.d;
    let end = d[line_start..]
        .iter()
        .position(|&b| b == b'\n')
        .map_or(d.len(), |k| line_start + k);
    let text = &d[line_start..end];
    // `tobj` takes the name after the first space, trimmed; none is
    // its error.
    let after_space = text
        .iter()
        .position(|&b| b == b' ')
        .map_or(&text[..0], |k| &text[k + 1..]);
    if kw == b"usemtl" && after_space.trim_ascii().is_empty() {
        return Err(Stop::Bail);
    }
    // The name is all that follows the keyword (ASCII here).
    let name = String::from_utf8_lossy(d[c.i..end].trim_ascii()).into_owned();
    p.groups.push(match kw {
        b"usemtl" => GroupStatement::Use {
            triangle: p.tri_v.len(),
            at: line_start,
            name,
        },
        _ => GroupStatement::Library {
            at: line_start,
            name,
        },
    });
    Ok(())
}

/// Reads a face's corners into fan triangles.
#[inline]
fn face(c: &mut Cursor, start: Option<[usize; 3]>, p: &mut Part) -> Result<(), Stop> {
    let here = [p.positions.len(), p.texcoords.len(), p.normals.len()];
    let mut first = [MISSING; 3];
    let mut prev = [MISSING; 3];
    let mut n = 0;
    let tris = p.tri_v.len();
    while let Some(w) = c.word() {
        let key = corner(w, here, start, &mut p.need)?;
        match n {
            0 => first = key,
            1 => prev = key,
            _ => {
                p.tri_v.push([first[0], prev[0], key[0]]);
                for (k, list) in [(1, &mut p.tri_vt), (2, &mut p.tri_vn)] {
                    let t = [first[k], prev[k], key[k]];
                    if list.is_none() && t != [MISSING; 3] {
                        *list = Some(vec![[MISSING; 3]; tris + n - 2]);
                    }
                    if let Some(list) = list {
                        list.push(t);
                    }
                }
                prev = key;
            }
        }
        n += 1;
    }
    if n < 3 {
        return Err(Stop::Bail);
    }
    Ok(())
}

/// One corner `v[/vt[/vn]]` as absolute indices, `MISSING` for an empty
/// part; `here` holds the chunk's counts so far.
#[inline]
fn corner(
    w: &[u8],
    here: [usize; 3],
    start: Option<[usize; 3]>,
    need: &mut [i64; 3],
) -> Result<[u32; 3], Stop> {
    let mut key = [MISSING; 3];
    for (k, part) in w.split(|&b| b == b'/').enumerate() {
        if k == 3 {
            return Err(Stop::Bail);
        }
        if part.is_empty() {
            if k == 0 {
                return Err(Stop::Bail);
            }
            continue;
        }
        let x = integer(part).ok_or(Stop::Bail)?;
        let local = here[k] as i64;
        key[k] = if x > 0 {
            if x >= MISSING as i64 {
                return Err(Stop::Bail);
            }
            need[k] = need[k].max(x - local);
            (x - 1) as u32
        } else if x < 0 {
            let Some(start) = start else {
                return Err(Stop::Relative);
            };
            let i = start[k] as i64 + local + x;
            if i < 0 || i >= MISSING as i64 {
                return Err(Stop::Bail);
            }
            i as u32
        } else {
            return Err(Stop::Bail);
        };
    }
    Ok(key)
}

/// Reads the OBJ file `data` in chunks of about `chunk_bytes`, or `None`
/// when the serial reader must.
pub(super) fn parse_obj_chunks(data: &[u8], chunk_bytes: usize) -> Option<MeshFile> {
    use rayon::prelude::*;
    let chunks = line_chunks(data, chunk_bytes);
    let progress = Step::current();
    let first: Vec<Outcome> = chunks
        .par_iter()
        .enumerate()
        .map(|(k, r)| {
            progress.advance(r.len());
            read_chunk(&data[r.clone()], (k == 0).then_some([0; 3]))
        })
        .collect();
    let counts = |o: &Outcome| match o {
        Outcome::Read(p) => Some([p.positions.len(), p.texcoords.len(), p.normals.len()]),
        Outcome::Again(c) => Some(*c),
        Outcome::Bail => None,
    };
    let mut starts = Vec::with_capacity(first.len());
    let mut sum = [0usize; 3];
    for o in &first {
        starts.push(sum);
        let c = counts(o)?;
        for k in 0..3 {
            sum[k] += c[k];
        }
    }
    if sum[0] >= MISSING as usize || sum[1] >= MISSING as usize || sum[2] >= MISSING as usize {
        return None;
    }
    let parts: Vec<Outcome> = first
        .into_par_iter()
        .zip(&chunks)
        .zip(&starts)
        .map(|((o, r), &s)| match o {
            Outcome::Again(_) => read_chunk(&data[r.clone()], Some(s)),
            o => o,
        })
        .collect();
    let mut read = Vec::with_capacity(parts.len());
    for (o, s) in parts.into_iter().zip(&starts) {
        let Outcome::Read(p) = o else {
            return None;
        };
        if (0..3).any(|k| p.need[k] > s[k] as i64) {
            // An index past the count so far: `scan_obj`'s error.
            return None;
        }
        read.push(*p);
    }
    let groups = groups(data, &chunks, &read);
    build(read, groups)
}
