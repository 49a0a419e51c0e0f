//! The `luz` command line: render a scene, tone map or compare images, and
//! tell what this build can do.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use luz::accel::{Accel, Backend as _, BackendKind, BuildOptions, Quality};
use luz::distributed::merge::merge;
use luz::distributed::part::{self, PartMeta};
use luz::distributed::passes::{render_passes, Outcome};
use luz::distributed::task::{self, Task};
use luz::image::io::{self as imageio, WriteOptions};
use luz::image::metrics;
use luz::image::tonemap::{ToneMap, ToneMapParams};
use luz::render::{Film, Progress, RenderOptions};
use luz::scene::Scene;
use luz::study::{ReferenceSource, Study, StudyOptions, Vary};
use std::io::IsTerminal;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
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
        #[arg(long, default_value_t = 0.0)]
        abs_tol: f64,
        /// Relative tolerance (of the reference) of a value that counts as agreeing.
        #[arg(long, default_value_t = 1e-3)]
        rel_tol: f64,
        /// Exit with status 1 when the RMSE exceeds this.
        #[arg(long)]
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
    let bad = || format!("expected a duration such as 500ms, 30s, 5m, 1h or off, found `{s}`");
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
    /// embree-robust. A varied setting replaces its option (--max-depth,
    /// --russian-roulette, --embree-quality, --embree-robust).
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
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
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

    /// Sets the worker threads, then loads the scene with these overrides
    /// (and `spp`'s).
    fn load_scene(&self, path: &Path, spp: Option<u32>) -> Result<Scene, Failure> {
        if let Some(n) = self.threads {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build_global()
                .map_err(Failure::other)?;
        }
        let mut scene = luz::scene::load(path).map_err(Failure::input)?;
        if let Some((w, h)) = self.resolution {
            scene.camera.width = w;
            scene.camera.height = h;
        }
        let settings = &mut scene.render;
        settings.spp = spp.unwrap_or(settings.spp);
        settings.max_depth = self.max_depth.unwrap_or(settings.max_depth);
        settings.seed = self.seed.unwrap_or(settings.seed);
        settings.russian_roulette = self.russian_roulette.unwrap_or(settings.russian_roulette);
        Ok(scene)
    }
}

#[derive(clap::Args)]
struct ToneMapArgs {
    /// Tone mapping of 8-bit outputs: clamp, equalize, equalize-clamp, gamma,
    /// clamp-gamma, reinhard.
    #[arg(long, visible_alias = "op", default_value = "clamp-gamma")]
    tonemap: ToneMap,
    /// Gamma of the gamma operators.
    #[arg(long, default_value_t = 2.2)]
    gamma: f32,
    /// Exposure in stops: radiance is scaled by 2^EXPOSURE before tone mapping.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
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

fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" | "true" => Ok(true),
        "off" | "false" => Ok(false),
        _ => Err(format!("expected on or off, found `{s}`")),
    }
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected WIDTHxHEIGHT such as 512x512, found `{s}`");
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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Tonemap {
            input,
            output,
            tonemap,
        } => tonemap_file(&input, &output, &tonemap),
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

/// Reports a stage before the first sample that kept the user waiting
/// (over half a second: a large mesh), so a long load is not silent.
fn stage_done(quiet: bool, what: &str, time: Duration) {
    if !quiet && time >= Duration::from_millis(500) {
        eprintln!("luz: {what} in {:.1} s", time.as_secs_f64());
    }
}

fn render(args: RenderArgs) -> Result<(), Failure> {
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = args.scene.file_stem().unwrap_or("render".as_ref());
        PathBuf::from(stem).with_extension("png")
    });
    // Refuse an output we cannot write before spending time on the render.
    imageio::check_output_path(&output).map_err(Failure::input)?;
    let checkpoint = args
        .checkpoint
        .clone()
        .or_else(|| args.resume.clone())
        .unwrap_or_else(|| output.with_extension("checkpoint.exr"));
    if !is_exr(&checkpoint) || checkpoint == output {
        return Err(Failure::input(format!(
            "{}: --checkpoint must name an .exr file other than the output",
            checkpoint.display()
        )));
    }
    imageio::check_output_path(&checkpoint).map_err(Failure::input)?;
    let load_start = Instant::now();
    let scene = args.settings.load_scene(&args.scene, args.spp)?;
    let load_time = load_start.elapsed();
    stage_done(args.quiet, "loaded the scene", load_time);
    let scene = Arc::new(scene);
    let spp = scene.render.spp;

    let samples = sample_range(&args, spp)?;
    if samples != (0..spp) && !is_exr(&output) {
        return Err(Failure::input(format!(
            "{}: a render of samples {}..{} must be written to .exr, which keeps what `luz merge` needs",
            output.display(),
            samples.start,
            samples.end
        )));
    }

    let build_start = Instant::now();
    let build_options = args.settings.build_options();
    let accel = Accel::build(&scene, args.backend, &build_options).map_err(Failure::input)?;
    let build_time = build_start.elapsed();
    stage_done(args.quiet, "built the tree", build_time);

    let hash_start = Instant::now();
    let scene_hash = part::scene_hash(&scene);
    let hash_time = hash_start.elapsed();
    let meta = PartMeta {
        version: env!("CARGO_PKG_VERSION").into(),
        scene_hash,
        seed: scene.render.seed,
        spp,
        ranges: vec![samples.clone()],
        backend: accel.kind(),
    };
    let (width, height) = (scene.camera.width, scene.camera.height);
    let mut film = match &args.resume {
        Some(path) => resumed_film(path, &meta, (width, height))?,
        None => Film::try_new(width, height)
            .map_err(|e| Failure::input(format!("{}: resolution: {e}", args.scene.display())))?,
    };
    let resumed_samples = film.samples;

    // The first SIGINT or SIGTERM stops the render after the pass in flight;
    // a second one ends the process at once, for a user who cannot wait.
    let signal = Arc::new(AtomicUsize::new(0));
    let signalled = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        use signal_hook::flag;
        flag::register_conditional_shutdown(sig, 128 + sig, Arc::clone(&signalled))
            .and_then(|_| flag::register(sig, Arc::clone(&signalled)))
            .and_then(|_| flag::register_usize(sig, Arc::clone(&signal), sig as usize))
            .map_err(Failure::other)?;
    }

    let options = RenderOptions {
        samples: samples.clone(),
        ..RenderOptions::from_scene(&scene)
    };
    let remaining = samples.len() as u64 - film.samples;
    let bar = progress_bar(height as u64 * remaining, width as u64, args.quiet);
    // Passes short enough that a signal is answered within a second or so,
    // and that checkpoints come about when asked.
    let pass_time = args
        .checkpoint_every
        .0
        .map_or(Duration::from_secs(1), |every| {
            every.min(Duration::from_secs(1))
        });
    let mut last_checkpoint = Instant::now();
    let mut checkpoints = (0u32, Duration::ZERO);
    let (outcome, stats) = render_passes(
        &scene,
        &accel,
        &options,
        &mut film,
        &Bar(bar.clone()),
        pass_time,
        || signal.load(Ordering::Relaxed) != 0,
        |film| {
            match args.checkpoint_every.0 {
                Some(every) if last_checkpoint.elapsed() >= every => {}
                _ => return Ok(()),
            }
            let start = Instant::now();
            write_part(&checkpoint, &meta, film)?;
            checkpoints.0 += 1;
            checkpoints.1 += start.elapsed();
            last_checkpoint = Instant::now();
            Ok::<_, Failure>(())
        },
    )?;
    bar.finish_and_clear();

    if outcome == Outcome::Stopped {
        let signal = signal.load(Ordering::Relaxed);
        let name = if signal == signal_hook::consts::SIGINT as usize {
            "SIGINT"
        } else {
            "SIGTERM"
        };
        if film.samples == 0 {
            return Err(Failure {
                status: 128 + signal as u8,
                message: format!(
                    "interrupted by {name} before any sample was done; nothing written"
                ),
            });
        }
        write_part(&checkpoint, &meta, &film)?;
        write_output(&output, &held(&meta, &film), &film, &args.tonemap)?;
        return Err(Failure {
            status: 128 + signal as u8,
            message: format!(
                "interrupted by {name} after {} of {} samples per pixel; wrote the checkpoint {} and the partial image {}; resume with: {}",
                film.samples,
                samples.len(),
                checkpoint.display(),
                output.display(),
                resume_command(&checkpoint)
            ),
        });
    }

    write_output(&output, &held(&meta, &film), &film, &args.tonemap)?;
    // The output holds everything now; a checkpoint left behind would only
    // mislead a later --resume.
    if checkpoint.exists() {
        std::fs::remove_file(&checkpoint)
            .map_err(|e| Failure::other(format!("{}: cannot remove: {e}", checkpoint.display())))?;
    }
    if film.non_finite > 0 {
        eprintln!(
            "luz: warning: {} samples were not finite and were left out",
            film.non_finite
        );
    }
    if !args.quiet {
        let resumed = if resumed_samples > 0 {
            format!(" (resumed at {resumed_samples})")
        } else {
            String::new()
        };
        let saved = if checkpoints.0 > 0 {
            format!(
                ", {} checkpoints in {:.3} s",
                checkpoints.0,
                checkpoints.1.as_secs_f64()
            )
        } else {
            String::new()
        };
        eprintln!(
            "{}: {width}x{height}, samples {}..{}{resumed} of {spp} spp, {} backend (loaded in {:.3} s, hashed in {:.3} s, built in {:.3} s), {} threads: {:.3} s, {:.2} Msamples/s, {:.2} Mrays/s{saved} -> {}",
            args.scene.display(),
            samples.start,
            samples.end,
            accel.name(),
            load_time.as_secs_f64(),
            hash_time.as_secs_f64(),
            build_time.as_secs_f64(),
            rayon::current_num_threads(),
            stats.wall.as_secs_f64(),
            stats.msamples_per_s(),
            stats.mrays_per_s(),
            output.display()
        );
    }
    Ok(())
}

fn is_exr(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// The samples to render: --samples, else the task's share of `0..spp`
/// (--task-index, else the batch system's), else all of them.
fn sample_range(args: &RenderArgs, spp: u32) -> Result<Range<u32>, Failure> {
    if let Some(samples) = &args.samples {
        return Ok(samples.clone());
    }
    let task = match (args.task_index, args.task_count) {
        (Some(index), Some(count)) => Some(Task {
            index,
            count,
            source: "--task-index",
        }),
        (_, count) => {
            task::from_env(|name| std::env::var(name).ok(), count).map_err(Failure::input)?
        }
    };
    match task {
        Some(task) => {
            let range = task.range(spp).map_err(Failure::input)?;
            if !args.quiet {
                eprintln!(
                    "luz: task {} of {} ({}): samples {}..{} of {spp}",
                    task.index, task.count, task.source, range.start, range.end
                );
            }
            Ok(range)
        }
        None if args.task_count.is_some() => Err(Failure::input(
            "--task-count needs --task-index, SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX",
        )),
        None => Ok(0..spp),
    }
}

/// The film of a checkpoint, if it is of this very render.
fn resumed_film(path: &Path, meta: &PartMeta, resolution: (u32, u32)) -> Result<Film, Failure> {
    let saved = part::read(path).map_err(Failure::input)?;
    let refuse = |field: &str, message: String| {
        Failure::input(format!("{}: {field}: {message}", path.display()))
    };
    let (ours, theirs) = (meta, &saved.meta);
    let saved_resolution = (saved.film.width, saved.film.height);
    if let Some(m) = part::first_mismatch((ours, resolution), (theirs, saved_resolution)) {
        return Err(refuse(
            m.attribute,
            format!(
                "the checkpoint has {}, this render {}: it is not of this render",
                m.theirs, m.ours
            ),
        ));
    }
    let want = &ours.ranges[0];
    match theirs.ranges.as_slice() {
        [held] if held.start == want.start && held.end <= want.end => Ok(saved.film),
        _ => Err(refuse(
            "luz:samples",
            format!(
                "the checkpoint holds samples {}, which do not start this render's {}..{}",
                part::format_ranges(&theirs.ranges),
                want.start,
                want.end
            ),
        )),
    }
}

/// `meta` for a film holding the first `film.samples` of the samples `meta`
/// was made for.
fn held(meta: &PartMeta, film: &Film) -> PartMeta {
    let start = meta.ranges[0].start;
    let range = start..start + film.samples as u32;
    PartMeta {
        ranges: vec![range],
        ..meta.clone()
    }
}

fn write_part(path: &Path, meta: &PartMeta, film: &Film) -> Result<(), Failure> {
    part::write(path, &held(meta, film), film).map_err(Failure::other)
}

/// Writes `film` to `path`: a part (`meta` says what it holds) when `path`
/// is an EXR, else the tone mapped image.
fn write_output(
    path: &Path,
    meta: &PartMeta,
    film: &Film,
    tonemap: &ToneMapArgs,
) -> Result<(), Failure> {
    if is_exr(path) {
        part::write(path, meta, film).map_err(Failure::other)
    } else {
        imageio::write(path, &film.image(), &tonemap.write_options()).map_err(Failure::other)
    }
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
    imageio::check_output_path(&args.output).map_err(Failure::input)?;
    let mut parts = Vec::new();
    for path in &args.parts {
        parts.push((path.clone(), part::read(path).map_err(Failure::input)?));
    }
    let count = parts.len();
    let merged = merge(parts, args.allow_gaps).map_err(Failure::input)?;
    let (meta, film) = (&merged.part.meta, &merged.part.film);
    if !merged.missing.is_empty() {
        eprintln!(
            "luz: warning: samples {} of {} per pixel are in no part; the image holds {}",
            part::format_ranges(&merged.missing),
            meta.spp,
            film.samples
        );
    }
    write_output(&args.output, meta, film, &args.tonemap)?;
    if !args.quiet {
        eprintln!(
            "merged {count} parts: samples {} ({} per pixel), {}x{} -> {}",
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
    let scene = args.settings.load_scene(&args.scene, None)?;
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

fn tonemap_file(input: &Path, output: &Path, args: &ToneMapArgs) -> Result<(), Failure> {
    imageio::check_output_path(output).map_err(Failure::input)?;
    let image = imageio::read(input).map_err(Failure::input)?;
    imageio::write(output, &image, &args.write_options()).map_err(Failure::other)
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
