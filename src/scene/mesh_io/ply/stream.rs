//! A PLY parsed as it is inflated: the body read through a [`Window`] of
//! bounded size, the records it holds by the same functions that read a
//! file held whole, with the offsets, lines and failures of the file as if
//! it had been inflated whole.
//!
//! Where the parse of the whole file would judge a failure by what comes
//! after it, the stream is read on to its end (dropping what it reads) to
//! judge it alike: a body longer than its limit fails there first, and a
//! fixed-size element cut short fails as cut short before any bad value
//! in it. Binary faces are read record by record, not in parallel bulk:
//! the window is read as it inflates, on one thread. A record longer than
//! the window (a list of millions of items) grows it to hold the record.

use super::binary::{self, cut_element, get_int, trailing_bytes, truncated};
use super::builder::Builder;
use super::header::{Element, Format, Header, Kind};
use super::plan::{plan, Plan, Role};
use super::window::Window;
use super::{finish, stream_ascii, trailing, Noted};
use crate::scene::mesh_io::fail::Fail;
use std::io::Read;

/// Why a streamed parse stopped.
pub(in crate::scene::mesh_io) enum Stop {
    /// The stream could not be read (a broken gzip file).
    Gzip(std::io::Error),
    Fail(Fail),
}

impl From<Fail> for Stop {
    fn from(f: Fail) -> Self {
        Stop::Fail(f)
    }
}

impl From<std::io::Error> for Stop {
    fn from(e: std::io::Error) -> Self {
        Stop::Gzip(e)
    }
}

/// Parses the PLY whose stream begins with `head`, which holds its whole
/// `header`, and goes on in `rest`, through a window of `window` bytes.
/// The stream may be no longer than `limit` bytes (`rest` gives at most one
/// more), which fails at that byte, as trailing data, whatever else is
/// wrong after the header; `body_hint` is the most bytes the body could
/// have, for the room reserved for the mesh.
pub(in crate::scene::mesh_io) fn parse_ply_stream(
    head: &[u8],
    header: Header,
    rest: impl Read,
    limit: usize,
    window: usize,
    body_hint: usize,
) -> Result<Noted, Stop> {
    // What of the body came with the header is read through the window too.
    let body = &head[header.body.min(head.len())..];
    let mut w = Window::new(header.body, body.chain(rest), window);
    let read = read_body(&mut w, &header, body_hint);
    if let Err(Stop::Gzip(e)) = read {
        return Err(Stop::Gzip(e));
    }
    if w.total()? > limit {
        return Err(trailing(limit, &header.elements, true).into());
    }
    let (plan, out) = read?;
    Ok(finish(&header, &plan, out)?)
}

/// The plan of `header`, and the body read by it from `w`.
fn read_body<R: Read>(
    w: &mut Window<R>,
    header: &Header,
    body_hint: usize,
) -> Result<(Plan, Builder), Stop> {
    let plan = plan(&header.elements, header.body_line - 1)?;
    let (nv, nf) = (
        header.elements[plan.vertex].count,
        header.elements[plan.face].count,
    );
    let mut out = Builder::new(nv, nf, &plan, body_hint);
    let (elements, roles) = (&header.elements, &plan.roles);
    match header.format {
        Format::Ascii => stream_ascii::ascii_body(w, header.body_line, elements, roles, &mut out)?,
        Format::BinaryLe => binary_body::<false, R>(w, elements, roles, &mut out)?,
        Format::BinaryBe => binary_body::<true, R>(w, elements, roles, &mut out)?,
    }
    Ok((plan, out))
}

/// Reads the binary body that `w` starts with.
fn binary_body<const BE: bool, R: Read>(
    w: &mut Window<R>,
    elements: &[Element],
    roles: &[Vec<Role>],
    out: &mut Builder,
) -> Result<(), Stop> {
    let mut pos = w.start();
    for (el, roles) in elements.iter().zip(roles) {
        let stride = el.props.iter().try_fold(0usize, |s, p| match p.kind {
            Kind::Scalar(ty) => Some(s + ty.size()),
            Kind::List(..) => None,
        });
        pos = match stride {
            Some(stride) => fixed_records::<BE, R>(w, pos, stride, el, roles, out)?,
            None => list_records::<BE, R>(w, pos, el, roles, out)?,
        };
    }
    let total = w.total()?;
    if pos < total {
        return Err(trailing_bytes(pos, total, elements).into());
    }
    Ok(())
}

/// Reads the records of `el`, all `stride` bytes long, from offset `first`
/// on, as many at a time as the window holds; returns the offset after
/// them.
fn fixed_records<const BE: bool, R: Read>(
    w: &mut Window<R>,
    first: usize,
    stride: usize,
    el: &Element,
    roles: &[Role],
    out: &mut Builder,
) -> Result<usize, Stop> {
    if stride == 0 {
        return Ok(first);
    }
    let is_vertex = roles.contains(&Role::Value(0));
    let (mut pos, mut left) = (first, el.count);
    while left > 0 {
        let whole = ((w.end() - pos) / stride).min(left);
        if whole == 0 {
            if w.at_end() {
                return Err(truncated(w.end(), el, el.count - left, pos).into());
            }
            w.refill(pos)?;
            continue;
        }
        if is_vertex {
            let at = pos - w.start();
            let records = &w.bytes()[at..at + whole * stride];
            if let Err(f) = binary::fixed_vertices::<BE>(records, pos, stride, el, roles, out) {
                // The whole file's parse checks the element's length first.
                let cut = cut_element(w.total()?, first, stride, el);
                return Err(cut.unwrap_or(f).into());
            }
        }
        pos += whole * stride;
        left -= whole;
    }
    Ok(pos)
}

/// Reads the records of `el`, which has lists, from offset `pos` on, as
/// many at a time as the window holds whole; returns the offset after them.
fn list_records<const BE: bool, R: Read>(
    w: &mut Window<R>,
    mut pos: usize,
    el: &Element,
    roles: &[Role],
    out: &mut Builder,
) -> Result<usize, Stop> {
    let mut r = 0;
    while r < el.count {
        let whole = whole_records::<BE>(&w.bytes()[pos - w.start()..], el, el.count - r);
        if whole == 0 && !w.at_end() {
            w.refill(pos)?;
            continue;
        }
        // At the end of the stream, a record cut off fails as it does in
        // the whole file.
        let n = whole.max(1);
        let (data, base) = (w.bytes(), w.start());
        pos = binary::list_records::<BE>(data, base, pos, el, roles, r..r + n, out)?;
        r += n;
    }
    Ok(pos)
}

/// How many whole records of `el` (at most `max`) `data` starts with. A
/// record with a negative list length counts as whole, and as the last:
/// its failure needs nothing after the length.
fn whole_records<const BE: bool>(data: &[u8], el: &Element, max: usize) -> usize {
    let mut end = 0;
    for k in 0..max {
        let mut at = end;
        for p in &el.props {
            let size = match p.kind {
                Kind::Scalar(ty) => Some(ty.size()),
                Kind::List(ct, it) => {
                    let Some(count) = data.get(at..at + ct.size()) else {
                        return k;
                    };
                    let n = get_int::<BE>(count, ct);
                    if n < 0 {
                        return k + 1;
                    }
                    at += ct.size();
                    (n as usize).checked_mul(it.size())
                }
            };
            match size.and_then(|s| at.checked_add(s)) {
                Some(next) if next <= data.len() => at = next,
                _ => return k,
            }
        }
        end = at;
    }
    max
}
