//! Benchmark-driven regression check. Runs every benchmark of `traversal`
//! and `render` briefly (criterion, 0.5 s warm-up and 2 s of samples each:
//! about four minutes in all on two cores), compares each figure (triangles
//! or rays per second) with the baseline `benches/baseline/NAME.json`,
//! prints its ratio to the baseline and, for the native backend, its ratio
//! to Embree measured in the same run, and exits with status 1 when a figure
//! is slower than the baseline by more than the threshold.
//!
//! ```text
//! cargo bench --bench regress [-- [--threshold PCT] [--baseline NAME]
//!                                 [--save-baseline [--note TEXT]]]
//! ```
//!
//! `--threshold`: the allowed slowdown in percent (default 10);
//! `--baseline`: the baseline's name (default `default`); `--save-baseline`:
//! write this run's figures as the baseline instead of comparing, with the
//! machine, date and luz commit, and `--note` (what else ran meanwhile).
//! Under `cargo test` (no `--bench`), it only reads the default baseline and
//! runs each benchmark once.

mod assets;
mod backends;
mod baselines;
mod renders;

use baselines::{baseline_path, read_json, write_json, Args, Provenance};

use criterion::Criterion;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

const USAGE: &str = "usage: cargo bench --bench regress -- [--threshold PCT] [--baseline NAME] \
                     [--save-baseline [--note TEXT]]";

#[derive(Debug, Deserialize, Serialize)]
struct Baseline {
    #[serde(flatten)]
    provenance: Provenance,
    threads: usize,
    /// By criterion id.
    figures: BTreeMap<String, Figure>,
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize)]
struct Figure {
    /// Median time of one iteration.
    ms: f64,
    /// Triangles (builds) or rays per second.
    per_s: f64,
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if !args.iter().any(|a| a == "--bench") {
        // `cargo test --all-targets`: check the benchmarks run and the
        // baseline reads, time nothing.
        if let Err(e) = read_json::<Baseline>(&baseline_path("default")) {
            eprintln!("regress: {e}");
            return ExitCode::FAILURE;
        }
        let mut c = Criterion::default().configure_from_args();
        backends::backends(&mut c);
        renders::renders(&mut c);
        return ExitCode::SUCCESS;
    }
    let args = match Args::parse(&args, 10.0, "default") {
        Ok(args) => args,
        Err(e) => {
            eprintln!("regress: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let path = baseline_path(&args.baseline);
    let baseline = if args.save {
        None
    } else {
        match read_json::<Baseline>(&path) {
            Ok(b) => Some(b),
            Err(e) => {
                eprintln!("regress: {e}\n(record one with --save-baseline)");
                return ExitCode::from(2);
            }
        }
    };
    let figures = match run_benchmarks() {
        Ok(f) => f,
        Err(e) => {
            eprintln!("regress: reading criterion's results: {e}");
            return ExitCode::from(2);
        }
    };
    let regressions = report(&figures, baseline.as_ref(), args.threshold);
    if args.save {
        let baseline = Baseline {
            provenance: Provenance::here(args.note),
            threads: rayon::current_num_threads(),
            figures,
        };
        if let Err(e) = write_json(&path, &baseline) {
            eprintln!("regress: {e}");
            return ExitCode::from(2);
        }
        println!("saved {}", path.display());
        return ExitCode::SUCCESS;
    }
    if regressions.is_empty() {
        println!("no figure regressed by more than {}%", args.threshold);
        ExitCode::SUCCESS
    } else {
        println!(
            "{} figures regressed by more than {}%:\n  {}",
            regressions.len(),
            args.threshold,
            regressions.join("\n  ")
        );
        ExitCode::FAILURE
    }
}

/// Runs the benchmarks into a fresh criterion directory and reads back each
/// one's median time and throughput.
fn run_benchmarks() -> Result<BTreeMap<String, Figure>, String> {
    let home = std::env::temp_dir().join(format!("luz-bench-regress-{}", std::process::id()));
    // Criterion reads it once, when it first needs its output directory.
    std::env::set_var("CRITERION_HOME", &home);
    let mut c = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .without_plots();
    backends::backends(&mut c);
    renders::renders(&mut c);
    let mut files = Vec::new();
    find_results(&home, &mut files).map_err(|e| format!("{}: {e}", home.display()))?;
    let figures = files.iter().map(|dir| read_result(dir)).collect();
    // A leftover directory in /tmp is harmless: ignore a failure to remove.
    let _ = std::fs::remove_dir_all(&home);
    figures
}

/// The `new` directories criterion writes a benchmark's results to.
fn find_results(dir: &Path, found: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n == "new") {
                found.push(path);
            } else {
                find_results(&path, found)?;
            }
        }
    }
    Ok(())
}

/// One benchmark's id and figure from criterion's `benchmark.json` (id and
/// elements per iteration) and `estimates.json` (times in ns).
fn read_result(dir: &Path) -> Result<(String, Figure), String> {
    let json = |name: &str| read_json::<serde_json::Value>(&dir.join(name));
    let (benchmark, estimates) = (json("benchmark.json")?, json("estimates.json")?);
    let missing = |what| format!("{}: no {what}", dir.display());
    let id = benchmark["full_id"]
        .as_str()
        .ok_or_else(|| missing("full_id"))?;
    let elements = benchmark["throughput"]["Elements"]
        .as_f64()
        .ok_or_else(|| missing("throughput"))?;
    let ns = estimates["median"]["point_estimate"]
        .as_f64()
        .ok_or_else(|| missing("median"))?;
    let figure = Figure {
        ms: ns * 1e-6,
        per_s: elements / (ns * 1e-9),
    };
    Ok((id.to_string(), figure))
}

/// Prints every figure, its ratio to the baseline and, on native-backend
/// lines, native/Embree; returns the figures slower than the baseline by
/// more than `threshold` percent.
fn report(
    figures: &BTreeMap<String, Figure>,
    baseline: Option<&Baseline>,
    threshold: f64,
) -> Vec<String> {
    let mut regressions = Vec::new();
    println!(
        "\n{:<44} {:>14} {:>11} {:>12} {:>14}",
        "benchmark", "throughput", "time", "vs baseline", "native/Embree"
    );
    for (id, now) in figures {
        let unit = if id.starts_with("build/") {
            "Mtri/s"
        } else {
            "Mrays/s"
        };
        let vs_baseline = match baseline.map(|b| b.figures.get(id)) {
            None => String::new(),
            Some(None) => "new".into(),
            Some(Some(then)) => {
                let ratio = now.per_s / then.per_s;
                if ratio < 1.0 - threshold / 100.0 {
                    regressions.push(format!("{id}: {ratio:.3} of the baseline"));
                    format!("{ratio:.3} SLOWER")
                } else {
                    format!("{ratio:.3}")
                }
            }
        };
        let native_vs_embree = id
            .strip_suffix("/rust")
            .and_then(|stem| {
                ["embree", "embree-medium"]
                    .iter()
                    .find_map(|e| figures.get(&format!("{stem}/{e}")))
            })
            .map(|embree| format!("{:.3}", now.per_s / embree.per_s))
            .unwrap_or_default();
        println!(
            "{id:<44} {:>7.2} {unit:<7} {:>8.2} ms {vs_baseline:>12} {native_vs_embree:>14}",
            now.per_s * 1e-6,
            now.ms
        );
    }
    if let Some(baseline) = baseline {
        for id in baseline
            .figures
            .keys()
            .filter(|id| !figures.contains_key(*id))
        {
            println!("{id:<44} not measured in this run (assets or Embree missing?)");
        }
    }
    regressions
}
