//! Rendering a sample range in passes of whole samples per pixel, so that
//! between passes the film can be saved (a checkpoint) or the render stopped
//! cleanly. Passes continue each pixel's running sums (see
//! [`render_into`](crate::render::render_into)), so the image does not depend on how
//! the range is cut into passes.

use crate::accel::Accel;
use crate::render::{render_into_with, Film, Progress, RenderOptions, RenderStats};
use crate::scene::Scene;
use std::time::{Duration, Instant};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every sample of the range is in the film.
    Complete,
    /// `stop` said so; the film holds whole passes.
    Stopped,
}

/// Renders the samples of `options.samples` that `film` does not hold yet
/// (it holds the first `film.samples` of them), in passes of about
/// `pass_time` each. After every pass `after_pass` sees the film; the render
/// ends early, after the pass in flight, once `stop` says so.
#[allow(clippy::too_many_arguments)]
pub fn render_passes<E>(
    scene: &Scene,
    accel: &Accel,
    options: &RenderOptions,
    film: &mut Film,
    progress: &dyn Progress,
    pass_time: Duration,
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
    // One sample first, to learn the rate; then passes sized to the rate.
    let mut pass = 1u64;
    loop {
        let next = range.start as u64 + film.samples;
        if next >= range.end as u64 {
            stats.wall = start.elapsed();
            return Ok((Outcome::Complete, stats));
        }
        if stop() {
            stats.wall = start.elapsed();
            return Ok((Outcome::Stopped, stats));
        }
        let end = (next + pass).min(range.end as u64) as u32;
        let pass_options = RenderOptions {
            samples: next as u32..end,
            ..options.clone()
        };
        let pass_stats = render_into_with(scene, accel, &pass_options, film, progress);
        stats.rays.add(&pass_stats.rays);
        stats.samples += pass_stats.samples;
        let per_sample = pass_stats.wall.as_secs_f64() / (end as u64 - next) as f64;
        let fit = (pass_time.as_secs_f64() / per_sample.max(1e-9)) as u64;
        // At most four times the last pass: a rate measured on a pass of a
        // sample or two is rough, and an overlong pass delays the answer to
        // a signal.
        pass = fit.clamp(1, pass * 4);
        after_pass(film)?;
    }
}
