//! The `luz` command line: render a scene, tone map or compare images, and
//! tell what this build can do.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use luz::accel::{Accel, Backend as _, BackendKind, BuildOptions, EmbreeQuality};
use luz::image::io::{self as imageio, WriteOptions};
use luz::image::metrics;
use luz::image::tonemap::{ToneMap, ToneMapParams};
use luz::render::{render_with, Progress, RenderOptions};
use luz::scene::Scene;
use luz::study::{ReferenceSource, Study, StudyOptions, Vary};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

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
    /// Speed against accuracy: render a sweep of settings and sample counts,
    /// compare each image with a reference, and write a CSV, a Markdown
    /// summary and log-log plots of error against time.
    Study(StudyArgs),
    /// Version, compiled backends and CPU features.
    Info,
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
    /// Embree's BVH quality: low, medium, high.
    #[arg(long, default_value = "medium")]
    embree_quality: EmbreeQuality,
    /// Embree's robust (watertight, slower) traversal.
    #[arg(long)]
    embree_robust: bool,
    /// No progress bar and no summary line.
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    tonemap: ToneMapArgs,
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
    /// embree-robust.
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
    /// Maximum path segments where max-depth is not varied.
    #[arg(long)]
    max_depth: Option<u32>,
    #[arg(long)]
    seed: Option<u64>,
    /// Russian roulette where it is not varied: on or off.
    #[arg(long, value_parser = parse_on_off)]
    russian_roulette: Option<bool>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Image size as WIDTHxHEIGHT, overriding the scene's.
    #[arg(long, value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,
    /// Embree's BVH quality where it is not varied.
    #[arg(long, default_value = "medium")]
    embree_quality: EmbreeQuality,
    /// Embree's robust traversal where it is not varied.
    #[arg(long)]
    embree_robust: bool,
    /// No progress bar, notes or summary line.
    #[arg(long)]
    quiet: bool,
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
    if w == 0 || h == 0 || w > 1 << 15 || h > 1 << 15 {
        return Err(format!("resolution {w}x{h} is outside 1..=32768 per side"));
    }
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

/// Rows finished, drawn as a bar with an ETA and the sample rate.
struct Bar(ProgressBar);

impl Progress for Bar {
    fn row_done(&self) {
        self.0.inc(1);
    }
}

fn progress_bar(rows: u64, samples_per_row: u64, quiet: bool) -> ProgressBar {
    let bar = ProgressBar::new(rows);
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
                    let rate = state.per_sec() * samples_per_row as f64 / 1e6;
                    let _ = write!(w, "{rate:.2} Msamples/s");
                },
            );
    bar.set_style(style);
    bar
}

fn render(args: RenderArgs) -> Result<(), Failure> {
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = args.scene.file_stem().unwrap_or("render".as_ref());
        PathBuf::from(stem).with_extension("png")
    });
    // Refuse an output we cannot write before spending time on the render.
    imageio::check_output_path(&output).map_err(Failure::input)?;
    use_threads(args.threads)?;
    let scene = load_scene(
        &args.scene,
        &Overrides {
            resolution: args.resolution,
            spp: args.spp,
            max_depth: args.max_depth,
            seed: args.seed,
            russian_roulette: args.russian_roulette,
        },
    )?;
    let scene = Arc::new(scene);

    let build_start = Instant::now();
    let build_options = BuildOptions {
        embree_quality: args.embree_quality,
        embree_robust: args.embree_robust,
    };
    let accel = Accel::build(&scene, args.backend, &build_options).map_err(Failure::input)?;
    let build_time = build_start.elapsed();

    let options = RenderOptions::from_scene(&scene);
    let (width, height) = (scene.camera.width, scene.camera.height);
    let bar = progress_bar(
        height as u64,
        width as u64 * scene.render.spp as u64,
        args.quiet,
    );
    let (film, stats) = render_with(&scene, &accel, &options, &Bar(bar.clone()));
    bar.finish_and_clear();

    imageio::write(&output, &film.image(), &args.tonemap.write_options())
        .map_err(Failure::other)?;
    if film.non_finite > 0 {
        eprintln!(
            "luz: warning: {} samples were not finite and were left out",
            film.non_finite
        );
    }
    if !args.quiet {
        eprintln!(
            "{}: {width}x{height}, {} spp, {} backend (built in {:.3} s), {} threads: {:.3} s, {:.2} Msamples/s, {:.2} Mrays/s -> {}",
            args.scene.display(),
            scene.render.spp,
            accel.name(),
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

/// What the command line overrides in a scene file.
struct Overrides {
    resolution: Option<(u32, u32)>,
    spp: Option<u32>,
    max_depth: Option<u32>,
    seed: Option<u64>,
    russian_roulette: Option<bool>,
}

fn load_scene(path: &Path, o: &Overrides) -> Result<Scene, Failure> {
    let mut scene = luz::scene::load(path).map_err(Failure::input)?;
    if let Some((w, h)) = o.resolution {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    let settings = &mut scene.render;
    settings.spp = o.spp.unwrap_or(settings.spp);
    settings.max_depth = o.max_depth.unwrap_or(settings.max_depth);
    settings.seed = o.seed.unwrap_or(settings.seed);
    settings.russian_roulette = o.russian_roulette.unwrap_or(settings.russian_roulette);
    Ok(scene)
}

fn use_threads(threads: Option<usize>) -> Result<(), Failure> {
    match threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(Failure::other),
        None => Ok(()),
    }
}

fn study(args: StudyArgs) -> Result<(), Failure> {
    use_threads(args.threads)?;
    let scene = load_scene(
        &args.scene,
        &Overrides {
            resolution: args.resolution,
            spp: None,
            max_depth: args.max_depth,
            seed: args.seed,
            russian_roulette: args.russian_roulette,
        },
    )?;
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
        build: BuildOptions {
            embree_quality: args.embree_quality,
            embree_robust: args.embree_robust,
        },
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
