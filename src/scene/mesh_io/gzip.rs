//! Gzipped mesh files: a PLY parsed as it inflates, through a window of
//! [`WINDOW_BYTES`], and inflated no further than its header's counts
//! allow; an OBJ inflated whole (its reader wants the whole text).

use super::fail::Fail;
use super::ply::{parse_header, parse_ply_stream, Format, Header, Kind, Stop, Ty};
use super::{MeshError, Noted};
use crate::meter::{unmetered, Reporter, Step};
use std::io::Read;
use std::path::Path;

/// The most bytes a PLY header may take before `end_header`.
const MAX_PLY_HEADER: usize = 1 << 20;

/// The most bytes one ascii value (with its separator) may take, for the
/// bound on an ascii body: `-1.2345678901234567e-123` is 24.
const MAX_ASCII_VALUE: usize = 64;

/// How much of a gzipped PLY's inflated body is held at a time: large
/// enough that a refill's copy of the record cut off is nothing, small next
/// to the mesh it is read into.
const WINDOW_BYTES: usize = 4 << 20;

/// The most bytes deflate inflates one byte to (a 258-byte match coded in
/// two bits): with the compressed size, a bound on the body known before it
/// is read.
const MAX_DEFLATE_RATIO: usize = 1032;

/// Whether `data` starts with gzip's magic bytes.
pub(super) fn is_gzip(data: &[u8]) -> bool {
    data.starts_with(&[0x1f, 0x8b])
}

/// The failure of the gzipped file `path` that cannot be inflated.
fn gzip_error(path: &Path, e: std::io::Error) -> MeshError {
    MeshError::Invalid {
        path: path.to_path_buf(),
        msg: format!("gzip: {e}"),
    }
}

/// The decoder of the gzipped `data`, reporting the compressed bytes it
/// takes to the current step.
fn decoder(data: &[u8]) -> impl Read + '_ {
    flate2::read::MultiGzDecoder::new(Counted {
        rest: data,
        progress: Step::current(),
    })
}

/// The decompressed contents of the gzipped `data` of the file `path`,
/// whole: for an OBJ, whose reader needs all of it at once.
pub(super) fn inflate(data: &[u8], path: &Path) -> Result<Vec<u8>, MeshError> {
    let mut out = Vec::with_capacity(data.len().saturating_mul(4));
    decoder(data)
        .read_to_end(&mut out)
        .map_err(|e| gzip_error(path, e))?;
    Ok(out)
}

/// Compressed bytes, reported to the step as the decoder takes them.
struct Counted<'a> {
    rest: &'a [u8],
    progress: Reporter,
}

impl Read for Counted<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.rest.read(buf)?;
        self.progress.advance(n);
        Ok(n)
    }
}

/// The PLY mesh of the gzipped `data` of the file `path`, parsed as it
/// inflates; the step counts the compressed bytes.
pub(super) fn parse_ply(data: &[u8], path: &Path) -> Result<Noted, MeshError> {
    parse_ply_windowed(data, path, WINDOW_BYTES)
}

/// [`parse_ply`] through a window of `window` bytes. The header is
/// inflated first (at most [`MAX_PLY_HEADER`] bytes), then no more of the
/// body than its declared elements can take ([`max_body`]) and one byte: a
/// file that goes on past that is an error at the byte where the declared
/// data must end, found without inflating the rest (a 2 MB file of zeros
/// inflated to 1 GB before it was refused).
pub(super) fn parse_ply_windowed(
    data: &[u8],
    path: &Path,
    window: usize,
) -> Result<Noted, MeshError> {
    let mut decoder = decoder(data);
    let head = read_head(&mut decoder).map_err(|e| gzip_error(path, e))?;
    let header = parse_header(&head).map_err(|f: Fail| f.at(path))?;
    let limit = header.body.saturating_add(max_body(&header));
    let rest = decoder.take(limit.saturating_add(1).saturating_sub(head.len()) as u64);
    let body_hint = (limit - header.body).min(data.len().saturating_mul(MAX_DEFLATE_RATIO));
    unmetered(|| parse_ply_stream(&head, header, rest, limit, window, body_hint)).map_err(|s| {
        match s {
            Stop::Gzip(e) => gzip_error(path, e),
            Stop::Fail(f) => f.at(path),
        }
    })
}

/// The first inflated bytes of a PLY: through its `end_header` line, or
/// as many as there are up to a little more than [`MAX_PLY_HEADER`] when
/// there is none (a header the parser then refuses).
fn read_head(decoder: &mut impl Read) -> std::io::Result<Vec<u8>> {
    let mut chunk = vec![0u8; 64 << 10];
    let mut head = Vec::new();
    loop {
        let n = decoder.read(&mut chunk)?;
        head.extend_from_slice(&chunk[..n]);
        let complete = head
            .windows(11)
            .any(|w| w == b"end_header\n" || w == b"end_header\r");
        if n == 0 || complete || head.len() > MAX_PLY_HEADER {
            return Ok(head);
        }
    }
}

/// The most bytes a body can hold for the header's counts: per record, the
/// sizes of its scalars and of its lists at the longest their count type
/// allows (binary), or [`MAX_ASCII_VALUE`] per value (ascii).
fn max_body(header: &Header) -> usize {
    let value = |ty: Ty| match header.format {
        Format::Ascii => MAX_ASCII_VALUE,
        _ => ty.size(),
    };
    let max_items = |ty: Ty| -> usize {
        match ty {
            Ty::I8 => i8::MAX as usize,
            Ty::U8 => u8::MAX as usize,
            Ty::I16 => i16::MAX as usize,
            Ty::U16 => u16::MAX as usize,
            Ty::I32 => i32::MAX as usize,
            _ => u32::MAX as usize,
        }
    };
    header.elements.iter().fold(0usize, |total, el| {
        let record = el.props.iter().fold(0usize, |r, p| match p.kind {
            Kind::Scalar(ty) => r.saturating_add(value(ty)),
            Kind::List(ct, it) => r
                .saturating_add(value(ct))
                .saturating_add(max_items(ct).saturating_mul(value(it))),
        });
        total.saturating_add(record.saturating_mul(el.count))
    })
}

#[cfg(test)]
mod tests {
    use super::super::load_mesh;
    use super::super::test_support::{binary_example, check_example, err, gz, write, ASCII};
    use crate::meter::test_support::{steps, Recorder};

    #[test]
    fn gzipped_ply() {
        for data in [ASCII.as_bytes().to_vec(), binary_example(false, 0)] {
            let gz = gz(&data);
            let path = write("z.ply.gz", &gz);
            let (mesh, events) = Recorder::record(|| load_mesh(&path).unwrap());
            check_example(&mesh);
            // One step, counting the compressed bytes, not the parse of
            // what they inflate to.
            let done = steps(&events)
                .iter()
                .map(|s| (s.1, s.2))
                .collect::<Vec<_>>();
            assert_eq!(done, vec![(gz.len() as u64, gz.len() as u64)]);
        }
        let e = err("bad.ply.gz", &[0x1f, 0x8b, 8, 0, 1, 2]);
        assert!(e.contains("gzip"), "{e}");
    }
}
