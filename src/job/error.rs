//! What can go wrong in a job, typed, with the exit status each earns: 2 for
//! input the user can fix (scene, arguments, files), 1 for a failure while
//! working (a write that failed), 128 + n for a stop by signal n.

use super::files::{FileError, Role};
use super::signals::StopSignal;
use crate::accel::AccelError;
use crate::distributed::merge::MergeError;
use crate::distributed::part::{Mismatch, PartError};
use crate::distributed::task::TaskError;
use crate::image::ImageError;
use crate::render::film::FilmError;
use crate::render::Sampling;
use crate::scene::SceneError;
use std::ops::Range;
use std::path::PathBuf;

/// A failed write of an output or a checkpoint.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error(transparent)]
    Part(#[from] PartError),
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error(transparent)]
    File(#[from] FileError),
}

#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error(transparent)]
    Files(#[from] FileError),
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// An output whose extension names no format luz writes.
    #[error(transparent)]
    OutputKind(ImageError),
    #[error(transparent)]
    Input(ImageError),
    #[error("{}: --checkpoint must name an .exr file", path.display())]
    CheckpointNotExr { path: PathBuf },
    #[error(
        "{}: a render of samples {}..{} must be written to .exr, which keeps what `luz merge` needs",
        path.display(), samples.start, samples.end
    )]
    PartialNeedsExr { path: PathBuf, samples: Range<u32> },
    #[error("--samples {}..{}: the scene renders {spp} samples per pixel (indices 0..{spp}); raise --spp or lower the range", samples.start, samples.end)]
    SamplesBeyondSpp { samples: Range<u32>, spp: u32 },
    #[error("{sampling} renders every pixel from sample 0, so it cannot render --samples {}..{} or a task's share: render it in one job (checkpoints resume it exactly)", samples.start, samples.end)]
    AdaptiveSplit {
        sampling: Sampling,
        samples: Range<u32>,
    },
    #[error("--min-spp {min} is above --max-spp {max}")]
    MinAboveMax { min: u32, max: u32 },
    #[error("--task-count needs --task-index, SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX")]
    TaskCountWithoutIndex,
    #[error(transparent)]
    Task(#[from] TaskError),
    #[error(transparent)]
    Accel(#[from] AccelError),
    #[error("{}: resolution: {error}", scene.display())]
    Film { scene: PathBuf, error: FilmError },
    /// A part (to merge or resume) that cannot be used.
    #[error(transparent)]
    Part(PartError),
    #[error(transparent)]
    Merge(#[from] MergeError),
    #[error("{}: {}: the checkpoint has {}, this render {}: it is not of this render", path.display(), mismatch.attribute, mismatch.theirs, mismatch.ours)]
    ResumeMismatch { path: PathBuf, mismatch: Mismatch },
    #[error("{}: luz:samples: the checkpoint holds samples {held}, which do not start this render's {}..{}", path.display(), wanted.start, wanted.end)]
    ResumeSamples {
        path: PathBuf,
        held: String,
        wanted: Range<u32>,
    },
    #[error("cannot write {role}: {error}")]
    Write { role: Role, error: WriteError },
    /// The final write failed; `saved` says whether the render's samples
    /// are kept in the checkpoint.
    #[error("cannot write the output: {error}; {}", match saved {
        Ok(path) => format!("all its samples are kept in the checkpoint {}: resume from it to write the output", path.display()),
        Err(e) => format!("the checkpoint could not be written either ({e}): the render is lost"),
    })]
    OutputLost {
        error: WriteError,
        saved: Result<PathBuf, Box<WriteError>>,
    },
    /// Stopped by a signal; `saved` names the checkpoint and the partial
    /// output when samples were done and written.
    #[error("interrupted by {} after {held} of {of} samples per pixel{}", signal.name(), match saved {
        Some((checkpoint, output)) => format!("; wrote the checkpoint {} and the partial image {}", checkpoint.display(), output.display()),
        None => "; nothing written".into(),
    })]
    Interrupted {
        signal: StopSignal,
        held: u64,
        of: u64,
        saved: Option<(PathBuf, PathBuf)>,
    },
}

impl JobError {
    pub fn exit_status(&self) -> u8 {
        match self {
            JobError::Write { .. } | JobError::OutputLost { .. } => 1,
            JobError::Interrupted { signal, .. } => signal.exit_status(),
            _ => 2,
        }
    }
}
