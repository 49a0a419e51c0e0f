//! The `luz` command line: render a scene, tone map or compare images, and
//! tell what this build can do.

mod args;
mod progress;

use args::{Cli, Command, MergeArgs, RenderArgs, StudyArgs};
use clap::Parser;
use luz::distributed::part;
use luz::distributed::task::Task;
use luz::image::{metrics, zscore};
use luz::job::{self, signals, JobError, JobReport, RenderJob, SampleChoice, SamplingRequest};
use luz::render::Sampling;
use luz::scene::Scene;
use luz::study::{ReferenceSource, Study, StudyOptions};
use progress::{progress_bar, Bar, RenderObserver};
use std::path::Path;
use std::process::ExitCode;

/// A failure and the exit status it earns: 2 for bad input (scene, image,
/// arguments), 1 for everything else.
struct Failure {
    status: u8,
    message: String,
}

impl Failure {
    fn input(e: impl std::fmt::Display) -> Self {
        Self {
            status: 2,
            message: e.to_string(),
        }
    }

    fn other(e: impl std::fmt::Display) -> Self {
        Self {
            status: 1,
            message: e.to_string(),
        }
    }

    fn job(e: JobError) -> Self {
        Self {
            status: e.exit_status(),
            message: e.to_string(),
        }
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if e.use_stderr() => {
            eprint!("{}", shorten_arguments(&e.render().to_string()));
            return ExitCode::from(e.exit_code() as u8);
        }
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Tonemap {
            input,
            output,
            tonemap,
        } => job::tonemap_file(&input, &output, &tonemap.write_options()).map_err(Failure::job),
        Command::Compare {
            a,
            b,
            abs_tol,
            rel_tol,
            fail_above,
            sigma,
        } => compare(&a, &b, abs_tol, rel_tol, fail_above, sigma),
        Command::Merge(args) => merge_parts(&args),
        Command::Study(args) => study(args),
        Command::Info => info(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            eprintln!("luz: {}", failure.message);
            ExitCode::from(failure.status)
        }
    }
}

/// `message` with every long argument of this process that it repeats
/// shortened (clap echoes a rejected value whole, however long).
fn shorten_arguments(message: &str) -> String {
    let mut message = message.to_string();
    for arg in std::env::args().skip(1).filter(|a| a.len() > 80) {
        let echoed = luz::echo::echo(&arg);
        message = message.replace(&arg, echoed.trim_matches('`'));
    }
    message
}

fn render(args: RenderArgs) -> Result<(), Failure> {
    args.settings.start_threads()?;
    let samples = match (args.samples.clone(), args.task_index, args.task_count) {
        (Some(range), _, _) => SampleChoice::Range(range),
        (None, Some(index), Some(count)) => SampleChoice::Task(Task {
            index,
            count,
            source: "--task-index",
        }),
        (None, _, count) => SampleChoice::BatchSystem { count },
    };
    let job = RenderJob {
        scene: args.scene.clone(),
        output: args.output.clone(),
        backend: args.backend,
        build: args.settings.build_options(),
        overrides: args.settings.overrides(args.spp),
        samples,
        checkpoint: args.checkpoint.clone(),
        checkpoint_every: args.checkpoint_every.0,
        resume: args.resume.clone(),
        write: args.tonemap.write_options(),
        sampling: match (args.noise_threshold, args.adaptive) {
            (Some(threshold), _) => SamplingRequest::NoiseThreshold {
                threshold,
                min_spp: args.min_spp,
                max_spp: args.max_spp,
            },
            (None, true) => SamplingRequest::Budget,
            (None, false) => SamplingRequest::Uniform,
        },
        time_limit: args.time_limit.and_then(|limit| limit.0),
    };
    let signals = signals::install().map_err(Failure::other)?;
    let observer = RenderObserver::new(args.quiet);
    let result = job.run(&observer, signals);
    observer.finish();
    let report = result.map_err(|e| match &e {
        JobError::Interrupted {
            saved: Some((checkpoint, _)),
            ..
        } => Failure {
            status: e.exit_status(),
            message: format!("{e}; resume with: {}", resume_command(checkpoint)),
        },
        _ => Failure::job(e),
    })?;
    if report.non_finite > 0 {
        eprintln!(
            "luz: warning: {} samples were not finite and were left out",
            report.non_finite
        );
    }
    if !args.quiet {
        eprintln!("{}: {}", args.scene.display(), summary(&report));
    }
    Ok(())
}

/// The render's summary line (after the scene's name).
fn summary(r: &JobReport) -> String {
    let resumed = if r.resumed_at > 0 {
        format!(" (resumed at {})", r.resumed_at)
    } else {
        String::new()
    };
    let mut saved = String::new();
    if r.checkpoints > 0 {
        saved = format!(
            ", {} checkpoints in {:.3} s",
            r.checkpoints,
            r.checkpoint_time.as_secs_f64()
        );
    }
    if r.checkpoint_failures > 0 {
        saved.push_str(&format!(", {} checkpoints failed", r.checkpoint_failures));
    }
    let (width, height) = r.resolution;
    let stats = &r.stats;
    let out_of_time = if r.out_of_time {
        " (stopped by --time-limit)"
    } else {
        ""
    };
    let samples = match r.sampling {
        Sampling::Uniform => format!(
            "samples {}..{}{resumed}{out_of_time} of {} spp",
            r.samples.start, r.samples.end, r.spp
        ),
        sampling => format!(
            "{sampling}: {:.1} spp on average, up to {}{resumed}{out_of_time}",
            r.sample_total as f64 / (width as f64 * height as f64),
            r.samples.end
        ),
    };
    format!(
        "{width}x{height}, {samples}, {} backend (loaded in {:.3} s, hashed in {:.3} s, built in {:.3} s), {} threads: {:.3} s, {:.2} Msamples/s, {:.2} Mrays/s, estimated relative error {:.2}% (relMSE {:.3e}){saved} -> {}",
        r.backend,
        r.load_time.as_secs_f64(),
        r.hash_time.as_secs_f64(),
        r.build_time.as_secs_f64(),
        rayon::current_num_threads(),
        stats.wall.as_secs_f64(),
        stats.msamples_per_s(),
        stats.mrays_per_s(),
        100.0 * r.estimate.rel_error(),
        r.estimate.rel_mse,
        r.output.display()
    )
}

/// This process's command line with `--resume CHECKPOINT` in place of any
/// `--resume` it had, quoted for a POSIX shell.
fn resume_command(checkpoint: &Path) -> String {
    let mut words = Vec::new();
    let mut args = std::env::args();
    while let Some(arg) = args.next() {
        if arg == "--resume" {
            args.next();
        } else if !arg.starts_with("--resume=") {
            words.push(arg);
        }
    }
    words.push("--resume".into());
    words.push(checkpoint.display().to_string());
    let quote = |w: &String| {
        if !w.is_empty()
            && w.chars()
                .all(|c| c.is_ascii_alphanumeric() || "_-./:=@%+,".contains(c))
        {
            w.clone()
        } else {
            format!("'{}'", w.replace('\'', r"'\''"))
        }
    };
    words.iter().map(quote).collect::<Vec<_>>().join(" ")
}

fn merge_parts(args: &MergeArgs) -> Result<(), Failure> {
    let write = args.tonemap.write_options();
    let merged = job::merge_files(&args.parts, &args.output, args.allow_gaps, &write)
        .map_err(Failure::job)?;
    let (meta, film) = (&merged.part.meta, &merged.part.film);
    if !merged.missing.is_empty() {
        eprintln!(
            "luz: warning: samples {} of {} per pixel are in no part; the image holds {}",
            part::format_ranges(&merged.missing),
            meta.spp,
            film.samples
        );
    }
    if !args.quiet {
        eprintln!(
            "merged {} parts: samples {} ({} per pixel), {}x{} -> {}",
            args.parts.len(),
            part::format_ranges(&meta.ranges),
            film.samples,
            film.width,
            film.height,
            args.output.display()
        );
    }
    Ok(())
}

fn study(args: StudyArgs) -> Result<(), Failure> {
    args.settings.start_threads()?;
    let scene: Scene = args
        .settings
        .overrides(None)
        .load(&args.scene)
        .map_err(Failure::input)?;
    let width = scene.camera.width;
    let reference = match args.reference {
        Some(path) => ReferenceSource::File(path),
        None => ReferenceSource::Render {
            spp: args.reference_spp,
            save: args.save_reference,
        },
    };
    let options = StudyOptions {
        spp: args.spp,
        backends: args.backends,
        vary: args.vary,
        max_depths: args.max_depths,
        build: args.settings.build_options(),
        reference,
        target_rel_mse: args.target_rel_mse,
        out: args.out.clone(),
    };
    let failure = |e: luz::study::StudyError| {
        if e.is_input() {
            Failure::input(e)
        } else {
            Failure::other(e)
        }
    };
    let name = args.scene.file_name().unwrap_or(args.scene.as_os_str());
    let study = Study::new(scene, &name.to_string_lossy(), options).map_err(failure)?;
    if let (Some(r), false) = (study.reference_render(), args.quiet) {
        eprintln!(
            "luz: no --reference given: rendering one first ({r}){}",
            match &r.save {
                Some(path) => format!(", saved to {}", path.display()),
                None => " (keep it with --save-reference REF.exr)".into(),
            }
        );
    }
    let bar = progress_bar(study.work(), width as u64, args.quiet);
    let report = study.run(&Bar(bar.clone())).map_err(failure)?;
    bar.finish_and_clear();
    if !args.quiet {
        eprintln!(
            "luz: {} settings x {} sample counts -> {}: {}",
            report.settings.len(),
            report.rows.len() / report.settings.len().max(1),
            args.out.display(),
            report.conclusion()
        );
    }
    Ok(())
}

fn compare(
    a: &Path,
    b: &Path,
    abs_tol: f64,
    rel_tol: f64,
    fail_above: Option<f64>,
    sigma: Option<f64>,
) -> Result<(), Failure> {
    let (image_a, error_a) = job::read_with_error(a).map_err(Failure::job)?;
    let (image_b, error_b) = job::read_with_error(b).map_err(Failure::job)?;
    let comparison =
        metrics::compare(&image_a, &image_b, abs_tol, rel_tol).map_err(Failure::input)?;
    print_stdout(&format!("{comparison}\n"))?;
    if let Some(k) = sigma {
        let noise = zscore::compare_in_noise((&image_a, &error_a), (&image_b, &error_b), k)
            .map_err(Failure::input)?;
        print_stdout(&format!("{noise}\n"))?;
    }
    match fail_above {
        Some(limit) if comparison.rmse.is_nan() || comparison.rmse > limit => {
            Err(Failure::other(format!(
                "RMSE {:.6e} is above --fail-above {limit:e}",
                comparison.rmse
            )))
        }
        _ => Ok(()),
    }
}

/// Writes to stdout; a reader that went away (`luz info | head`) is not an
/// error worth a message, let alone a panic.
fn print_stdout(text: &str) -> Result<(), Failure> {
    use std::io::Write;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::other(e)),
        _ => Ok(()),
    }
}

fn info() -> Result<(), Failure> {
    let embree = match luz::accel::embree_version() {
        Some(v) => v,
        None => "not compiled in (install libembree-dev and rebuild)".into(),
    };
    print_stdout(&format!(
        "luz {}\nbackends: {}\nembree: {embree}\nthreads: {}\ncpu features: {}\n",
        env!("CARGO_PKG_VERSION"),
        luz::accel::compiled_backends().join(", "),
        rayon::current_num_threads(),
        cpu_features().join(" ")
    ))
}

fn cpu_features() -> Vec<&'static str> {
    let mut found = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        macro_rules! probe {
            ($($f:tt),*) => {$(
                if std::arch::is_x86_feature_detected!($f) {
                    found.push($f);
                }
            )*};
        }
        probe!("sse4.2", "avx", "avx2", "fma", "avx512f");
    }
    #[cfg(target_arch = "aarch64")]
    {
        if std::arch::is_aarch64_feature_detected!("neon") {
            found.push("neon");
        }
    }
    found
}
