//! The error of every image operation (reading, writing, tone mapping,
//! comparing), in a module of its own below `io`, `tonemap` and `metrics`
//! so that none of them imports another for it.

use std::path::PathBuf;

/// a file names it.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// A located error in a text header or ascii body (PPM).
    #[error("{}:{line}:{column}: {field}: {message}", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        column: usize,
        field: String,
        message: String,
    },
    /// A located error in binary data (PPM pixels).
    #[error("{}: byte {offset}: {field}: {message}", path.display())]
    BinaryParse {
        path: PathBuf,
        offset: usize,
        field: String,
        message: String,
    },
    /// Undecodable or unencodable data.
    #[error("{}: {message}", path.display())]
    Format { path: PathBuf, message: String },
    #[error("{}: {message}; supported: {supported}", path.display())]
    Unsupported {
        path: PathBuf,
        message: String,
        supported: &'static str,
    },
    #[error("{}: pixel ({x}, {y}) {channel} is {value}: {reason}", path.display())]
    BadValue {
        path: PathBuf,
        x: u32,
        y: u32,
        channel: &'static str,
        value: f32,
        reason: &'static str,
    },
    #[error("images differ in size: {a_width}x{a_height} vs {b_width}x{b_height}")]
    DimensionMismatch {
        a_width: u32,
        a_height: u32,
        b_width: u32,
        b_height: u32,
    },
    #[error("{0}")]
    InvalidParameter(String),
}
