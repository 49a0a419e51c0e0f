//! Gzipped mesh files, and the bound on how far a gzipped PLY is inflated.

use super::fail::Fail;
use super::ply::{parse_header, trailing, Format, Header, Kind, Ty};
use super::MeshError;
use crate::meter::{Reporter, Step};
use std::io::Read;
use std::path::Path;

/// The most bytes a PLY header may take before `end_header`.
const MAX_PLY_HEADER: usize = 1 << 20;

/// The most bytes one ascii value (with its separator) may take, for the
/// bound on an ascii body: `-1.2345678901234567e-123` is 24.
const MAX_ASCII_VALUE: usize = 64;

/// Whether `data` starts with gzip's magic bytes.
pub(super) fn is_gzip(data: &[u8]) -> bool {
    data.starts_with(&[0x1f, 0x8b])
}

/// The decompressed contents of the gzipped `data` of the file `path`; of a
/// PLY (`is_ply`), no more than [`inflate_ply`] allows.
pub(super) fn inflate(data: &[u8], is_ply: bool, path: &Path) -> Result<Vec<u8>, MeshError> {
    let gzip = |e: std::io::Error| MeshError::Invalid {
        path: path.to_path_buf(),
        msg: format!("gzip: {e}"),
    };
    let mut decoder = flate2::read::MultiGzDecoder::new(Counted {
        rest: data,
        progress: Step::current(),
    });
    let mut out = Vec::new();
    if is_ply {
        inflate_ply(&mut decoder, &mut out).map_err(|e| match e {
            Inflate::Gzip(e) => gzip(e),
            Inflate::Fail(f) => f.at(path),
        })?;
    } else {
        out.reserve(data.len().saturating_mul(4));
        decoder.read_to_end(&mut out).map_err(gzip)?;
    }
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

enum Inflate {
    Gzip(std::io::Error),
    Fail(Fail),
}

/// Inflates a gzipped PLY into `out`: the header first (at most
/// [`MAX_PLY_HEADER`] bytes), then no more of the body than its declared
/// elements can take ([`max_body`]) and one byte: a file that goes on past
/// that is an error at the byte where the declared data must end, found
/// before the rest is inflated (a 2 MB file of zeros inflated to 1 GB
/// before it was refused).
fn inflate_ply(decoder: &mut impl Read, out: &mut Vec<u8>) -> Result<(), Inflate> {
    let mut chunk = vec![0u8; 64 << 10];
    let header = loop {
        let n = decoder.read(&mut chunk).map_err(Inflate::Gzip)?;
        out.extend_from_slice(&chunk[..n]);
        let complete = out
            .windows(11)
            .position(|w| w == b"end_header\n" || w == b"end_header\r")
            .is_some();
        if n == 0 || complete || out.len() > MAX_PLY_HEADER {
            // A broken header is reported by the parser, from what is here.
            match parse_header(out) {
                Ok(h) => break h,
                Err(_) => return Ok(()),
            }
        }
    };
    let limit = header.body.saturating_add(max_body(&header));
    if out.len() <= limit {
        let left = (limit - out.len()) as u64 + 1;
        decoder.take(left).read_to_end(out).map_err(Inflate::Gzip)?;
    }
    if out.len() > limit {
        return Err(Inflate::Fail(trailing(limit, &header.elements, true)));
    }
    Ok(())
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
    use super::super::test_support::{binary_example, check_example, err, write, ASCII};
    use crate::meter::test_support::{steps, Recorder};

    #[test]
    fn gzipped_ply() {
        use flate2::write::GzEncoder;
        use std::io::Write;
        for data in [ASCII.as_bytes().to_vec(), binary_example(false, 0)] {
            let mut gz = GzEncoder::new(Vec::new(), flate2::Compression::default());
            gz.write_all(&data).unwrap();
            let gz = gz.finish().unwrap();
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
