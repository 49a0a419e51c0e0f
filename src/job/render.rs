//! The render job: which samples to render, where the checkpoint goes,
//! whether a resumed checkpoint is of this render, and how the results are
//! written, with a full disk or a signal along the way.

use super::files::{check_output, refuse_overlaps, Checkpoint, Role};
use super::observer::{metered_by, Observer, Stage};
use super::signals::Stop;
use super::{JobError, WriteError};
use crate::accel::{Backend as _, BackendKind, BuildOptions};
use crate::distributed::part::{self, PartMeta};
use crate::distributed::passes::{render_passes, Outcome, PassTiming};
use crate::distributed::task::{self, Task};
use crate::image::io::{self as imageio, WriteOptions};
use crate::render::film::ErrorEstimate;
use crate::render::{build_accel, Film, RenderOptions, RenderStats, Sampling};
use crate::sampling::SamplerKind;
use crate::scene::{LoadOptions, Scene, SceneError};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What the command line may override in the scene file.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
    pub seed: Option<u64>,
    pub russian_roulette: Option<bool>,
    pub sampler: Option<SamplerKind>,
    pub resolution: Option<(u32, u32)>,
    /// Mitsuba parameters (`-D`) and `--strict`.
    pub load: LoadOptions,
}

impl Overrides {
    /// Loads the scene at `path` and applies the overrides.
    pub fn load(&self, path: &Path) -> Result<Scene, SceneError> {
        let mut scene = crate::scene::load_with(path, &self.load)?;
        if let Some((w, h)) = self.resolution {
            scene.camera.resize(w, h);
        }
        let settings = &mut scene.render;
        settings.spp = self.spp.unwrap_or(settings.spp);
        settings.max_depth = self.max_depth.unwrap_or(settings.max_depth);
        settings.seed = self.seed.unwrap_or(settings.seed);
        settings.russian_roulette = self.russian_roulette.unwrap_or(settings.russian_roulette);
        settings.sampler = self.sampler.unwrap_or(settings.sampler);
        Ok(scene)
    }
}

/// Which of the scene's samples per pixel to render.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SampleChoice {
    /// Sample indices `A..B` (`--samples`).
    Range(Range<u32>),
    /// A task's share (`--task-index`, `--task-count`).
    Task(Task),
    /// The batch system's task, from the environment (Slurm, Kubernetes),
    /// with the task count given on the command line if it was; every
    /// sample when there is no task.
    BatchSystem { count: Option<u32> },
}

/// How the user asked for samples to be spread over the pixels; the
/// scene's spp settles the defaults.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SamplingRequest {
    #[default]
    Uniform,
    /// `--noise-threshold E` with `--min-spp` (default 16) and `--max-spp`
    /// (default: the scene's spp).
    NoiseThreshold {
        threshold: f64,
        min_spp: Option<u32>,
        max_spp: Option<u32>,
    },
    /// `--adaptive`: the scene's spp, times the pixels, as the budget.
    Budget,
}

/// Samples a noise threshold gives every pixel before its first decision,
/// unless `--min-spp` says otherwise: enough for a first variance estimate
/// that is not mostly luck.
pub const DEFAULT_MIN_SPP: u32 = 16;

impl SamplingRequest {
    /// The sampling of a render of `spp` samples per pixel.
    pub fn resolve(self, spp: u32) -> Result<Sampling, JobError> {
        Ok(match self {
            Self::Uniform => Sampling::Uniform,
            Self::Budget => Sampling::Budget { spp },
            Self::NoiseThreshold {
                threshold,
                min_spp,
                max_spp,
            } => {
                let max = max_spp.unwrap_or(spp);
                let min = min_spp.unwrap_or(DEFAULT_MIN_SPP.min(max));
                if min > max {
                    return Err(JobError::MinAboveMax { min, max });
                }
                Sampling::NoiseThreshold {
                    threshold,
                    min_spp: min,
                    max_spp: max,
                }
            }
        })
    }
}

/// `luz render`, as parsed from its arguments.
#[derive(Clone, Debug)]
pub struct RenderJob {
    pub scene: PathBuf,
    /// Default: the scene's name with `.png`, in the current folder.
    pub output: Option<PathBuf>,
    pub backend: BackendKind,
    pub build: BuildOptions,
    pub overrides: Overrides,
    pub samples: SampleChoice,
    /// Default: the resume file, else the output's name with
    /// `.checkpoint.exr`.
    pub checkpoint: Option<PathBuf>,
    /// `None`: no checkpoints while rendering (one is still written when
    /// the render is stopped).
    pub checkpoint_every: Option<Duration>,
    pub resume: Option<PathBuf>,
    pub write: WriteOptions,
    pub sampling: SamplingRequest,
    /// Render whole passes until this much time is spent (`--time-limit`),
    /// then write what is done.
    pub time_limit: Option<Duration>,
}

/// What a finished job did.
#[derive(Clone, Debug)]
pub struct JobReport {
    pub output: PathBuf,
    pub resolution: (u32, u32),
    pub spp: u32,
    pub samples: Range<u32>,
    /// Samples per pixel the resumed checkpoint held (0 without one).
    pub resumed_at: u64,
    pub backend: &'static str,
    pub load_time: Duration,
    pub hash_time: Duration,
    pub build_time: Duration,
    pub stats: RenderStats,
    pub checkpoints: u32,
    pub checkpoint_time: Duration,
    pub checkpoint_failures: u32,
    pub non_finite: u64,
    pub sampling: Sampling,
    /// The samples of all pixels together.
    pub sample_total: u64,
    /// The image's error, estimated from its own samples.
    pub estimate: ErrorEstimate,
    /// The time limit ended the render before its samples were done.
    pub out_of_time: bool,
}

impl RenderJob {
    pub fn output_path(&self) -> PathBuf {
        self.output.clone().unwrap_or_else(|| {
            let stem = self.scene.file_stem().unwrap_or("render".as_ref());
            PathBuf::from(stem).with_extension("png")
        })
    }

    pub fn checkpoint_path(&self) -> PathBuf {
        self.checkpoint
            .clone()
            .or_else(|| self.resume.clone())
            .unwrap_or_else(|| self.output_path().with_extension("checkpoint.exr"))
    }

    /// Runs the job. Everything that can be refused is refused before the
    /// first sample; see the module docs of [`super`].
    pub fn run(&self, observer: &dyn Observer, stop: &dyn Stop) -> Result<JobReport, JobError> {
        let output = self.output_path();
        let checkpoint_path = self.checkpoint_path();
        imageio::check_output_path(&output).map_err(JobError::OutputKind)?;
        if !is_exr(&checkpoint_path) {
            return Err(JobError::CheckpointNotExr {
                path: checkpoint_path,
            });
        }
        check_output(Role::Output, &output)?;
        check_output(Role::Checkpoint, &checkpoint_path)?;
        let outputs = [
            (Role::Output, output.as_path()),
            (Role::Checkpoint, &checkpoint_path),
        ];
        let mut inputs = vec![(Role::Scene, self.scene.as_path())];
        inputs.extend(self.resume.as_deref().map(|r| (Role::Resume, r)));
        // The resumed checkpoint is the checkpoint by default: only the
        // output must not be it.
        refuse_overlaps(&outputs, &inputs[..1])?;
        refuse_overlaps(&outputs[..1], &inputs)?;
        let mut checkpoint = Checkpoint::claim(&checkpoint_path, self.resume.as_deref())?;

        let load_start = Instant::now();
        let scene = Arc::new(metered_by(observer, || self.overrides.load(&self.scene))?);
        let load_time = load_start.elapsed();
        observer.stage_done(Stage::Loaded, load_time);
        let scene_files: Vec<(Role, &Path)> = scene
            .files
            .iter()
            .enumerate()
            .map(|(i, f)| {
                (
                    if i == 0 {
                        Role::Scene
                    } else {
                        Role::SceneInput
                    },
                    f.as_path(),
                )
            })
            .collect();
        refuse_overlaps(&outputs, &scene_files)?;

        let sampling = self.sampling.resolve(scene.render.spp)?;
        let spp = sampling.max_spp(scene.render.spp);
        let samples = self.sample_range(spp, observer)?;
        if sampling.is_adaptive() && samples != (0..spp) {
            return Err(JobError::AdaptiveSplit { sampling, samples });
        }
        if samples != (0..spp) && !is_exr(&output) {
            return Err(JobError::PartialNeedsExr {
                path: output,
                samples,
            });
        }

        let build_start = Instant::now();
        let accel = metered_by(observer, || build_accel(&scene, self.backend, &self.build))?;
        let build_time = build_start.elapsed();
        observer.stage_done(Stage::Built, build_time);

        let hash_start = Instant::now();
        let meta = PartMeta {
            version: env!("CARGO_PKG_VERSION").into(),
            scene_hash: part::scene_hash(&scene),
            seed: scene.render.seed,
            spp,
            ranges: vec![samples.clone()],
            sampling,
            backend: accel.kind(),
        };
        let hash_time = hash_start.elapsed();
        let (width, height) = (scene.camera.width, scene.camera.height);
        let mut film = match &self.resume {
            Some(path) => resumed_film(path, &meta, (width, height))?,
            None => {
                let mut film = Film::try_new(width, height).map_err(|error| JobError::Film {
                    scene: self.scene.clone(),
                    error,
                })?;
                film.plan = sampling.first_plan(film.sum.len());
                film
            }
        };
        let resumed_at = film.samples;

        let options = RenderOptions {
            samples: samples.clone(),
            sampling,
            ..RenderOptions::from_scene(&scene)
        };
        // Rows of one sample each: for an adaptive render, as many as it
        // may take at most.
        let most = match sampling {
            Sampling::Budget { spp } => spp as u64,
            _ => samples.len() as u64,
        };
        let pixels = width as u64 * height as u64;
        let remaining = (most * pixels).saturating_sub(film.total_samples());
        observer.rendering(remaining / width as u64, width as u64);
        // Passes short enough that a signal is answered within a second or
        // so, and that checkpoints come about when asked.
        let pass_time = self
            .checkpoint_every
            .map_or(Duration::from_secs(1), |every| {
                every.min(Duration::from_secs(1))
            });
        let mut last_checkpoint = Instant::now();
        let (mut checkpoints, mut checkpoint_time, mut checkpoint_failures) =
            (0, Duration::ZERO, 0);
        let timing = PassTiming {
            pass_time,
            deadline: self.time_limit.map(|limit| Instant::now() + limit),
        };
        let (outcome, stats) = render_passes(
            &scene,
            &accel,
            &options,
            &mut film,
            observer,
            timing,
            || stop.requested().is_some(),
            |film| {
                match self.checkpoint_every {
                    Some(every) if last_checkpoint.elapsed() >= every => {}
                    _ => return Ok::<_, JobError>(()),
                }
                let start = Instant::now();
                match write_checkpoint(&mut checkpoint, &meta, film) {
                    Ok(()) => checkpoints += 1,
                    Err(e) => {
                        checkpoint_failures += 1;
                        observer.checkpoint_failed(&e);
                    }
                }
                checkpoint_time += start.elapsed();
                last_checkpoint = Instant::now();
                Ok(())
            },
        )?;

        stop.writing();
        if outcome == Outcome::Stopped {
            return Err(stopped(
                stop,
                &mut checkpoint,
                &output,
                &meta,
                &film,
                &self.write,
            ));
        }
        if let Err(error) = write_output(&output, &held_meta(&meta, &film), &film, &self.write) {
            let saved = write_checkpoint(&mut checkpoint, &meta, &film)
                .map(|()| checkpoint.path().to_path_buf())
                .map_err(Box::new);
            return Err(JobError::OutputLost { error, saved });
        }
        // The output holds everything now; a checkpoint left behind would
        // only mislead a later --resume.
        checkpoint.remove().map_err(|source| JobError::Write {
            role: Role::Checkpoint,
            error: WriteError::Image(crate::image::ImageError::Io {
                path: checkpoint.path().to_path_buf(),
                source,
            }),
        })?;
        Ok(JobReport {
            output,
            resolution: (width, height),
            spp,
            samples: samples.start..samples.start + film.samples as u32,
            resumed_at,
            backend: accel.name(),
            load_time,
            hash_time,
            build_time,
            stats,
            checkpoints,
            checkpoint_time,
            checkpoint_failures,
            non_finite: film.non_finite,
            sampling,
            sample_total: film.total_samples(),
            estimate: film.error_estimate(),
            out_of_time: outcome == Outcome::OutOfTime,
        })
    }

    /// The samples to render: --samples, else the task's share of `0..spp`
    /// (--task-index, else the batch system's), else all of them.
    fn sample_range(&self, spp: u32, observer: &dyn Observer) -> Result<Range<u32>, JobError> {
        let task = match &self.samples {
            SampleChoice::Range(samples) => {
                if samples.end > spp {
                    return Err(JobError::SamplesBeyondSpp {
                        samples: samples.clone(),
                        spp,
                    });
                }
                return Ok(samples.clone());
            }
            SampleChoice::Task(task) => task.clone(),
            SampleChoice::BatchSystem { count } => {
                match task::from_env(|name| std::env::var(name).ok(), *count)? {
                    Some(task) => task,
                    None if count.is_some() => return Err(JobError::TaskCountWithoutIndex),
                    None => return Ok(0..spp),
                }
            }
        };
        let range = task.range(spp)?;
        observer.task_chosen(&task, &range);
        Ok(range)
    }
}

/// The error of a render stopped by a signal, after saving what it holds.
fn stopped(
    stop: &dyn Stop,
    checkpoint: &mut Checkpoint,
    output: &Path,
    meta: &PartMeta,
    film: &Film,
    write: &WriteOptions,
) -> JobError {
    let signal = stop
        .requested()
        .expect("a stopped render was asked to stop");
    let (held, of) = (film.samples, meta.sample_count());
    if film.samples == 0 {
        return JobError::Interrupted {
            signal,
            held,
            of,
            saved: None,
        };
    }
    let saved = write_checkpoint(checkpoint, meta, film)
        .map_err(|error| JobError::Write {
            role: Role::Checkpoint,
            error,
        })
        .and_then(|()| {
            write_output(output, &held_meta(meta, film), film, write).map_err(|error| {
                JobError::Write {
                    role: Role::Output,
                    error,
                }
            })
        });
    match saved {
        Ok(()) => JobError::Interrupted {
            signal,
            held,
            of,
            saved: Some((checkpoint.path().to_path_buf(), output.to_path_buf())),
        },
        Err(e) => e,
    }
}

fn is_exr(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// The film of a checkpoint, if it is of this very render.
fn resumed_film(path: &Path, meta: &PartMeta, resolution: (u32, u32)) -> Result<Film, JobError> {
    let saved = part::read(path).map_err(JobError::Part)?;
    let (ours, theirs) = (meta, &saved.meta);
    let saved_resolution = (saved.film.width, saved.film.height);
    if let Some(mismatch) = part::first_mismatch((ours, resolution), (theirs, saved_resolution)) {
        return Err(JobError::ResumeMismatch {
            path: path.to_path_buf(),
            mismatch,
        });
    }
    let wanted = &ours.ranges[0];
    match theirs.ranges.as_slice() {
        [held] if held.start == wanted.start && held.end <= wanted.end => Ok(saved.film),
        _ => Err(JobError::ResumeSamples {
            path: path.to_path_buf(),
            held: part::format_ranges(&theirs.ranges),
            wanted: wanted.clone(),
        }),
    }
}

/// `meta` for a film holding the first `film.samples` of the samples `meta`
/// was made for.
fn held_meta(meta: &PartMeta, film: &Film) -> PartMeta {
    let start = meta.ranges[0].start;
    let range = start..start + film.samples as u32;
    PartMeta {
        ranges: vec![range],
        ..meta.clone()
    }
}

fn write_checkpoint(
    checkpoint: &mut Checkpoint,
    meta: &PartMeta,
    film: &Film,
) -> Result<(), WriteError> {
    let meta = held_meta(meta, film);
    checkpoint.write(|path| part::write(path, &meta, film).map_err(WriteError::from))
}

/// Writes `film` to `path`: a part (`meta` says what it holds) when `path`
/// is an EXR, else the tone mapped image.
pub(super) fn write_output(
    path: &Path,
    meta: &PartMeta,
    film: &Film,
    write: &WriteOptions,
) -> Result<(), WriteError> {
    if is_exr(path) {
        part::write(path, meta, film)?;
    } else {
        imageio::write(path, &film.image(), write)?;
    }
    Ok(())
}
