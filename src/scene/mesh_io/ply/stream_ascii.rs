//! The body of an ascii PLY read through a [`Window`], by the serial
//! reader of `ascii`: the window is read up to its last line end, so no
//! token is cut, and a record whose values run on past it is forgotten and
//! read again once the window has been refilled from its line on. A line
//! is kept whole for the columns of its errors, so a body with no `\n`
//! (lines ended by `\r` alone) is held whole, within the body's limit.

use super::ascii::{record, Tokens};
use super::builder::Builder;
use super::header::Element;
use super::plan::Role;
use super::stream::Stop;
use super::window::Window;
use std::io::Read;

/// Where the reading is, as offsets in the stream: the next byte, and the
/// line it is on, which starts at `line_start`.
#[derive(Clone, Copy)]
struct Place {
    pos: usize,
    line: usize,
    line_start: usize,
}

/// The tokens of `w` from `at` up to its last line end (its end, at the
/// end of the stream).
fn tokens<R: Read>(w: &Window<R>, at: Place) -> Tokens<'_, false> {
    let data = w.bytes();
    let text = match w.at_end() {
        true => data.len(),
        false => data.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1),
    };
    let pos = at.pos - w.start();
    Tokens::resumed(
        &data[..text.max(pos)],
        pos,
        at.line,
        at.line_start - w.start(),
    )
}

fn place<R: Read>(t: &Tokens<false>, w: &Window<R>) -> Place {
    Place {
        pos: w.start() + t.pos,
        line: t.line,
        line_start: w.start() + t.line_start,
    }
}

/// Reads the ascii body that `w` starts with, whose first line is line
/// `first_line` of the file.
pub(super) fn ascii_body<R: Read>(
    w: &mut Window<R>,
    first_line: usize,
    elements: &[Element],
    roles: &[Vec<Role>],
    out: &mut Builder,
) -> Result<(), Stop> {
    let start = Place {
        pos: w.start(),
        line: first_line,
        line_start: w.start(),
    };
    let mut t = tokens(w, start);
    for (el, roles) in elements.iter().zip(roles) {
        // As in the whole file's parse: records without properties take no
        // text, however many there are.
        if el.props.is_empty() {
            continue;
        }
        let is_vertex = roles.contains(&Role::Value(0));
        let mut r = 0;
        while r < el.count {
            let (before, mark) = (place(&t, w), out.mark());
            match record(&mut t, el, roles, r, is_vertex, out) {
                Ok(()) => r += 1,
                Err(_) if t.ended && !w.at_end() => {
                    out.rollback(mark);
                    w.refill(before.line_start)?;
                    t = tokens(w, before);
                }
                Err(f) => return Err(f.into()),
            }
        }
    }
    // Anything but blanks after the last record fails at its first token.
    loop {
        if t.next().is_some() {
            return Err(t.trailing(elements).into());
        }
        if w.at_end() {
            return Ok(());
        }
        let at = place(&t, w);
        w.refill(at.line_start)?;
        t = tokens(w, at);
    }
}
