//! The attribute records of an EXR header, found in its bytes: the writer
//! reorders them ([`super::ordered`]) and the reader needs where the header
//! ends ([`super::layout`]).

use std::ops::Range;

/// The byte range and name of each attribute record of a header, and the
/// offset after its end.
pub(super) type Records = (Vec<(Range<usize>, Vec<u8>)>, usize);

/// Whether the bytes of an EXR file start with a complete single-part
/// header: then its [`Records`].
pub(super) fn header_records(bytes: &[u8]) -> std::io::Result<Option<Records>> {
    let mut pos = 8; // magic number and version
    let mut records = Vec::new();
    let zero = |from: usize| {
        bytes
            .get(from..)
            .and_then(|rest| rest.iter().position(|&b| b == 0))
            .map(|i| from + i)
    };
    loop {
        let Some(name_end) = zero(pos) else {
            return Ok(None);
        };
        if name_end == pos {
            return Ok(Some((records, pos + 1)));
        }
        let Some(type_end) = zero(name_end + 1) else {
            return Ok(None);
        };
        let Some(size) = bytes.get(type_end + 1..type_end + 5) else {
            return Ok(None);
        };
        let size = i32::from_le_bytes(size.try_into().unwrap());
        let size = usize::try_from(size)
            .map_err(|_| std::io::Error::other("negative attribute size in a header"))?;
        let end = type_end + 5 + size;
        if end > bytes.len() {
            return Ok(None);
        }
        records.push((pos..end, bytes[pos..name_end].to_vec()));
        pos = end;
    }
}
