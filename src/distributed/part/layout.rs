//! What a part's header claims, checked before anything is allocated for
//! its pixels: the reader allocates what the header claims.

use super::channels::part_channels;
use super::PartError;
use crate::render::film::check_resolution;
use exr::meta::header::Header;
use exr::meta::BlockDescription;
use exr::prelude::Compression;
use std::path::Path;

/// Checks what `header` (of `header_len` bytes) says the file holds against
/// luz's layout and limits and against `file_len`, the bytes there are,
/// before any pixel is read. For luz's uncompressed scan lines the bytes
/// needed are exact.
pub(super) fn check_layout(
    path: &Path,
    header: &Header,
    header_len: usize,
    file_len: usize,
    adaptive: bool,
) -> Result<(), PartError> {
    let invalid = |field: &str, message: String| PartError::invalid(path, field, message);
    let (width, height) = (header.layer_size.width(), header.layer_size.height());
    let side = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    check_resolution(side(width), side(height)).map_err(|m| invalid("dataWindow", m))?;
    if header.deep {
        return Err(invalid("type", "deep data: a luz part is flat".into()));
    }
    if let BlockDescription::Tiles(_) = header.blocks {
        return Err(invalid("tiles", "tiled: a luz part is scan lines".into()));
    }
    if header.compression != Compression::Uncompressed {
        return Err(invalid(
            "compression",
            format!("{}: luz writes its parts uncompressed", header.compression),
        ));
    }
    check_channels(path, header, adaptive)?;
    // After the header, each scan-line chunk has an offset-table entry (8
    // bytes), its y and its byte count (4 + 4), and then its pixels.
    let bytes_per_pixel = header.channels.bytes_per_pixel;
    let needed = (header_len as u64)
        .saturating_add(header.chunk_count as u64 * 16)
        .saturating_add((width as u64 * height as u64).saturating_mul(bytes_per_pixel as u64));
    if needed > file_len as u64 {
        return Err(PartError::Truncated {
            path: path.to_path_buf(),
            width,
            height,
            bytes_per_pixel,
            needed,
            held: file_len as u64,
        });
    }
    Ok(())
}

/// Every channel of a part, of its type, each with one sample per pixel.
fn check_channels(path: &Path, header: &Header, adaptive: bool) -> Result<(), PartError> {
    let invalid = |field: &str, message: String| PartError::invalid(path, field, message);
    for (name, sample_type) in part_channels(adaptive) {
        let found = header
            .channels
            .list
            .iter()
            .find(|c| c.name == *name.as_str());
        match found {
            None => return Err(invalid(&name, "channel missing".into())),
            Some(c) if c.sample_type != sample_type => {
                return Err(invalid(
                    &name,
                    format!(
                        "expected a {sample_type:?} channel, found {:?}",
                        c.sample_type
                    ),
                ))
            }
            Some(_) => {}
        }
    }
    if let Some(c) = header.channels.list.iter().find(|c| c.sampling.area() != 1) {
        return Err(invalid(
            &c.name.to_string(),
            "subsampled: a luz part has one sample per pixel".into(),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::records::header_records;
    use super::super::tests::{sample_part, temp_dir, value_of, written};
    use super::super::{read, PartError};

    #[test]
    fn a_header_claiming_more_than_the_file_holds_is_refused_before_its_pixels() {
        let dir = temp_dir("header");
        let (path, bytes) = written(&dir, "p.exr", &sample_part());
        let mut huge = bytes.clone();
        let window = value_of(&huge, "dataWindow");
        let corners: Vec<u8> = [0i32, 0, 15999, 15999]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        huge[window].copy_from_slice(&corners);
        let chunks = value_of(&huge, "chunkCount");
        huge[chunks].copy_from_slice(&16000i32.to_le_bytes());
        std::fs::write(&path, &huge).unwrap();
        let err = read(&path).unwrap_err();
        let message = err.to_string();
        assert!(
            matches!(
                err,
                PartError::Truncated {
                    width: 16000,
                    height: 16000,
                    bytes_per_pixel: 72,
                    ..
                }
            ),
            "{message}"
        );
        assert!(message.contains(&format!(
            "p.exr: dataWindow: 16000x16000 pixels of 72 bytes need at least {} bytes, the file holds {}",
            header_records(&bytes).unwrap().unwrap().1 as u64 + 16000 * 16 + 16000 * 16000 * 72,
            bytes.len()
        )), "{message}");

        // A truncated part is the same mismatch, seen from the other side.
        std::fs::write(&path, &bytes[..bytes.len() - 100]).unwrap();
        let err = read(&path).unwrap_err();
        assert!(
            matches!(
                err,
                PartError::Truncated {
                    width: 3,
                    height: 2,
                    ..
                }
            ),
            "{err}"
        );

        // Beyond luz's limits, whatever the file's size.
        let mut wide = bytes.clone();
        let window = value_of(&wide, "dataWindow");
        wide[window.start + 8..window.start + 12].copy_from_slice(&40000i32.to_le_bytes());
        std::fs::write(&path, &wide).unwrap();
        let err = read(&path).unwrap_err().to_string();
        assert!(
            err.contains("p.exr: dataWindow: resolution 40001x2 is outside"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
