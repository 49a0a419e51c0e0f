//! The command line's arguments, as clap parses them, and the parsers of
//! their values: every bad value is refused here, with its flag named.

use crate::Failure;
use clap::{Parser, Subcommand};
use luz::accel::{BackendKind, BuildOptions, Quality};
use luz::distributed::part;
use luz::image::io::WriteOptions;
use luz::image::tonemap::{ToneMap, ToneMapParams};
use luz::job::Overrides;
use luz::sampling::SamplerKind;
use luz::scene::LoadOptions;
use luz::study::Vary;
use std::ops::Range;
use std::path::PathBuf;
use std::time::Duration;

#[derive(Parser)]
#[command(name = "luz", version, about = "A physically based path tracer")]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand)]
pub(crate) enum Command {
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
        /// Also count the pixel channels that differ by more than K
        /// combined standard errors, from the stderr of luz's EXR renders
        /// (an image that is not one counts as exact).
        #[arg(long, value_name = "K", value_parser = parse_positive::<f64>)]
        sigma: Option<f64>,
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
pub(crate) struct MergeArgs {
    /// EXR files written by `luz render`, in any order.
    #[arg(required = true)]
    pub(crate) parts: Vec<PathBuf>,
    /// Output image; .exr keeps the sums so the result can be merged again.
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Merge even when some sample ranges are in no part (and say which).
    #[arg(long)]
    pub(crate) allow_gaps: bool,
    /// No summary line.
    #[arg(long)]
    pub(crate) quiet: bool,
    #[command(flatten)]
    pub(crate) tonemap: ToneMapArgs,
}

#[derive(clap::Args)]
pub(crate) struct RenderArgs {
    pub(crate) scene: PathBuf,
    /// Output image; the extension picks the format: exr, hdr, ppm (HDR PPM
    /// with `#MAX=`), png (tone mapped). Default: the scene's name with .png.
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
    /// Intersection backend: auto (Embree when compiled in), rust, embree.
    #[arg(long, default_value = "auto")]
    pub(crate) backend: BackendKind,
    #[arg(long)]
    pub(crate) spp: Option<u32>,
    #[command(flatten)]
    pub(crate) settings: SettingsArgs,
    /// No progress bar and no summary line.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Render only sample indices A to B-1 of every pixel (output: .exr).
    #[arg(long, value_name = "A..B", value_parser = part::parse_range, conflicts_with = "task_index")]
    pub(crate) samples: Option<Range<u32>>,
    /// Render the I-th of --task-count equal shares of --spp (output: .exr).
    /// Default: SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX when set.
    #[arg(long, value_name = "I", requires = "task_count")]
    pub(crate) task_index: Option<u32>,
    /// Number of tasks sharing the samples (default with Slurm:
    /// SLURM_ARRAY_TASK_COUNT).
    #[arg(long, value_name = "N")]
    pub(crate) task_count: Option<u32>,
    /// Save the film this often (e.g. 30s, 5m, 1h; off: never).
    #[arg(long, value_name = "DURATION", default_value = "1m", value_parser = parse_interval)]
    pub(crate) checkpoint_every: Interval,
    /// Checkpoint file. Default: the --resume file, else the output's name
    /// with .checkpoint.exr.
    #[arg(long, value_name = "FILE.exr")]
    pub(crate) checkpoint: Option<PathBuf>,
    /// Continue the render saved in this checkpoint.
    #[arg(long, value_name = "CHECKPOINT")]
    pub(crate) resume: Option<PathBuf>,
    /// Adaptive sampling: each pixel samples until its relative standard
    /// error (standard error over max(mean, 0.1), every channel) is at most
    /// E at two decisions in a row (at --min-spp, twice that, ...), or it
    /// has --max-spp samples.
    #[arg(long, value_name = "E", value_parser = parse_positive::<f64>, conflicts_with = "adaptive")]
    pub(crate) noise_threshold: Option<f64>,
    /// Samples of every pixel before its first noise decision (default 16).
    #[arg(long, value_name = "N", requires = "noise_threshold", value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) min_spp: Option<u32>,
    /// Most samples per pixel with --noise-threshold (default: --spp).
    #[arg(long, value_name = "N", requires = "noise_threshold", value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) max_spp: Option<u32>,
    /// Adaptive sampling at the budget of --spp: spp x pixels samples in
    /// all, spent where the relative error is largest.
    #[arg(long)]
    pub(crate) adaptive: bool,
    /// Render whole passes until this much time is spent (e.g. 90s, 5m),
    /// then write what is done; with --noise-threshold, whichever comes
    /// first. How many samples that is depends on the machine and its
    /// load, so such a render is not reproducible.
    #[arg(long, value_name = "DURATION", value_parser = parse_interval)]
    pub(crate) time_limit: Option<Interval>,
    #[command(flatten)]
    pub(crate) tonemap: ToneMapArgs,
}

/// How often to checkpoint; `None` is never.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Interval(pub(crate) Option<Duration>);

pub(crate) fn parse_interval(s: &str) -> Result<Interval, String> {
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
pub(crate) struct StudyArgs {
    pub(crate) scene: PathBuf,
    /// Directory for study.csv, summary.md and the plots (created).
    #[arg(long, default_value = "study")]
    pub(crate) out: PathBuf,
    /// Samples per pixel of the sweep.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32,64")]
    pub(crate) spp: Vec<u32>,
    /// Backends to compare (default: every backend of this build).
    #[arg(long, value_delimiter = ',')]
    pub(crate) backends: Vec<BackendKind>,
    /// What to vary, every combination: nee (area lights; point lights are
    /// always sampled), russian-roulette, max-depth, embree-quality,
    /// embree-robust, sampler, sampling (uniform against --adaptive at each
    /// spp's budget). A varied setting replaces its option (--max-depth,
    /// --russian-roulette, --embree-quality, --embree-robust, --sampler).
    #[arg(long, value_delimiter = ',')]
    pub(crate) vary: Vec<Vary>,
    /// Depths of `--vary max-depth` (default 3,5,8).
    #[arg(long, value_delimiter = ',')]
    pub(crate) max_depths: Option<Vec<u32>>,
    /// Reference image (default: rendered first, 16 times the largest spp,
    /// with another seed).
    #[arg(long, conflicts_with_all = ["reference_spp", "save_reference"])]
    pub(crate) reference: Option<PathBuf>,
    /// Samples per pixel of the rendered reference.
    #[arg(long)]
    pub(crate) reference_spp: Option<u32>,
    /// Also write the rendered reference to this image (.exr keeps it exact).
    #[arg(long)]
    pub(crate) save_reference: Option<PathBuf>,
    /// The relMSE the summary ranks settings by the time to reach.
    #[arg(long, default_value_t = 1e-2)]
    pub(crate) target_rel_mse: f64,
    #[command(flatten)]
    pub(crate) settings: SettingsArgs,
    /// No progress bar, notes or summary line.
    #[arg(long)]
    pub(crate) quiet: bool,
}

/// What `render` and `study` may override in the scene file, and how they
/// run (`study` applies them where it does not vary them).
#[derive(clap::Args)]
pub(crate) struct SettingsArgs {
    /// Maximum path segments, camera segment included (Mitsuba's max_depth).
    #[arg(long)]
    pub(crate) max_depth: Option<u32>,
    #[arg(long)]
    pub(crate) seed: Option<u64>,
    /// Russian roulette over the lobes: on or off.
    #[arg(long, value_parser = parse_on_off)]
    pub(crate) russian_roulette: Option<bool>,
    /// Where samples' numbers come from: sobol (Owen-scrambled Sobol'
    /// points, the default) or independent (PCG32).
    #[arg(long)]
    pub(crate) sampler: Option<SamplerKind>,
    /// Worker threads (default: all cores; at most 4096).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..=4096))]
    pub(crate) threads: Option<u16>,
    /// Image size as WIDTHxHEIGHT, overriding the scene's.
    #[arg(long, value_parser = parse_resolution)]
    pub(crate) resolution: Option<(u32, u32)>,
    /// The native BVH's build: auto, low (Morton codes, quickest, leaves
    /// read from the meshes), medium (binned SAH), high. auto: low below a
    /// fifth of a sample per triangle, else medium.
    #[arg(long, default_value = "auto")]
    pub(crate) bvh_quality: Quality,
    /// Embree's BVH quality: auto, low, medium, high. auto: low and compact
    /// below one sample per triangle, else medium.
    #[arg(long, default_value = "auto")]
    pub(crate) embree_quality: Quality,
    /// Embree's robust (watertight, slower) traversal.
    #[arg(long)]
    pub(crate) embree_robust: bool,
    /// A parameter of a Mitsuba XML scene: `$KEY` becomes VALUE (repeatable).
    #[arg(short = 'D', long = "define", value_name = "KEY=VALUE", value_parser = parse_define)]
    pub(crate) defines: Vec<(String, String)>,
    /// Refuse the scene when loading it warns (a Mitsuba feature luz
    /// substitutes, mesh data it does not use).
    #[arg(long)]
    pub(crate) strict: bool,
}

impl SettingsArgs {
    pub(crate) fn build_options(&self) -> BuildOptions {
        BuildOptions {
            bvh_quality: self.bvh_quality,
            embree_quality: self.embree_quality,
            embree_robust: self.embree_robust,
        }
    }

    pub(crate) fn overrides(&self, spp: Option<u32>) -> Overrides {
        Overrides {
            spp,
            max_depth: self.max_depth,
            seed: self.seed,
            russian_roulette: self.russian_roulette,
            sampler: self.sampler,
            resolution: self.resolution,
            load: LoadOptions {
                defines: self.defines.clone(),
                strict: self.strict,
            },
        }
    }

    /// Starts the worker threads `--threads` asks for.
    pub(crate) fn start_threads(&self) -> Result<(), Failure> {
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
pub(crate) struct ToneMapArgs {
    /// Tone mapping of 8-bit outputs: clamp, equalize, equalize-clamp, gamma,
    /// clamp-gamma, reinhard.
    #[arg(long, visible_alias = "op", default_value = "clamp-gamma")]
    pub(crate) tonemap: ToneMap,
    /// Gamma of the gamma operators.
    #[arg(long, default_value_t = 2.2, value_parser = parse_positive::<f32>)]
    pub(crate) gamma: f32,
    /// Exposure in stops: radiance is scaled by 2^EXPOSURE before tone mapping.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse_finite::<f32>)]
    pub(crate) exposure: f32,
}

impl ToneMapArgs {
    pub(crate) fn write_options(&self) -> WriteOptions {
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
pub(crate) fn parse_finite<T: std::str::FromStr + Into<f64> + Copy>(s: &str) -> Result<T, String> {
    match s.trim().parse::<T>() {
        Ok(v) if v.into().is_finite() => Ok(v),
        _ => Err(format!(
            "expected a finite number, found {}",
            luz::echo::echo(s)
        )),
    }
}

/// A finite number above zero.
pub(crate) fn parse_positive<T: std::str::FromStr + Into<f64> + Copy>(
    s: &str,
) -> Result<T, String> {
    match parse_finite::<T>(s) {
        Ok(v) if v.into() > 0.0 => Ok(v),
        _ => Err(format!(
            "expected a finite number above 0, found {}",
            luz::echo::echo(s)
        )),
    }
}

/// A finite number, zero or above.
pub(crate) fn parse_non_negative(s: &str) -> Result<f64, String> {
    match parse_finite::<f64>(s) {
        Ok(v) if v >= 0.0 => Ok(v),
        _ => Err(format!(
            "expected a finite number of 0 or more, found {}",
            luz::echo::echo(s)
        )),
    }
}

pub(crate) fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" | "true" => Ok(true),
        "off" | "false" => Ok(false),
        _ => Err(format!("expected on or off, found {}", luz::echo::echo(s))),
    }
}

pub(crate) fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v))
            if !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') =>
        {
            Ok((k.to_string(), v.to_string()))
        }
        _ => Err(format!(
            "expected KEY=VALUE with a KEY of letters, digits and _, found {}",
            luz::echo::echo(s)
        )),
    }
}

pub(crate) fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
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
