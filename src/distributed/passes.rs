//! Rendering a sample range in passes of whole samples per pixel, so that
//! between passes the film can be saved (a checkpoint) or the render stopped
//! cleanly. Passes continue each pixel's running sums (see
//! [`render_into`](crate::render::render_into)), so the image does not depend on how
//! the range is cut into passes. A time limit ends the render after whole
//! passes; how many passes that is depends on the machine, so such a render
//! is the one kind that is not deterministic.

use crate::accel::Accel;
use crate::render::{render_into_with, Film, Progress, RenderOptions, RenderStats};
use crate::scene::Scene;
use std::time::{Duration, Instant};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every sample of the range is in the film (for an adaptive render:
    /// every pixel has stopped).
    Complete,
    /// `stop` said so; the film holds whole passes.
    Stopped,
    /// The time limit came first; the film holds whole passes.
    OutOfTime,
}

/// When passes end and how long they may take.
#[derive(Clone, Copy, Debug)]
pub struct PassTiming {
    /// About how long a pass takes, so that a signal or a checkpoint waits
    /// no longer.
    pub pass_time: Duration,
    /// No pass ends after this; the render ends, complete or not.
    pub deadline: Option<Instant>,
}

/// Renders the samples of `options.samples` that `film` does not hold yet
/// (it holds the first `film.samples` of them), in passes of about
/// `timing.pass_time` each. After every pass `after_pass` sees the film; the
/// render ends early, after the pass in flight, once `stop` says so, and
/// before a pass that the deadline would cut.
///
/// A film with a plan (an adaptive render) renders until
/// `options.sampling` stops every pixel; its decisions are made here, between
/// passes, whenever every pixel has reached its goal.
#[allow(clippy::too_many_arguments)]
pub fn render_passes<E>(
    scene: &Scene,
    accel: &Accel,
    options: &RenderOptions,
    film: &mut Film,
    progress: &dyn Progress,
    timing: PassTiming,
    stop: impl Fn() -> bool,
    mut after_pass: impl FnMut(&Film) -> Result<(), E>,
) -> Result<(Outcome, RenderStats), E> {
    let start = Instant::now();
    let range = &options.samples;
    let mut stats = RenderStats {
        wall: Duration::ZERO,
        rays: Default::default(),
        samples: 0,
    };
    let finish = |mut stats: RenderStats, outcome| {
        stats.wall = start.elapsed();
        Ok((outcome, stats))
    };
    // One sample first, to learn the rate; then passes sized to the rate.
    let mut pass = 1u64;
    let mut per_sample = None;
    loop {
        let pixels_left = match film.plan.as_ref() {
            None => {
                let next = range.start as u64 + film.samples;
                (next < range.end as u64).then_some(film.sum.len() as u64)
            }
            Some(_) => options.sampling.pass_due(film).then(|| {
                let plan = film.plan.as_ref().expect("an adaptive film keeps its plan");
                let active = plan.count.iter().zip(&plan.goal).filter(|(c, g)| c < g);
                active.count() as u64
            }),
        };
        let Some(pixels_left) = pixels_left else {
            return finish(stats, Outcome::Complete);
        };
        if stop() {
            return finish(stats, Outcome::Stopped);
        }
        if let (Some(deadline), Some(per_sample)) = (timing.deadline, per_sample) {
            // Whole samples of the pixels left, as many as the time left
            // holds, at the rate measured so far.
            let left = deadline
                .saturating_duration_since(Instant::now())
                .as_secs_f64();
            let fits = (left / (per_sample * pixels_left as f64)) as u64;
            if fits == 0 {
                return finish(stats, Outcome::OutOfTime);
            }
            pass = pass.min(fits);
        }
        let next = range.start as u64 + film.samples;
        let samples = match film.plan {
            None => next as u32..(next + pass).min(range.end as u64) as u32,
            Some(_) => 0..pass.min(u32::MAX as u64) as u32,
        };
        let pass_options = RenderOptions {
            samples,
            ..options.clone()
        };
        let pass_stats = render_into_with(scene, accel, &pass_options, film, progress);
        stats.rays.add(&pass_stats.rays);
        stats.samples += pass_stats.samples;
        // Time per sample of one pixel: the rate the next pass is sized by.
        let rate = pass_stats.wall.as_secs_f64() / pass_stats.samples.max(1) as f64;
        per_sample = Some(rate);
        let fit = (timing.pass_time.as_secs_f64() / (rate * pixels_left as f64).max(1e-12)) as u64;
        // At most four times the last pass: a rate measured on a pass of a
        // sample or two is rough, and an overlong pass delays the answer to
        // a signal.
        pass = fit.clamp(1, pass * 4);
        after_pass(film)?;
    }
}
