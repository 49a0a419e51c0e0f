//! Text bodies cut at line ends, for parsing in parallel: each chunk is
//! parsed on its own, with its first line's number from the newlines
//! before it, and the results are joined in order.

use std::ops::Range;

/// About how many bytes a chunk of a large body holds: enough that a
/// chunk's setup is nothing next to its parse, small enough that two
/// threads share a 10 MB file evenly.
pub(super) const CHUNK_BYTES: usize = 1 << 20;

/// Ranges that cover `data` in order, each of at least `size` bytes and
/// ending just after a `\n` (the last one at the end of `data`); one range
/// for a body of no more than `size` bytes.
pub(super) fn line_chunks(data: &[u8], size: usize) -> Vec<Range<usize>> {
    let size = size.max(1);
    let mut out = Vec::with_capacity(data.len() / size + 1);
    let mut start = 0;
    while start < data.len() {
        let from = start.saturating_add(size - 1).min(data.len());
        let end = match data[from..].iter().position(|&b| b == b'\n') {
            Some(k) => from + k + 1,
            None => data.len(),
        };
        out.push(start..end);
        start = end;
    }
    out
}

/// The number of `\n` in `data` (a loop the compiler vectorises).
pub(super) fn newlines(data: &[u8]) -> usize {
    data.iter().map(|&b| (b == b'\n') as usize).sum()
}

/// Per chunk, the number of lines before it: the newlines of the chunks
/// before, counted in parallel.
pub(super) fn lines_before(data: &[u8], chunks: &[Range<usize>]) -> Vec<usize> {
    use rayon::prelude::*;
    let counts: Vec<usize> = chunks
        .par_iter()
        .map(|r| newlines(&data[r.clone()]))
        .collect();
    counts
        .iter()
        .scan(0usize, |before, &n| {
            let here = *before;
            *before += n;
            Some(here)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_end_at_line_ends_and_cover_everything() {
        let data = b"ab\ncd\r\n\nefgh\nij";
        for size in 1..20 {
            let chunks = line_chunks(data, size);
            assert_eq!(chunks.first().map(|r| r.start), Some(0));
            assert_eq!(chunks.last().map(|r| r.end), Some(data.len()));
            for w in chunks.windows(2) {
                assert_eq!(w[0].end, w[1].start);
                assert_eq!(data[w[0].end - 1], b'\n');
                assert!(w[0].len() >= size);
            }
            let before = lines_before(data, &chunks);
            for (r, n) in chunks.iter().zip(before) {
                assert_eq!(n, newlines(&data[..r.start]));
            }
        }
        assert!(line_chunks(b"", 4).is_empty());
        assert_eq!(line_chunks(data, 100), vec![0..data.len()]);
    }
}
