//! What can go wrong in the Embree backend, in terms Embree 3 and Embree 4
//! share (their `RTCError` codes are the same), so that each version's
//! module reports its failures as the same kinds.

use std::fmt;

/// Embree's `RTCError`: the kind of a failure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorCode {
    /// `RTC_ERROR_NONE`: the thread's code was clear although the error
    /// callback reported something (the report can come from another
    /// thread's call on the same device).
    None,
    Unknown,
    InvalidArgument,
    InvalidOperation,
    OutOfMemory,
    UnsupportedCpu,
    Cancelled,
    /// A code this luz does not know, from a newer Embree.
    Other(u32),
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Self::None => "no error",
            Self::Unknown => "unknown error",
            Self::InvalidArgument => "invalid argument",
            Self::InvalidOperation => "invalid operation",
            Self::OutOfMemory => "out of memory",
            Self::UnsupportedCpu => "unsupported CPU",
            Self::Cancelled => "cancelled",
            Self::Other(code) => return write!(f, "unknown error {code}"),
        };
        f.write_str(name)
    }
}

/// One error that Embree's error callback reported: its code and Embree's
/// own message (which may be empty).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Report {
    pub code: ErrorCode,
    pub message: String,
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.message.is_empty() {
            write!(f, "{}", self.code)
        } else {
            write!(f, "{} ({})", self.message, self.code)
        }
    }
}

/// Embree's reports of a failed call, or its code alone when the callback
/// reported nothing.
fn detail(code: ErrorCode, reports: &[Report]) -> String {
    if reports.is_empty() {
        return code.to_string();
    }
    let lines: Vec<String> = reports.iter().map(Report::to_string).collect();
    lines.join("; ")
}

#[derive(Debug, thiserror::Error)]
pub enum EmbreeError {
    /// A device configuration C cannot be handed: it holds a NUL byte.
    #[error("rtcNewDevice: the device configuration contains a NUL byte")]
    ConfigHasNul,
    /// `rtcNewDevice` returned no device. Embree 3 keeps only the code of
    /// an error without a device: its callback is not installed yet.
    #[error("rtcNewDevice failed: {code}")]
    Device { code: ErrorCode },
    /// Embree reported an error for `call` (the function called, with the
    /// kind of geometry where one function serves several).
    #[error("{call}: {}", detail(*code, reports))]
    Call {
        call: &'static str,
        /// The thread's error code after the call.
        code: ErrorCode,
        /// What the error callback reported since the previous check.
        reports: Vec<Report>,
    },
    /// `call` returned a null handle yet reported no error.
    #[error("{call} returned null")]
    NullHandle { call: &'static str },
    /// More shapes than there are geometry ids (`RTC_INVALID_GEOMETRY_ID`
    /// is the last `u32`).
    #[error("{shapes} shapes, more than Embree has ids")]
    TooManyShapes { shapes: usize },
    /// A triangle with an index past the mesh's vertices, which Embree
    /// would read without checking.
    #[error(
        "shape {shape}: triangle {triangle} refers to vertex {vertex}, but the mesh has {vertices} vertices"
    )]
    VertexOutOfRange {
        shape: u32,
        triangle: usize,
        vertex: u32,
        vertices: usize,
    },
    /// A shape that would be user geometry without finite bounds, which
    /// every Embree primitive needs.
    #[error("shape {shape} ({kind}) has no finite bounds")]
    Unbounded { shape: u32, kind: &'static str },
}
