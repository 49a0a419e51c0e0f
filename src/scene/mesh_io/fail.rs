//! Parse failures before the path is attached, with their place in the file,
//! and the shortening of names and tokens quoted in their messages.

use super::checks::no_faces;
use super::MeshError;
use crate::echo::echo;
use std::path::Path;

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
pub(super) struct Fail {
    at: Option<Loc>,
    pub(super) msg: String,
    /// Every triangle of the file is degenerate ([`MeshError::NoArea`]).
    no_area: bool,
}

impl Fail {
    pub(super) fn at(self, path: &Path) -> MeshError {
        let path = path.to_path_buf();
        let msg = self.msg;
        match self.at {
            Some(Loc::Text(line, column)) if self.no_area => MeshError::NoArea {
                path,
                place: format!("{line}:{column}"),
                msg,
            },
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
pub(super) fn fail(msg: impl Into<String>) -> Fail {
    Fail {
        at: None,
        msg: msg.into(),
        no_area: false,
    }
}

pub(super) fn fail_at(line: usize, column: usize, msg: impl Into<String>) -> Fail {
    Fail {
        at: Some(Loc::Text(line, column)),
        msg: msg.into(),
        no_area: false,
    }
}

/// The failure of a file whose `triangles` triangles are all degenerate,
/// or that has none, at the line where faces were expected.
pub(super) fn no_triangles(line: usize, column: usize, triangles: usize) -> Fail {
    Fail {
        no_area: triangles > 0,
        ..fail_at(line, column, no_faces(triangles))
    }
}

pub(super) fn fail_byte(offset: usize, msg: impl Into<String>) -> Fail {
    Fail {
        at: Some(Loc::Byte(offset)),
        msg: msg.into(),
        no_area: false,
    }
}

/// 1-based column of `word`, a slice of `line`.
pub(super) fn column(line: &str, word: &str) -> usize {
    word.as_ptr() as usize - line.as_ptr() as usize + 1
}

/// A name from the header for a message: itself, or [`echo`]'s shortened
/// form when long.
pub(super) fn short(name: &str) -> std::borrow::Cow<'_, str> {
    if name.len() <= 60 {
        name.into()
    } else {
        echo(name).into()
    }
}

/// A token for an error message: lossy UTF-8, cut short when long.
pub(super) fn show(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(tok);
    if s.chars().count() > 40 {
        format!("{}...", s.chars().take(40).collect::<String>())
    } else {
        s.into_owned()
    }
}
