//! The render job driven in-process (issue 13, classes 1 and 8): what
//! happens to the user's files when the final write fails, when a render is
//! stopped, and when it is resumed.

use crate::common::temp_dir;
use luz::accel::{BackendKind, BuildOptions};
use luz::distributed::part;
use luz::distributed::task::{Task, TaskError};
use luz::image::io::WriteOptions;
use luz::job::signals::{Stop, StopSignal};
use luz::job::{JobError, Observer, Overrides, RenderJob, SampleChoice, SamplingRequest};
use luz::render::Progress;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

fn job(scene: &Path, output: PathBuf) -> RenderJob {
    RenderJob {
        scene: scene.to_path_buf(),
        output: Some(output),
        backend: BackendKind::Rust,
        build: BuildOptions::default(),
        overrides: Overrides {
            spp: Some(8),
            resolution: Some((16, 16)),
            ..Overrides::default()
        },
        samples: SampleChoice::Range(0..8),
        checkpoint: None,
        checkpoint_every: None,
        resume: None,
        write: WriteOptions::default(),
        sampling: SamplingRequest::Uniform,
        time_limit: None,
    }
}

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-area.toml")
}

/// Removes a folder once rendering starts: the final write into it fails.
struct RemoveFolder(PathBuf);

impl Progress for RemoveFolder {
    fn row_done(&self, _: u32) {}
}

impl Observer for RemoveFolder {
    fn rendering(&self, _: u64, _: u64) {
        std::fs::remove_dir_all(&self.0).unwrap();
    }
}

#[test]
fn a_failed_final_write_keeps_every_sample_in_the_checkpoint() {
    let dir = temp_dir("final-write");
    let out_dir = dir.join("out");
    std::fs::create_dir(&out_dir).unwrap();
    let output = out_dir.join("image.exr");
    let checkpoint = dir.join("keep.exr");
    let mut render = job(&cornell(), output.clone());
    render.checkpoint = Some(checkpoint.clone());
    let err = render.run(&RemoveFolder(out_dir.clone()), &()).unwrap_err();
    assert!(
        matches!(err, JobError::OutputLost { saved: Ok(_), .. }),
        "{err}"
    );
    assert_eq!(err.exit_status(), 1);
    assert!(err.to_string().contains("keep.exr"), "{err}");
    let kept = part::read(&checkpoint).unwrap();
    assert_eq!(kept.meta.ranges, vec![0..8]);
    assert_eq!(kept.film.samples, 8);

    // Resuming from it writes the output without rendering again, and the
    // output is the straight run's.
    std::fs::create_dir(&out_dir).unwrap();
    render.resume = Some(checkpoint.clone());
    let report = render.run(&(), &()).unwrap();
    assert_eq!(report.resumed_at, 8);
    assert!(
        !checkpoint.exists(),
        "the finished render's checkpoint stays"
    );
    let straight = dir.join("straight.exr");
    job(&cornell(), straight.clone()).run(&(), &()).unwrap();
    assert_eq!(
        part::read(&output).unwrap().film,
        part::read(&straight).unwrap().film
    );
}

/// Asks to stop after `passes` passes (each pass asks once or twice).
struct StopAfter {
    asked: AtomicU32,
    passes: u32,
}

impl Stop for StopAfter {
    fn requested(&self) -> Option<StopSignal> {
        let asked = self.asked.fetch_add(1, Ordering::Relaxed);
        (asked >= self.passes).then_some(StopSignal::Terminate)
    }
}

#[test]
fn a_stopped_render_saves_both_files_and_resumes_to_the_same_image() {
    let dir = temp_dir("stopped");
    let output = dir.join("image.exr");
    let render = job(&cornell(), output.clone());
    let stop = StopAfter {
        asked: AtomicU32::new(0),
        passes: 2,
    };
    let err = render.run(&(), &stop).unwrap_err();
    let JobError::Interrupted {
        signal,
        held,
        saved: Some((checkpoint, partial)),
        ..
    } = &err
    else {
        panic!("{err}");
    };
    assert_eq!((*signal, err.exit_status()), (StopSignal::Terminate, 143));
    assert!(*held > 0 && *held < 8, "held {held}");
    assert_eq!(partial, &output);
    assert_eq!(part::read(checkpoint).unwrap().film.samples, *held);

    let mut resumed = render.clone();
    resumed.resume = Some(checkpoint.clone());
    resumed.run(&(), &()).unwrap();
    assert!(!checkpoint.exists());
    let straight = dir.join("straight.exr");
    job(&cornell(), straight.clone()).run(&(), &()).unwrap();
    assert_eq!(
        part::read(&output).unwrap().film,
        part::read(&straight).unwrap().film
    );
}

#[test]
fn a_resume_file_of_another_render_is_refused_and_kept() {
    let dir = temp_dir("other-resume");
    let theirs = dir.join("theirs.exr");
    let mut other = job(&cornell(), theirs.clone());
    other.overrides.seed = Some(7);
    other.run(&(), &()).unwrap();
    let before = std::fs::read(&theirs).unwrap();
    let mut render = job(&cornell(), dir.join("image.exr"));
    render.resume = Some(theirs.clone());
    let err = render.run(&(), &()).unwrap_err();
    assert!(
        matches!(&err, JobError::ResumeMismatch { mismatch, .. } if mismatch.attribute == "luz:seed"),
        "{err}"
    );
    assert_eq!(err.exit_status(), 2);
    assert_eq!(std::fs::read(&theirs).unwrap(), before);
    assert!(!dir.join("image.exr").exists());
}

#[test]
fn task_errors_are_typed() {
    let dir = temp_dir("tasks");
    let mut render = job(&cornell(), dir.join("p.exr"));
    render.samples = SampleChoice::Task(Task {
        index: 0,
        count: 9,
        source: "--task-index",
    });
    let err = render.run(&(), &()).unwrap_err();
    assert!(
        matches!(
            err,
            JobError::Task(TaskError::MoreTasksThanSamples {
                count: 9,
                spp: 8,
                ..
            })
        ),
        "{err}"
    );
    assert_eq!(err.exit_status(), 2);
}

/// `job` with adaptive sampling `sampling` over all samples.
fn adaptive_job(output: PathBuf, sampling: SamplingRequest) -> RenderJob {
    RenderJob {
        sampling,
        samples: SampleChoice::BatchSystem { count: None },
        overrides: Overrides {
            spp: Some(32),
            resolution: Some((16, 16)),
            ..Overrides::default()
        },
        ..job(&cornell(), output)
    }
}

const ADAPTIVE: [SamplingRequest; 2] = [
    SamplingRequest::NoiseThreshold {
        threshold: 0.2,
        min_spp: Some(4),
        max_spp: None,
    },
    SamplingRequest::Budget,
];

#[test]
fn a_stopped_adaptive_render_resumes_to_the_uninterrupted_image_bit_for_bit() {
    let dir = temp_dir("adaptive-resume");
    for (n, sampling) in ADAPTIVE.into_iter().enumerate() {
        let straight = dir.join(format!("straight-{n}.exr"));
        adaptive_job(straight.clone(), sampling)
            .run(&(), &())
            .unwrap();
        let straight = part::read(&straight).unwrap();
        let plan = straight.film.plan.as_ref().expect("an adaptive part");
        assert!(
            plan.count.iter().min() < plan.count.iter().max(),
            "{sampling:?}"
        );

        let output = dir.join(format!("image-{n}.exr"));
        let render = adaptive_job(output.clone(), sampling);
        for passes in [1, 3] {
            let stop = StopAfter {
                asked: AtomicU32::new(0),
                passes,
            };
            let err = render.run(&(), &stop).unwrap_err();
            let JobError::Interrupted {
                saved: Some((checkpoint, _)),
                ..
            } = &err
            else {
                panic!("{err}");
            };
            let mut resumed = render.clone();
            resumed.resume = Some(checkpoint.clone());
            let report = resumed.run(&(), &()).unwrap();
            assert!(report.resumed_at > 0);
            assert_eq!(report.sample_total, straight.film.total_samples());
            assert_eq!(part::read(&output).unwrap(), straight, "{sampling:?}");
        }
    }
}

#[test]
fn an_adaptive_render_refuses_a_task_and_another_sampling_s_checkpoint() {
    let dir = temp_dir("adaptive-refusals");
    let mut split = adaptive_job(dir.join("p.exr"), SamplingRequest::Budget);
    split.samples = SampleChoice::Range(0..16);
    let err = split.run(&(), &()).unwrap_err();
    assert!(matches!(err, JobError::AdaptiveSplit { .. }), "{err}");
    assert!(err.to_string().contains("render it in one job"), "{err}");
    assert_eq!(err.exit_status(), 2);

    let uniform = dir.join("uniform.exr");
    adaptive_job(uniform.clone(), SamplingRequest::Uniform)
        .run(&(), &())
        .unwrap();
    let mut render = adaptive_job(dir.join("image.exr"), SamplingRequest::Budget);
    render.resume = Some(uniform);
    let err = render.run(&(), &()).unwrap_err();
    assert!(
        matches!(&err, JobError::ResumeMismatch { mismatch, .. } if mismatch.attribute == "luz:sampling"),
        "{err}"
    );
}

#[test]
fn a_time_limit_writes_the_samples_it_reached() {
    let dir = temp_dir("time-limit");
    let output = dir.join("image.exr");
    let mut render = job(&cornell(), output.clone());
    render.overrides.spp = Some(1 << 30);
    render.samples = SampleChoice::Range(0..1 << 30);
    render.time_limit = Some(std::time::Duration::from_millis(300));
    let report = render.run(&(), &()).unwrap();
    assert!(report.out_of_time);
    let written = part::read(&output).unwrap();
    let reached = report.samples.end;
    assert!((1..1 << 30).contains(&reached), "{reached}");
    assert_eq!(written.meta.ranges, vec![0..reached]);
    assert_eq!(written.film.samples, reached as u64);
}
