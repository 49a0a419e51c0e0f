//! Progress of the long steps before the first sample: reading a mesh file,
//! building a tree. Whoever shows progress installs a [`Meter`] around the
//! work ([`metered`]); the code doing the work reports to it without a
//! parameter through every loader and builder in between. Nothing is
//! reported, at the cost of one thread-local read per step, where no meter
//! is installed.
//!
//! The meter is installed on the calling thread. Work that fans out over
//! rayon takes it ([`Step::current`]) before the fan-out and moves it into
//! the closures.

use std::cell::RefCell;
use std::path::Path;
use std::sync::Arc;

/// What a step is, and the unit it counts in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepKind<'a> {
    /// Reading and checking a mesh file; counts bytes of the file.
    ReadMesh { file: &'a Path },
    /// Building a tree over the scene's shapes; counts primitives (a
    /// triangle, or a shape of another kind).
    BuildTree { backend: &'static str },
}

/// Someone shown the progress of steps, one at a time.
pub trait Meter: Send + Sync {
    /// A step of `total` units starts.
    fn begin(&self, step: StepKind<'_>, total: u64);
    /// `amount` more units of the step are done; from any thread.
    fn advance(&self, amount: u64);
    /// The step is over, done or failed.
    fn end(&self);
}

thread_local! {
    static CURRENT: RefCell<Option<Arc<dyn Meter>>> = const { RefCell::new(None) };
}

/// Runs `work` with `meter` told of the steps it takes on this thread.
pub fn metered<R>(meter: Arc<dyn Meter>, work: impl FnOnce() -> R) -> R {
    with_current(Some(meter), work)
}

/// Runs `work` with no meter: for work whose progress the step in
/// progress counts otherwise (a gzipped mesh counts compressed bytes, not
/// the parse of what they inflate to).
pub(crate) fn unmetered<R>(work: impl FnOnce() -> R) -> R {
    with_current(None, work)
}

/// Runs `work` with `meter` as this thread's, and puts the one before
/// back afterwards, also when `work` panics.
fn with_current<R>(meter: Option<Arc<dyn Meter>>, work: impl FnOnce() -> R) -> R {
    struct Restore(Option<Arc<dyn Meter>>);
    impl Drop for Restore {
        fn drop(&mut self) {
            CURRENT.with(|c| *c.borrow_mut() = self.0.take());
        }
    }
    let _restore = Restore(CURRENT.with(|c| c.replace(meter)));
    work()
}

/// A handle on the step in progress, if a meter is installed; ends the step
/// when dropped. `Sync`, so parallel work can share it.
pub(crate) struct Step(Option<Arc<dyn Meter>>);

impl Step {
    /// Starts a step of `total` units with this thread's meter.
    pub(crate) fn begin(kind: StepKind<'_>, total: u64) -> Step {
        let meter = CURRENT.with(|c| c.borrow().clone());
        if let Some(m) = &meter {
            m.begin(kind, total);
        }
        Step(meter)
    }

    /// The step in progress on this thread, to report to without ending it:
    /// for code deep inside a step that does not own it.
    pub(crate) fn current() -> Reporter {
        Reporter(CURRENT.with(|c| c.borrow().clone()))
    }
}

impl Drop for Step {
    fn drop(&mut self) {
        if let Some(m) = &self.0 {
            m.end();
        }
    }
}

/// Reports to the step in progress; nothing without a meter.
#[derive(Clone)]
pub(crate) struct Reporter(Option<Arc<dyn Meter>>);

impl Reporter {
    /// A handle that reports nowhere.
    pub(crate) fn none() -> Reporter {
        Reporter(None)
    }

    #[inline]
    pub(crate) fn advance(&self, amount: usize) {
        if let Some(m) = &self.0 {
            m.advance(amount as u64);
        }
    }
}

#[cfg(test)]
pub(crate) mod test_support {
    use super::*;
    use std::sync::Mutex;

    /// A meter that records what it is told.
    #[derive(Default)]
    pub(crate) struct Recorder {
        pub(crate) events: Mutex<Vec<Event>>,
    }

    #[derive(Clone, Debug, PartialEq, Eq)]
    pub(crate) enum Event {
        Begin(String, u64),
        Advance(u64),
        End,
    }

    impl Meter for Recorder {
        fn begin(&self, step: StepKind<'_>, total: u64) {
            let what = match step {
                StepKind::ReadMesh { file } => file.display().to_string(),
                StepKind::BuildTree { backend } => format!("build {backend}"),
            };
            self.events.lock().unwrap().push(Event::Begin(what, total));
        }
        fn advance(&self, amount: u64) {
            self.events.lock().unwrap().push(Event::Advance(amount));
        }
        fn end(&self) {
            self.events.lock().unwrap().push(Event::End);
        }
    }

    impl Recorder {
        /// Runs `work` metered by a fresh recorder; its result and events.
        pub(crate) fn record<R>(work: impl FnOnce() -> R) -> (R, Vec<Event>) {
            let recorder = Arc::new(Recorder::default());
            let r = metered(recorder.clone(), work);
            let events = recorder.events.lock().unwrap().clone();
            (r, events)
        }
    }

    /// The begins of `events`, and the sum and count of the advances of
    /// each step.
    pub(crate) fn steps(events: &[Event]) -> Vec<(String, u64, u64, usize)> {
        let mut out: Vec<(String, u64, u64, usize)> = Vec::new();
        let mut open = false;
        for e in events {
            match e {
                Event::Begin(what, total) => {
                    assert!(!open, "a step began inside another: {events:?}");
                    open = true;
                    out.push((what.clone(), *total, 0, 0));
                }
                Event::Advance(n) => {
                    assert!(open, "an advance outside a step: {events:?}");
                    let last = out.last_mut().unwrap();
                    last.2 += n;
                    last.3 += 1;
                }
                Event::End => {
                    assert!(open, "an end without a begin: {events:?}");
                    open = false;
                }
            }
        }
        assert!(!open, "a step never ended: {events:?}");
        out
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::*;
    use super::*;

    /// Steps reach the installed meter, and only inside `metered`; a nested
    /// meter is replaced by the outer one again when its work ends.
    #[test]
    fn steps_reach_the_installed_meter_only() {
        let step = || {
            let s = Step::begin(StepKind::BuildTree { backend: "rust" }, 10);
            Step::current().advance(4);
            Step::current().advance(6);
            drop(s);
        };
        step();
        let ((), outer) = Recorder::record(|| {
            let ((), inner) = Recorder::record(step);
            assert_eq!(steps(&inner), vec![("build rust".into(), 10, 10, 2)]);
            step();
        });
        assert_eq!(steps(&outer), vec![("build rust".into(), 10, 10, 2)]);
        step();
    }
}
