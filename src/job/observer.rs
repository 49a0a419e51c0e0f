//! Whoever shows a job's progress: the stages before the first sample, the
//! steps inside them, the rendering and what went wrong on the way.

use super::WriteError;
use crate::distributed::task::Task;
use crate::meter::Meter;
use crate::render::Progress;
use std::ops::Range;
use std::sync::Arc;
use std::time::Duration;

/// A stage before the first sample, reported when done.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Loaded,
    Built,
}

/// Whoever shows the job's progress.
pub trait Observer: Progress {
    fn stage_done(&self, _stage: Stage, _time: Duration) {}
    /// Who is told of the steps of loading and building (a mesh read, a
    /// tree built) as they go.
    fn meter(&self) -> Option<Arc<dyn Meter>> {
        None
    }
    fn task_chosen(&self, _task: &Task, _samples: &Range<u32>) {}
    /// Rendering starts: `steps` rows of one sample each are to come, of
    /// `samples_per_step` samples.
    fn rendering(&self, _steps: u64, _samples_per_step: u64) {}
    /// A checkpoint could not be written; the render goes on.
    fn checkpoint_failed(&self, _error: &WriteError) {}
}

impl Observer for () {}

/// Runs `work` with the observer's meter, if it has one.
pub(super) fn metered_by<R>(observer: &dyn Observer, work: impl FnOnce() -> R) -> R {
    match observer.meter() {
        Some(meter) => crate::meter::metered(meter, work),
        None => work(),
    }
}
