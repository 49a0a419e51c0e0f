//! SIGINT and SIGTERM as users send them. The first stops the render after
//! the pass in flight, and the job saves what it has; a second one ends the
//! process at once, for a user who cannot wait. But GNU `timeout`, `srun`
//! and shells relay a signal to the whole process group, so one signal can
//! arrive twice within microseconds. A second signal therefore counts only
//! when it is a different signal, or the same one after the final write has
//! begun, or after [`GRACE`]: a user sending it again, not a relay.

use std::io;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// How long after the first signal the same signal is taken as a relayed
/// copy of it rather than the user asking again.
pub const GRACE: Duration = Duration::from_millis(500);

/// A signal that asks a render to stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopSignal {
    Interrupt,
    Terminate,
}

impl StopSignal {
    pub fn number(self) -> i32 {
        match self {
            StopSignal::Interrupt => signal_hook::consts::SIGINT,
            StopSignal::Terminate => signal_hook::consts::SIGTERM,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            StopSignal::Interrupt => "SIGINT",
            StopSignal::Terminate => "SIGTERM",
        }
    }

    fn from_number(n: i32) -> Option<Self> {
        [StopSignal::Interrupt, StopSignal::Terminate]
            .into_iter()
            .find(|s| s.number() == n)
    }

    /// The exit status of a process that stopped for this signal (128 + n).
    pub fn exit_status(self) -> u8 {
        128 + self.number() as u8
    }
}

/// What a job asks of whoever can stop it.
pub trait Stop: Sync {
    /// The signal that asked the render to stop, if one did.
    fn requested(&self) -> Option<StopSignal>;
    /// The job is writing its results: a second signal now means "quit".
    fn writing(&self) {}
}

/// Never asks to stop.
impl Stop for () {
    fn requested(&self) -> Option<StopSignal> {
        None
    }
}

/// The first signal, packed as `milliseconds since START << 8 | number`
/// so a relayed copy racing in on another thread sees both at once; 0 is
/// none.
static FIRST: AtomicU64 = AtomicU64::new(0);
static WRITING: AtomicBool = AtomicBool::new(false);
static START: OnceLock<Instant> = OnceLock::new();

/// The process's SIGINT and SIGTERM, once [`install`]ed.
pub struct ProcessSignals(());

/// Installs the handlers; later calls return the same handle.
pub fn install() -> io::Result<&'static ProcessSignals> {
    static INSTALLED: OnceLock<ProcessSignals> = OnceLock::new();
    if let Some(installed) = INSTALLED.get() {
        return Ok(installed);
    }
    START.get_or_init(Instant::now);
    for sig in [StopSignal::Interrupt, StopSignal::Terminate] {
        let n = sig.number();
        // SAFETY: the handler only reads a clock and touches atomics, or
        // exits through signal_hook's async-signal-safe `exit`.
        unsafe { signal_hook::low_level::register(n, move || on_signal(n)) }?;
    }
    Ok(INSTALLED.get_or_init(|| ProcessSignals(())))
}

fn on_signal(n: i32) {
    let now = START.get().map_or(0, |s| s.elapsed().as_millis() as u64);
    let packed = (now << 8) | n as u64;
    let Err(first) = FIRST.compare_exchange(0, packed, Ordering::SeqCst, Ordering::SeqCst) else {
        return;
    };
    let (first_n, first_at) = ((first & 0xff) as i32, first >> 8);
    let again = first_n != n
        || WRITING.load(Ordering::SeqCst)
        || now.saturating_sub(first_at) >= GRACE.as_millis() as u64;
    if again {
        signal_hook::low_level::exit(128 + n);
    }
}

impl Stop for ProcessSignals {
    fn requested(&self) -> Option<StopSignal> {
        StopSignal::from_number((FIRST.load(Ordering::SeqCst) & 0xff) as i32)
    }

    fn writing(&self) {
        WRITING.store(true, Ordering::SeqCst);
    }
}
