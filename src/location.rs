//! Where a byte offset lies in a text file, as located errors report it;
//! and reading an input file only when it is a regular file.

use std::path::Path;

/// The bytes of the file at `path`, which must be a regular file (after
/// symbolic links): a FIFO would block the read for ever, a device such as
/// `/dev/zero` never ends, a directory is no input. Checked by its metadata
/// before it is opened.
pub fn read_regular_file(path: &Path) -> std::io::Result<Vec<u8>> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(not_regular(path));
    }
    // As `std::fs::read`, into a buffer on huge pages: a mesh of hundreds
    // of megabytes is read into fresh memory.
    let mut data = crate::memory::vec_with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    std::io::Read::read_to_end(&mut std::fs::File::open(path)?, &mut data)?;
    Ok(data)
}

/// Files from this size on are mapped rather than read.
const MAP_FROM: u64 = 8 << 20;

/// The bytes of an input file: read into memory, or mapped from the page
/// cache when large.
pub enum FileBytes {
    Read(Vec<u8>),
    Mapped(memmap2::Mmap),
}

impl std::ops::Deref for FileBytes {
    type Target = [u8];

    fn deref(&self) -> &[u8] {
        match self {
            FileBytes::Read(data) => data,
            FileBytes::Mapped(map) => map,
        }
    }
}

/// [`read_regular_file`], mapping a file of [`MAP_FROM`] bytes or more
/// instead of reading it. A mesh of hundreds of megabytes is parsed once
/// into arrays of its own: read, it would first be copied out of the page
/// cache into fresh memory that the kernel must clear, which took two
/// thirds of loading a 338 MB PLY.
pub fn map_regular_file(path: &Path) -> std::io::Result<FileBytes> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(not_regular(path));
    }
    if meta.len() < MAP_FROM {
        return read_regular_file(path).map(FileBytes::Read);
    }
    let file = std::fs::File::open(path)?;
    // SAFETY: the map is private and read-only, and its bytes are only
    // read as plain bytes. What no program can rule out for a mapped file
    // is another program truncating it meanwhile: reading the lost pages
    // then ends luz with SIGBUS instead of an error (a file rewritten in
    // place is read as whatever it holds, and checked as any input is).
    let map = unsafe { memmap2::MmapOptions::new().populate().map(&file)? };
    Ok(FileBytes::Mapped(map))
}

/// The error of a path that is not a regular file, naming it.
pub fn not_regular(path: &Path) -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::InvalidInput,
        format!(
            "{} is not a regular file",
            crate::echo::echo(&path.display().to_string())
        ),
    )
}

/// The 1-based line and column (counted in bytes) of byte `offset` of
/// `text`; an offset past the end is the end.
pub(crate) fn line_column(text: &[u8], offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    (line, before.len() - line_start + 1)
}

#[cfg(test)]
mod tests {
    use super::line_column;

    #[test]
    fn lines_and_columns_count_from_one() {
        let text = b"ab\ncd\n";
        assert_eq!(line_column(text, 0), (1, 1));
        assert_eq!(line_column(text, 2), (1, 3));
        assert_eq!(line_column(text, 3), (2, 1));
        assert_eq!(line_column(text, 6), (3, 1));
        assert_eq!(line_column(text, 99), (3, 1));
    }
}
