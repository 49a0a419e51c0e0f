//! The `luz` command line: render a scene, tone map or compare images, and
//! tell what this build can do.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use luz::accel::{BackendKind, BuildOptions, Quality};
use luz::distributed::part;
use luz::distributed::task::Task;
use luz::image::io::{self as imageio, WriteOptions};
use luz::image::metrics;
use luz::image::tonemap::{ToneMap, ToneMapParams};
use luz::job::{
    self, signals, JobError, JobReport, Observer, Overrides, RenderJob, SampleChoice, Stage,
    WriteError,
};
use luz::render::Progress;
use luz::sampling::SamplerKind;
use luz::scene::Scene;
use luz::study::{ReferenceSource, Study, StudyOptions, Vary};
use std::io::IsTerminal;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(name = "luz", version, about = "A physically based path tracer")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file.
    Render(RenderArgs),
    /// Tone map an HDR image (EXR, HDR, PPM) into another image.
    Tonemap {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        tonemap: ToneMapArgs,
    },
    /// Compare two images: means, RMSE, relMSE, max difference, agreement.
    Compare {
        a: PathBuf,
        /// The reference.
        b: PathBuf,
        /// Absolute tolerance of a value that counts as agreeing.
        #[arg(long, default_value_t = 0.0, value_parser = parse_non_negative)]
        abs_tol: f64,
        /// Relative tolerance (of the reference) of a value that counts as agreeing.
        #[arg(long, default_value_t = 1e-3, value_parser = parse_non_negative)]
        rel_tol: f64,
        /// Exit with status 1 when the RMSE exceeds this.
        #[arg(long, value_parser = parse_non_negative)]
        fail_above: Option<f64>,
    },
    /// Merge renders of disjoint sample ranges of one scene (EXR files that
    /// `luz render` wrote) into the image of all their samples.
    Merge(MergeArgs),
    /// Speed against accuracy: render a sweep of settings and sample counts,
    /// compare each image with a reference, and write a CSV, a Markdown
    /// summary and log-log plots of error against time.
    Study(StudyArgs),
    /// Version, compiled backends and CPU features.
    Info,
}

#[derive(clap::Args)]
struct MergeArgs {
    /// EXR files written by `luz render`, in any order.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output image; .exr keeps the sums so the result can be merged again.
    #[arg(short, long)]
    output: PathBuf,
    /// Merge even when some sample ranges are in no part (and say which).
    #[arg(long)]
    allow_gaps: bool,
    /// No summary line.
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    tonemap: ToneMapArgs,
}

#[derive(clap::Args)]
struct RenderArgs {
    scene: PathBuf,
    /// Output image; the extension picks the format: exr, hdr, ppm (HDR PPM
    /// with `#MAX=`), png (tone mapped). Default: the scene's name with .png.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Intersection backend: auto (Embree when compiled in), rust, embree.
    #[arg(long, default_value = "auto")]
    backend: BackendKind,
    #[arg(long)]
    spp: Option<u32>,
    #[command(flatten)]
    settings: SettingsArgs,
    /// No progress bar and no summary line.
    #[arg(long)]
    quiet: bool,
    /// Render only sample indices A to B-1 of every pixel (output: .exr).
    #[arg(long, value_name = "A..B", value_parser = part::parse_range, conflicts_with = "task_index")]
    samples: Option<Range<u32>>,
    /// Render the I-th of --task-count equal shares of --spp (output: .exr).
    /// Default: SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX when set.
    #[arg(long, value_name = "I", requires = "task_count")]
    task_index: Option<u32>,
    /// Number of tasks sharing the samples (default with Slurm:
    /// SLURM_ARRAY_TASK_COUNT).
    #[arg(long, value_name = "N")]
    task_count: Option<u32>,
    /// Save the film this often (e.g. 30s, 5m, 1h; off: never).
    #[arg(long, value_name = "DURATION", default_value = "1m", value_parser = parse_interval)]
    checkpoint_every: Interval,
    /// Checkpoint file. Default: the --resume file, else the output's name
    /// with .checkpoint.exr.
    #[arg(long, value_name = "FILE.exr")]
    checkpoint: Option<PathBuf>,
    /// Continue the render saved in this checkpoint.
    #[arg(long, value_name = "CHECKPOINT")]
    resume: Option<PathBuf>,
    #[command(flatten)]
    tonemap: ToneMapArgs,
}

/// How often to checkpoint; `None` is never.
#[derive(Clone, Copy, Debug)]
struct Interval(Option<Duration>);

fn parse_interval(s: &str) -> Result<Interval, String> {
    if s == "off" {
        return Ok(Interval(None));
    }
    let bad = || {
        format!(
            "expected a duration such as 500ms, 30s, 5m, 1h or off, found {}",
            luz::echo::echo(s)
        )
    };
    let split = s.find(|c: char| c.is_ascii_alphabetic()).ok_or_else(bad)?;
    let value: f64 = s[..split].parse().map_err(|_| bad())?;
    let unit = match &s[split..] {
        "ms" => 1e-3,
        "s" => 1.0,
        "m" => 60.0,
        "h" => 3600.0,
        _ => return Err(bad()),
    };
    match Duration::try_from_secs_f64(value * unit) {
        Ok(d) if !d.is_zero() => Ok(Interval(Some(d))),
        _ => Err(bad()),
    }
}

#[derive(clap::Args)]
struct StudyArgs {
    scene: PathBuf,
    /// Directory for study.csv, summary.md and the plots (created).
    #[arg(long, default_value = "study")]
    out: PathBuf,
    /// Samples per pixel of the sweep.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32,64")]
    spp: Vec<u32>,
    /// Backends to compare (default: every backend of this build).
    #[arg(long, value_delimiter = ',')]
    backends: Vec<BackendKind>,
    /// What to vary, every combination: nee (area lights; point lights are
    /// always sampled), russian-roulette, max-depth, embree-quality,
    /// embree-robust, sampler. A varied setting replaces its option
    /// (--max-depth, --russian-roulette, --embree-quality, --embree-robust,
    /// --sampler).
    #[arg(long, value_delimiter = ',')]
    vary: Vec<Vary>,
    /// Depths of `--vary max-depth` (default 3,5,8).
    #[arg(long, value_delimiter = ',')]
    max_depths: Option<Vec<u32>>,
    /// Reference image (default: rendered first, 16 times the largest spp,
    /// with another seed).
    #[arg(long, conflicts_with_all = ["reference_spp", "save_reference"])]
    reference: Option<PathBuf>,
    /// Samples per pixel of the rendered reference.
    #[arg(long)]
    reference_spp: Option<u32>,
    /// Also write the rendered reference to this image (.exr keeps it exact).
    #[arg(long)]
    save_reference: Option<PathBuf>,
    /// The relMSE the summary ranks settings by the time to reach.
    #[arg(long, default_value_t = 1e-2)]
    target_rel_mse: f64,
    #[command(flatten)]
    settings: SettingsArgs,
    /// No progress bar, notes or summary line.
    #[arg(long)]
    quiet: bool,
}

/// What `render` and `study` may override in the scene file, and how they
/// run (`study` applies them where it does not vary them).
#[derive(clap::Args)]
struct SettingsArgs {
    /// Maximum path segments, camera segment included (Mitsuba's max_depth).
    #[arg(long)]
    max_depth: Option<u32>,
    #[arg(long)]
    seed: Option<u64>,
    /// Russian roulette over the lobes: on or off.
    #[arg(long, value_parser = parse_on_off)]
    russian_roulette: Option<bool>,
    /// Where samples' numbers come from: sobol (Owen-scrambled Sobol'
    /// points, the default) or independent (PCG32).
    #[arg(long)]
    sampler: Option<SamplerKind>,
    /// Worker threads (default: all cores; at most 4096).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..=4096))]
    threads: Option<u16>,
    /// Image size as WIDTHxHEIGHT, overriding the scene's.
    #[arg(long, value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,
    /// The native BVH's build: auto, low (Morton codes, quickest), medium
    /// (binned SAH), high. auto: low below one sample per triangle, else
    /// medium.
    #[arg(long, default_value = "auto")]
    bvh_quality: Quality,
    /// Embree's BVH quality: auto, low, medium, high. auto: low and compact
    /// below one sample per triangle, else medium.
    #[arg(long, default_value = "auto")]
    embree_quality: Quality,
    /// Embree's robust (watertight, slower) traversal.
    #[arg(long)]
    embree_robust: bool,
}

impl SettingsArgs {
    fn build_options(&self) -> BuildOptions {
        BuildOptions {
            bvh_quality: self.bvh_quality,
            embree_quality: self.embree_quality,
            embree_robust: self.embree_robust,
        }
    }

    fn overrides(&self, spp: Option<u32>) -> Overrides {
        Overrides {
            spp,
            max_depth: self.max_depth,
            seed: self.seed,
            russian_roulette: self.russian_roulette,
            sampler: self.sampler,
            resolution: self.resolution,
        }
    }

    /// Starts the worker threads `--threads` asks for.
    fn start_threads(&self) -> Result<(), Failure> {
        if let Some(n) = self.threads {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n.into())
                .build_global()
                .map_err(|e| {
                    Failure::input(format!("--threads {n}: cannot start the threads: {e}"))
                })?;
        }
        Ok(())
    }
}

#[derive(clap::Args)]
struct ToneMapArgs {
    /// Tone mapping of 8-bit outputs: clamp, equalize, equalize-clamp, gamma,
    /// clamp-gamma, reinhard.
    #[arg(long, visible_alias = "op", default_value = "clamp-gamma")]
    tonemap: ToneMap,
    /// Gamma of the gamma operators.
    #[arg(long, default_value_t = 2.2, value_parser = parse_positive::<f32>)]
    gamma: f32,
    /// Exposure in stops: radiance is scaled by 2^EXPOSURE before tone mapping.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse_finite::<f32>)]
    exposure: f32,
}

impl ToneMapArgs {
    fn write_options(&self) -> WriteOptions {
        WriteOptions {
            tonemap: self.tonemap,
            params: ToneMapParams {
                gamma: self.gamma,
                exposure: self.exposure,
                ..ToneMapParams::default()
            },
            ..WriteOptions::default()
        }
    }
}

/// A finite number.
fn parse_finite<T: std::str::FromStr + Into<f64> + Copy>(s: &str) -> Result<T, String> {
    match s.trim().parse::<T>() {
        Ok(v) if v.into().is_finite() => Ok(v),
        _ => Err(format!(
            "expected a finite number, found {}",
            luz::echo::echo(s)
        )),
    }
}

/// A finite number above zero.
fn parse_positive<T: std::str::FromStr + Into<f64> + Copy>(s: &str) -> Result<T, String> {
    match parse_finite::<T>(s) {
        Ok(v) if v.into() > 0.0 => Ok(v),
        _ => Err(format!(
            "expected a finite number above 0, found {}",
            luz::echo::echo(s)
        )),
    }
}

/// A finite number, zero or above.
fn parse_non_negative(s: &str) -> Result<f64, String> {
    match parse_finite::<f64>(s) {
        Ok(v) if v >= 0.0 => Ok(v),
        _ => Err(format!(
            "expected a finite number of 0 or more, found {}",
            luz::echo::echo(s)
        )),
    }
}

fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" | "true" => Ok(true),
        "off" | "false" => Ok(false),
        _ => Err(format!("expected on or off, found {}", luz::echo::echo(s))),
    }
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let bad = || {
        format!(
            "expected WIDTHxHEIGHT such as 512x512, found {}",
            luz::echo::echo(s)
        )
    };
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?);
    luz::render::film::check_resolution(w, h)?;
    Ok((w, h))
}

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
        } => compare(&a, &b, abs_tol, rel_tol, fail_above),
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

/// Rows finished, drawn as a bar with an ETA and the sample rate; a step is
/// one sample of every pixel of a row.
struct Bar(ProgressBar);

impl Progress for Bar {
    fn row_done(&self, samples: u32) {
        self.0.inc(samples as u64);
    }
}

fn progress_bar(steps: u64, samples_per_step: u64, quiet: bool) -> ProgressBar {
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
struct RenderObserver {
    quiet: bool,
    bar: OnceLock<ProgressBar>,
    /// When the next progress line is due.
    next_line: Mutex<Instant>,
}

/// When a render that is not on a terminal first logs its progress: soon
/// enough that a week-long request is seen at once, late enough that the
/// rate is known.
const FIRST_LOG: Duration = Duration::from_secs(5);

/// How often a render that is not on a terminal logs its progress.
const LOG_EVERY: Duration = Duration::from_secs(60);

impl RenderObserver {
    fn new(quiet: bool) -> Self {
        Self {
            quiet,
            bar: OnceLock::new(),
            next_line: Mutex::new(Instant::now() + FIRST_LOG),
        }
    }

    fn finish(&self) {
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
    format!(
        "{width}x{height}, samples {}..{}{resumed} of {} spp, {} backend (loaded in {:.3} s, hashed in {:.3} s, built in {:.3} s), {} threads: {:.3} s, {:.2} Msamples/s, {:.2} Mrays/s{saved} -> {}",
        r.samples.start,
        r.samples.end,
        r.spp,
        r.backend,
        r.load_time.as_secs_f64(),
        r.hash_time.as_secs_f64(),
        r.build_time.as_secs_f64(),
        rayon::current_num_threads(),
        stats.wall.as_secs_f64(),
        stats.msamples_per_s(),
        stats.mrays_per_s(),
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
) -> Result<(), Failure> {
    let image_a = imageio::read(a).map_err(Failure::input)?;
    let image_b = imageio::read(b).map_err(Failure::input)?;
    let comparison =
        metrics::compare(&image_a, &image_b, abs_tol, rel_tol).map_err(Failure::input)?;
    print_stdout(&format!("{comparison}\n"))?;
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
