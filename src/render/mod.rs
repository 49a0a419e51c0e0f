//! The parallel render loop: rows of pixels in parallel (rayon), every sample
//! drawing its numbers from a sampler keyed by (seed, pixel, sample index),
//! each pixel summing its samples in order. The image is therefore
//! the same for any thread count, and disjoint sample ranges merge exactly.

pub mod adaptive;
pub mod film;
pub mod integrator;
mod normals;

pub use adaptive::Sampling;
pub use film::{Film, PixelPlan, PixelSum};
pub use integrator::{Integrator, IntegratorSettings, RayCounts};

use crate::accel::{Accel, AccelError, AccelTree, Backend, BackendKind, BuildOptions, Work};
use crate::math::Vec2;
use crate::sampling::{Sampler, SamplerKind};
use crate::scene::Scene;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Sample indices to render in every pixel.
    pub samples: Range<u32>,
    pub seed: u64,
    pub sampler: SamplerKind,
    pub integrator: IntegratorSettings,
    /// How the samples are spread over pixels; an adaptive render's film
    /// carries its plan.
    pub sampling: Sampling,
}

impl RenderOptions {
    /// All samples the scene asks for, with its own settings.
    pub fn from_scene(scene: &Scene) -> Self {
        Self {
            samples: 0..scene.render.spp,
            seed: scene.render.seed,
            sampler: scene.render.sampler,
            integrator: IntegratorSettings {
                max_depth: scene.render.max_depth,
                russian_roulette: scene.render.russian_roulette,
            },
            sampling: Sampling::Uniform,
        }
    }
}

#[derive(Clone, Debug)]
pub struct RenderStats {
    pub wall: Duration,
    pub rays: RayCounts,
    pub samples: u64,
}

impl RenderStats {
    pub fn msamples_per_s(&self) -> f64 {
        self.samples as f64 / self.wall.as_secs_f64() / 1e6
    }

    pub fn mrays_per_s(&self) -> f64 {
        self.rays.total() as f64 / self.wall.as_secs_f64() / 1e6
    }
}

/// Something told of progress, once per finished row of a pass.
pub trait Progress: Sync {
    /// One row got `samples` more samples in every pixel.
    fn row_done(&self, samples: u32);
}

impl Progress for () {
    fn row_done(&self, _samples: u32) {}
}

/// Renders `options.samples` of every pixel of `scene` through `backend`;
/// with adaptive `options.sampling`, until every pixel has stopped, in one
/// pass per decision.
pub fn render<B: Backend + ?Sized>(
    scene: &Scene,
    backend: &B,
    options: &RenderOptions,
    progress: &dyn Progress,
) -> (Film, RenderStats) {
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    film.plan = options.sampling.first_plan(film.sum.len());
    if film.plan.is_none() {
        let stats = render_into(scene, backend, options, &mut film, progress);
        return (film, stats);
    }
    let start = Instant::now();
    let mut stats = RenderStats {
        wall: Duration::ZERO,
        rays: RayCounts::default(),
        samples: 0,
    };
    let whole = RenderOptions {
        samples: 0..u32::MAX,
        ..options.clone()
    };
    while options.sampling.pass_due(&mut film) {
        let pass = render_into(scene, backend, &whole, &mut film, progress);
        stats.rays.add(&pass.rays);
        stats.samples += pass.samples;
    }
    stats.wall = start.elapsed();
    (film, stats)
}

/// Adds `options.samples` of every pixel to `film`, continuing each pixel's
/// running sums. Rendering a range in consecutive pieces into one film
/// therefore gives bit for bit the film of rendering it in one go: that is
/// what makes checkpoints and resumed renders exact.
///
/// A film with a [`PixelPlan`] (an adaptive render) instead moves each pixel
/// from its count towards its goal, by at most `options.samples.len()`
/// samples.
pub fn render_into<B: Backend + ?Sized>(
    scene: &Scene,
    backend: &B,
    options: &RenderOptions,
    film: &mut Film,
    progress: &dyn Progress,
) -> RenderStats {
    let start = Instant::now();
    let cam = &scene.camera;
    assert_eq!(
        (film.width, film.height),
        (cam.width, cam.height),
        "the film must have the camera's resolution"
    );
    let pixels = PixelRenderer {
        scene,
        basis: cam.basis(),
        integrator: Integrator::new(scene, backend, options.integrator),
        options,
        width: cam.width,
    };
    let totals = Totals::default();
    let width = cam.width as usize;
    let rows = film
        .sum
        .par_chunks_mut(width)
        .zip(film.sum_sq.par_chunks_mut(width));
    let samples = match &mut film.plan {
        None => {
            let pass = options.samples.len() as u32;
            rows.enumerate().for_each(|(y, (row_sum, row_sq))| {
                let done = pixels.row(
                    y as u32,
                    row_sum,
                    row_sq,
                    |_| options.samples.clone(),
                    &totals,
                );
                progress.row_done((done / width as u64) as u32);
            });
            film.samples += pass as u64;
            pass as u64 * film.sum.len() as u64
        }
        Some(plan) => {
            let most = options.samples.len() as u32;
            let reported = AtomicU64::new(0);
            rows.zip(plan.count.par_chunks_mut(width))
                .zip(plan.goal.par_chunks(width))
                .enumerate()
                .for_each(|(y, (((row_sum, row_sq), count), goal))| {
                    let range = |x: u32| {
                        let c = count[x as usize];
                        c..goal[x as usize].min(c.saturating_add(most))
                    };
                    let done = pixels.row(y as u32, row_sum, row_sq, range, &totals);
                    for (c, g) in count.iter_mut().zip(goal) {
                        *c = (*g).min(c.saturating_add(most));
                    }
                    // Rows of whole samples, however unevenly the pixels
                    // got them.
                    let before = reported.fetch_add(done, Ordering::Relaxed);
                    let rows_done = (before + done) / width as u64 - before / width as u64;
                    progress.row_done(rows_done as u32);
                });
            film.samples = plan.count.iter().copied().max().unwrap_or(0) as u64;
            reported.into_inner()
        }
    };
    film.non_finite += totals.non_finite.into_inner();
    RenderStats {
        wall: start.elapsed(),
        rays: totals.rays.into_inner().expect("no panics while held"),
        samples,
    }
}

/// What the rows of a pass add up.
#[derive(Default)]
struct Totals {
    rays: Mutex<RayCounts>,
    non_finite: AtomicU64,
}

/// Renders the samples of a pass, pixel by pixel.
struct PixelRenderer<'a, B: Backend + ?Sized> {
    scene: &'a Scene,
    basis: crate::scene::camera::CameraBasis,
    integrator: Integrator<'a, B>,
    options: &'a RenderOptions,
    width: u32,
}

impl<B: Backend + ?Sized> PixelRenderer<'_, B> {
    /// Adds samples `range(x)` of every pixel `x` of row `y` to its sums;
    /// returns how many samples that was.
    fn row(
        &self,
        y: u32,
        row_sum: &mut [[f64; 3]],
        row_sq: &mut [[f64; 3]],
        range: impl Fn(u32) -> Range<u32>,
        totals: &Totals,
    ) -> u64 {
        let cam = &self.scene.camera;
        let (seed, sampler_kind) = (self.options.seed, self.options.sampler);
        let mut local = RayCounts::default();
        let (mut bad, mut done) = (0, 0);
        for x in 0..self.width {
            let mut px = PixelSum {
                sum: row_sum[x as usize],
                sum_sq: row_sq[x as usize],
                non_finite: 0,
            };
            let samples = range(x);
            done += samples.len() as u64;
            for s in samples {
                let mut sampler = Sampler::for_sample(sampler_kind, seed, x, y, s);
                let jitter = sampler.camera();
                let ray = cam.ray(&self.basis, Vec2::new(x as f32, y as f32) + jitter);
                px.add(self.integrator.li(ray, &mut sampler, &mut local));
            }
            row_sum[x as usize] = px.sum;
            row_sq[x as usize] = px.sum_sq;
            bad += px.non_finite;
        }
        totals
            .rays
            .lock()
            .expect("no panics while held")
            .add(&local);
        totals.non_finite.fetch_add(bad, Ordering::Relaxed);
        done
    }
}

/// The accelerator over `scene`'s shapes (a hit's `geom` indexes
/// `scene.shapes`), its trees built for a whole render of the scene: every
/// pixel at its `spp`.
pub fn build_accel(
    scene: &Scene,
    kind: BackendKind,
    options: &BuildOptions,
) -> Result<Accel, AccelError> {
    let shapes: Vec<_> = scene.shapes.iter().map(|s| s.geometry.clone()).collect();
    let c = &scene.camera;
    let samples = c.width as f64 * c.height as f64 * scene.render.spp as f64;
    Accel::build(&shapes, Work::of(samples, &shapes), kind, options)
}

/// `render` with the backend held in an `Accel`.
pub fn render_with(
    scene: &Scene,
    accel: &Accel,
    options: &RenderOptions,
    progress: &dyn Progress,
) -> (Film, RenderStats) {
    match accel.tree() {
        AccelTree::Native(t) => render(scene, &accel.over(t), options, progress),
        AccelTree::NativeGathered(t) => render(scene, &accel.over(t), options, progress),
        #[cfg(luz_embree)]
        AccelTree::Embree(t) => render(scene, &accel.over(t), options, progress),
    }
}

/// `render_into` with the backend held in an `Accel`.
pub fn render_into_with(
    scene: &Scene,
    accel: &Accel,
    options: &RenderOptions,
    film: &mut Film,
    progress: &dyn Progress,
) -> RenderStats {
    match accel.tree() {
        AccelTree::Native(t) => render_into(scene, &accel.over(t), options, film, progress),
        AccelTree::NativeGathered(t) => render_into(scene, &accel.over(t), options, film, progress),
        #[cfg(luz_embree)]
        AccelTree::Embree(t) => render_into(scene, &accel.over(t), options, film, progress),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{BackendKind, BuildOptions};
    use std::path::Path;
    use std::sync::Arc;

    fn scene() -> Arc<Scene> {
        let scene = crate::scene::load_str(
            r#"[camera]
eye = [0, 1, 3]
target = [0, 1, 0]
resolution = [6, 5]
[render]
max_depth = 6
[materials.light]
emission = 4
[materials.wall]
kd = 0.7
[[shapes]]
type = "sphere"
center = [0, 2.2, 0]
radius = 0.5
material = "light"
nee = true
[[shapes]]
type = "cuboid"
min = [-2, -0.1, -2]
max = [2, 0, 2]
material = "wall"
"#,
            Path::new("t.toml"),
        )
        .unwrap();
        Arc::new(scene)
    }

    /// The film of `scene` rendered in pieces, from each of `cuts` to the
    /// next, on `threads` threads.
    fn film(scene: &Arc<Scene>, sampler: SamplerKind, cuts: &[u32], threads: usize) -> Film {
        let accel = build_accel(scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
        let mut film = Film::new(scene.camera.width, scene.camera.height);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        for piece in cuts.windows(2) {
            let options = RenderOptions {
                samples: piece[0]..piece[1],
                sampler,
                ..RenderOptions::from_scene(scene)
            };
            pool.install(|| render_into_with(scene, &accel, &options, &mut film, &()));
        }
        film
    }

    /// The film of an adaptive render of `scene`, in passes of at most
    /// `pass` samples per pixel, on `threads` threads.
    fn adaptive_film(scene: &Arc<Scene>, sampling: Sampling, pass: u32, threads: usize) -> Film {
        let accel = build_accel(scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
        let mut film = Film::new(scene.camera.width, scene.camera.height);
        film.plan = sampling.first_plan(film.sum.len());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let options = RenderOptions {
            samples: 0..pass,
            sampling,
            ..RenderOptions::from_scene(scene)
        };
        while sampling.pass_due(&mut film) {
            pool.install(|| render_into_with(scene, &accel, &options, &mut film, &()));
        }
        film
    }

    #[test]
    fn an_adaptive_render_in_any_passes_on_any_threads_is_one_image() {
        let scene = scene();
        for sampling in [
            Sampling::NoiseThreshold {
                threshold: 0.1,
                min_spp: 4,
                max_spp: 64,
            },
            Sampling::Budget { spp: 16 },
        ] {
            let straight = adaptive_film(&scene, sampling, 1000, 1);
            let pieces = adaptive_film(&scene, sampling, 3, 4);
            assert_eq!(straight, pieces, "{sampling}");
            let plan = straight.plan.as_ref().unwrap();
            let (least, most) = (plan.count.iter().min(), plan.count.iter().max());
            assert!(least < most, "{sampling}: pixels got unequal samples");
            if let Sampling::Budget { spp } = sampling {
                assert_eq!(plan.total(), spp as u64 * 30);
            }
        }
    }

    #[test]
    fn a_render_in_pieces_on_any_threads_is_the_render_in_one_go() {
        let scene = scene();
        for sampler in SamplerKind::ALL {
            let straight = film(&scene, sampler, &[0, 9], 1);
            let pieces = film(&scene, sampler, &[0, 2, 7, 9], 2);
            assert_eq!(straight.sum, pieces.sum, "{sampler:?}");
            assert_eq!(straight.sum_sq, pieces.sum_sq, "{sampler:?}");
            assert!(straight.image().mean().x > 0.01, "the scene is lit");
        }
        let (a, b) = (
            film(&scene, SamplerKind::Independent, &[0, 9], 1),
            film(&scene, SamplerKind::Sobol, &[0, 9], 1),
        );
        assert_ne!(a.sum, b.sum, "the samplers draw different numbers");
    }
}
