//! Progress as the user sees it: a bar on a terminal, progress lines with
//! the ETA in a log, and the stages that kept the user waiting.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use luz::distributed::task::Task;
use luz::job::{Observer, Stage, WriteError};
use luz::meter::{Meter, StepKind};
use luz::render::Progress;
use std::io::IsTerminal;
use std::ops::Range;
use std::sync::{Arc, Mutex, OnceLock, RwLock};
use std::time::{Duration, Instant};

/// Rows finished, drawn as a bar with an ETA and the sample rate; a step is
/// one sample of every pixel of a row.
pub(crate) struct Bar(pub(crate) ProgressBar);

impl Progress for Bar {
    fn row_done(&self, samples: u32) {
        self.0.inc(samples as u64);
    }
}

pub(crate) fn progress_bar(steps: u64, samples_per_step: u64, quiet: bool) -> ProgressBar {
    let bar = ProgressBar::new(steps);
    if quiet || !std::io::stderr().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
        return bar;
    }
    let style =
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent:>3}% ETA {eta} {rate}")
            .expect("the template is valid")
            .progress_chars("=> ")
            .with_key(
                "rate",
                move |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let rate = state.per_sec() * samples_per_step as f64 / 1e6;
                    let _ = write!(w, "{rate:.2} Msamples/s");
                },
            );
    bar.set_style(style);
    bar
}

/// Shows a render's progress: stages that kept the user waiting (over half
/// a second: a large mesh), the task, a bar on a terminal, and elsewhere (a
/// batch job's log) a line with the ETA after [`FIRST_LOG`] and then every
/// [`LOG_EVERY`], so nobody waits in the dark.
pub(crate) struct RenderObserver {
    pub(crate) quiet: bool,
    steps: Arc<StepBars>,
    pub(crate) bar: OnceLock<ProgressBar>,
    /// When the next progress line is due.
    pub(crate) next_line: Mutex<Instant>,
}

/// When a render that is not on a terminal first logs its progress: soon
/// enough that a week-long request is seen at once, late enough that the
/// rate is known.
pub(crate) const FIRST_LOG: Duration = Duration::from_secs(5);

/// How often a render that is not on a terminal logs its progress.
pub(crate) const LOG_EVERY: Duration = Duration::from_secs(60);

impl RenderObserver {
    pub(crate) fn new(quiet: bool) -> Self {
        Self {
            quiet,
            steps: Arc::new(StepBars {
                quiet,
                on_terminal: std::io::stderr().is_terminal(),
                shown: RwLock::new(None),
            }),
            bar: OnceLock::new(),
            next_line: Mutex::new(Instant::now() + FIRST_LOG),
        }
    }

    pub(crate) fn finish(&self) {
        if let Some(bar) = self.bar.get() {
            bar.finish_and_clear();
        }
    }
}

impl Progress for RenderObserver {
    fn row_done(&self, samples: u32) {
        let Some(bar) = self.bar.get() else { return };
        bar.inc(samples as u64);
        // Quiet, or on a terminal, which draws the bar.
        if self.quiet || !bar.is_hidden() {
            return;
        }
        let Ok(mut next) = self.next_line.try_lock() else {
            return;
        };
        if Instant::now() >= *next {
            *next = Instant::now() + LOG_EVERY;
            let done = bar.position() as f64 / bar.length().unwrap_or(1).max(1) as f64;
            eprintln!(
                "luz: {:.1}% done after {}, ETA {}",
                100.0 * done,
                indicatif::HumanDuration(bar.elapsed()),
                indicatif::HumanDuration(bar.eta())
            );
        }
    }
}

impl Observer for RenderObserver {
    fn stage_done(&self, stage: Stage, time: Duration) {
        let what = match stage {
            Stage::Loaded => "loaded the scene",
            Stage::Built => "built the tree",
        };
        if !self.quiet && time >= Duration::from_millis(500) {
            eprintln!("luz: {what} in {:.1} s", time.as_secs_f64());
        }
    }

    fn meter(&self) -> Option<Arc<dyn Meter>> {
        Some(self.steps.clone())
    }

    fn task_chosen(&self, task: &Task, samples: &Range<u32>) {
        if !self.quiet {
            eprintln!(
                "luz: task {} of {} ({}): samples {}..{}",
                task.index, task.count, task.source, samples.start, samples.end
            );
        }
    }

    fn rendering(&self, steps: u64, samples_per_step: u64) {
        let bar = progress_bar(steps, samples_per_step, self.quiet);
        *self.next_line.lock().expect("no panics while held") = Instant::now() + FIRST_LOG;
        let _ = self.bar.set(bar);
    }

    fn checkpoint_failed(&self, error: &WriteError) {
        eprintln!("luz: warning: cannot write the checkpoint, rendering on: {error}");
    }
}

/// The steps before the first sample: on a terminal, a bar for each large
/// one (a mesh's bytes read, then the tree's primitives built); elsewhere
/// a line for each mesh that kept the user waiting, beside the stage lines.
struct StepBars {
    quiet: bool,
    on_terminal: bool,
    shown: RwLock<Option<ShownStep>>,
}

struct ShownStep {
    bar: ProgressBar,
    /// What the line elsewhere says, for a mesh.
    line: Option<String>,
}

/// A mesh file from this size on, or a tree of this many primitives, gets
/// a bar: anything smaller takes too little time to watch.
const BAR_FROM_BYTES: u64 = 16 << 20;
const BAR_FROM_PRIMITIVES: u64 = 1 << 20;

impl StepBars {
    fn bar(&self, step: StepKind<'_>, total: u64) -> ProgressBar {
        let (big, template) = match step {
            StepKind::ReadMesh { .. } => (
                total >= BAR_FROM_BYTES,
                "{msg} [{bar:40}] {bytes}/{total_bytes} in {elapsed}",
            ),
            StepKind::BuildTree { .. } => (
                total >= BAR_FROM_PRIMITIVES,
                "{msg} [{bar:40}] {human_pos}/{human_len} primitives in {elapsed}",
            ),
        };
        if self.quiet || !self.on_terminal || !big {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::new(total);
        let style = ProgressStyle::with_template(template)
            .expect("the template is valid")
            .progress_chars("=> ");
        bar.set_style(style);
        bar
    }
}

impl Meter for StepBars {
    fn begin(&self, step: StepKind<'_>, total: u64) {
        let bar = self.bar(step, total);
        let line = match step {
            StepKind::ReadMesh { file } => {
                let name = file.file_name().unwrap_or(file.as_os_str());
                let name = name.to_string_lossy();
                bar.set_message(format!("luz: reading {name}"));
                Some(format!("read {name} ({:.1} MB)", total as f64 / 1e6))
            }
            StepKind::BuildTree { backend } => {
                bar.set_message(format!("luz: building the {backend} tree"));
                None
            }
        };
        *self.shown.write().expect("no panics while held") = Some(ShownStep { bar, line });
    }

    fn advance(&self, amount: u64) {
        if let Some(s) = &*self.shown.read().expect("no panics while held") {
            s.bar.inc(amount);
        }
    }

    fn end(&self) {
        let Some(s) = self.shown.write().expect("no panics while held").take() else {
            return;
        };
        let time = s.bar.elapsed();
        s.bar.finish_and_clear();
        if let Some(line) = s.line {
            if !self.quiet && !self.on_terminal && time >= Duration::from_millis(500) {
                eprintln!("luz: {line} in {:.1} s", time.as_secs_f64());
            }
        }
    }
}
