//! The writer that makes the same part the same bytes: it puts the luz
//! attributes of the header in a fixed order.

use super::attributes::{ATTRIBUTES, CHECKSUM};
use super::records::header_records;
use std::io::{Seek, SeekFrom, Write};
use std::ops::Range;

/// Puts the `luz:` attribute records of the complete header at the start of
/// `bytes` in [`ATTRIBUTES`] order, then `luz:checksum`, in place: the exr
/// crate writes them in the order of a `HashMap`, which changes from one
/// process (and one map) to the next. They are written one after the other,
/// so reordering them moves no other byte.
fn order_attributes(bytes: &mut [u8], records: &[(Range<usize>, Vec<u8>)]) -> std::io::Result<()> {
    let ours: Vec<&(Range<usize>, Vec<u8>)> = records
        .iter()
        .filter(|(_, name)| name.starts_with(b"luz:"))
        .collect();
    let (Some(first), Some(last)) = (ours.first(), ours.last()) else {
        return Ok(());
    };
    let span = first.0.start..last.0.end;
    if ours.windows(2).any(|w| w[0].0.end != w[1].0.start) {
        return Err(std::io::Error::other(
            "the luz attributes are not written one after the other",
        ));
    }
    let rank = |name: &[u8]| {
        let order = ATTRIBUTES.iter().chain(&[CHECKSUM]);
        let position = order.clone().position(|a| a.as_bytes() == name);
        (position.unwrap_or(usize::MAX), name.to_vec())
    };
    let mut sorted = ours.clone();
    sorted.sort_by_key(|(_, name)| rank(name));
    let reordered: Vec<u8> = sorted
        .iter()
        .flat_map(|(range, _)| bytes[range.clone()].to_vec())
        .collect();
    bytes[span].copy_from_slice(&reordered);
    Ok(())
}

/// A writer that holds back the start of the file until its header is
/// complete, puts the luz attributes in order ([`order_attributes`]), and
/// then lets everything through.
pub(super) struct InOrder<W> {
    inner: W,
    held: Option<Vec<u8>>,
}

impl<W: Write> InOrder<W> {
    pub(super) fn new(inner: W) -> Self {
        Self {
            inner,
            held: Some(Vec::new()),
        }
    }

    /// Errs if the header never completed (nothing was written then).
    pub(super) fn finish(self) -> std::io::Result<()> {
        match self.held {
            None => Ok(()),
            Some(_) => Err(std::io::Error::other("the EXR header was never completed")),
        }
    }
}

impl<W: Write> Write for InOrder<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let Some(held) = &mut self.held else {
            return self.inner.write(buf);
        };
        held.extend_from_slice(buf);
        if let Some((records, _)) = header_records(held)? {
            order_attributes(held, &records)?;
            self.inner.write_all(held)?;
            self.held = None;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl<W: Write + Seek> Seek for InOrder<W> {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        if self.held.is_some() {
            return Err(std::io::Error::other(
                "a seek before the EXR header was complete",
            ));
        }
        self.inner.seek(pos)
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{sample_part, temp_dir, written};
    use super::*;

    #[test]
    fn the_same_part_is_written_as_the_same_bytes() {
        // Every write builds its own attribute map, whose random hasher
        // orders the attributes differently.
        let dir = temp_dir("same-bytes");
        let part = sample_part();
        let (_, first) = written(&dir, "0.exr", &part);
        for i in 1..8 {
            let (_, again) = written(&dir, &format!("{i}.exr"), &part);
            assert!(again == first, "write {i} differs from the first");
        }
        let (records, _) = header_records(&first).unwrap().unwrap();
        let ours: Vec<&[u8]> = records
            .iter()
            .map(|(_, name)| name.as_slice())
            .filter(|name| name.starts_with(b"luz:"))
            .collect();
        let expected: Vec<&[u8]> = ATTRIBUTES
            .iter()
            .chain(&[CHECKSUM])
            .map(|a| a.as_bytes())
            .collect();
        assert_eq!(ours, expected);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
