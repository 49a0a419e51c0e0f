//! Jobs as the command line runs them, with every guard that keeps a
//! user's files safe: a render (sample range, checkpoints, resume, output)
//! and a merge. The command line only parses arguments into a job, shows
//! its progress and maps its errors to exit statuses.
//!
//! Everything that can be refused is refused before the first sample: the
//! outputs ([`files::check_output`]), outputs that are inputs
//! ([`files::refuse_overlaps`]), a checkpoint path that holds a file this
//! run did not write ([`files::Checkpoint`]), sample ranges beyond the
//! scene's samples per pixel, and a resume file of another render.

mod error;
pub mod files;
mod observer;
pub mod render;
pub mod signals;

pub use error::{JobError, WriteError};
pub use observer::{Observer, Stage};
pub use render::{JobReport, Overrides, RenderJob, SampleChoice, SamplingRequest};

use crate::distributed::merge::{merge, Merged};
use crate::distributed::part;
use crate::image::io::{self as imageio, WriteOptions};
use files::{check_output, refuse_overlaps, Role};
use std::path::{Path, PathBuf};

/// Merges the parts at `parts` into `output`, refusing an output that is one
/// of the parts before reading any of them.
pub fn merge_files(
    parts: &[PathBuf],
    output: &Path,
    allow_gaps: bool,
    write: &WriteOptions,
) -> Result<Merged, JobError> {
    imageio::check_output_path(output).map_err(JobError::OutputKind)?;
    check_output(Role::Output, output)?;
    let inputs: Vec<(Role, &Path)> = parts.iter().map(|p| (Role::Part, p.as_path())).collect();
    refuse_overlaps(&[(Role::Output, output)], &inputs)?;
    let mut read = Vec::new();
    for path in parts {
        read.push((path.clone(), part::read(path).map_err(JobError::Part)?));
    }
    let merged = merge(read, allow_gaps)?;
    render::write_output(output, &merged.part.meta, &merged.part.film, write).map_err(|error| {
        JobError::Write {
            role: Role::Output,
            error,
        }
    })?;
    Ok(merged)
}

/// Tone maps the image at `input` into `output`, which must not be it.
pub fn tonemap_file(input: &Path, output: &Path, write: &WriteOptions) -> Result<(), JobError> {
    imageio::check_output_path(output).map_err(JobError::OutputKind)?;
    check_output(Role::Output, output)?;
    refuse_overlaps(&[(Role::Output, output)], &[(Role::Image, input)])?;
    let image = imageio::read(input).map_err(JobError::Input)?;
    imageio::write(output, &image, write).map_err(|e| JobError::Write {
        role: Role::Output,
        error: e.into(),
    })
}

/// The image at `path` and its per-pixel standard errors: a luz render's
/// (read as a part, every check made), or for any other image zeros, as
/// for an exact reference.
pub fn read_with_error(
    path: &Path,
) -> Result<(crate::image::Image, crate::image::Image), JobError> {
    if part::is_part(path) {
        let film = part::read(path).map_err(JobError::Part)?.film;
        return Ok((film.image(), film.standard_error()));
    }
    let image = imageio::read(path).map_err(JobError::Input)?;
    let zeros = crate::image::Image::new(
        image.width,
        image.height,
        vec![crate::math::Vec3::splat(0.0); image.pixels.len()],
    );
    Ok((image, zeros))
}
