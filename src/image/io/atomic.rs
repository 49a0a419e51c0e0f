//! Atomic writes: every image file appears complete under its name or not
//! at all (see the policies in the module docs of [`super`]).

use super::ImageError;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// The directory a file `path` lies in (`.` for a bare file name).
pub(super) fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Runs `body` on a buffered temporary file next to `path`, then syncs and
/// renames it to `path`. On any failure the temporary is removed.
pub(crate) fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> Result<(), ImageError>,
) -> Result<(), ImageError> {
    let io_error = |source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    };
    let name = path.file_name().ok_or_else(|| ImageError::Format {
        path: path.to_path_buf(),
        message: "not a file name".into(),
    })?;
    let dir = directory_of(path);
    let temp = dir.join(format!(
        ".{}.luz-tmp-{}-{}",
        name.to_string_lossy(),
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let file = File::options()
        .write(true)
        .create_new(true)
        .open(&temp)
        .map_err(io_error)?;
    let result = (|| {
        let mut out = BufWriter::new(file);
        body(&mut out)?;
        let file = out.into_inner().map_err(|e| io_error(e.into_error()))?;
        file.sync_all().map_err(io_error)?;
        drop(file);
        std::fs::rename(&temp, path).map_err(io_error)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{hdr_image, leftovers, temp_dir};
    use super::super::{write, WriteOptions};
    use super::*;
    use crate::image::ToneMapParams;
    use std::io::Write;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporaries() {
        let dir = temp_dir("atomic");
        let path = dir.join("out.png");
        std::fs::write(&path, b"old").unwrap();
        write(&path, &hdr_image(), &WriteOptions::default()).unwrap();
        assert!(std::fs::read(&path).unwrap().starts_with(b"\x89PNG"));
        assert_eq!(leftovers(&dir), Vec::<String>::new());
        // A failing write (bad tone-map parameter) leaves the old file alone.
        let bad = WriteOptions {
            params: ToneMapParams {
                gamma: -1.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let before = std::fs::read(&path).unwrap();
        assert!(write(&path, &hdr_image(), &bad).is_err());
        assert_eq!(std::fs::read(&path).unwrap(), before);
        // A failure while encoding removes the temporary and writes nothing.
        let missing = dir.join("fresh.ppm");
        let r = write_atomic(&missing, |out| {
            out.write_all(b"P3\n").unwrap();
            Err(ImageError::InvalidParameter("simulated failure".into()))
        });
        assert!(r.is_err());
        assert!(!missing.exists());
        assert_eq!(leftovers(&dir), Vec::<String>::new());
        // A missing directory: an error naming the file, nothing written.
        let e = write(
            &dir.join("no/such/dir/x.exr"),
            &hdr_image(),
            &WriteOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("x.exr"), "{e}");
    }
}
