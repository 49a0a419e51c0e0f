//! Instructions per sample as a regression figure. Callgrind's counts do
//! not depend on the machine's load, so on a shared machine they show a
//! change of 1% where wall times move by ±25%. Each peer scene is counted
//! with both backends by `tools/instructions_per_sample.sh` (64×64, one
//! thread, a 48-spp render minus a 16-spp one, so that loading is left
//! out), compared with `benches/baseline/instructions-default.json`, and
//! the run exits with status 1 when a count rose by more than the
//! threshold.
//!
//! ```text
//! cargo bench --bench instructions [-- [--threshold PCT] [--baseline NAME]
//!                                       [--save-baseline [--note TEXT]]]
//! ```
//!
//! `--threshold`: the allowed rise in percent (default 2); `--baseline`:
//! the baseline's name, `benches/baseline/instructions-NAME.json` (default
//! `default`), so that each compiler can keep its own. A figure the baseline
//! lacks fails the check too. Needs valgrind (`apt-get install valgrind`);
//! about five minutes on two cores. The bunny
//! needs the meshes (`$LUZ_ASSETS`, default `../shared/assets`), the Embree
//! figures a build with Embree: without them those figures are skipped and
//! named. The counts depend on the compiler and on the instruction sets
//! valgrind lets luz detect (AVX2, never AVX-512), not on the CPU's speed:
//! the baseline records rustc's version, and a run with another says so.
//! Under `cargo test` (no `--bench`) it checks that the default baseline
//! holds every figure and that the script's count line is read.

mod assets;
mod baselines;

use baselines::{baseline_path, command_output, read_json, write_json, Args, Provenance};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, ExitCode};

const USAGE: &str = "usage: cargo bench --bench instructions -- [--threshold PCT] \
                     [--baseline NAME] [--save-baseline [--note TEXT]]";

const SCENES: [&str; 3] = ["cornell-point", "cornell-area", "bunny"];
const BACKENDS: [&str; 2] = ["rust", "embree"];

#[derive(Debug, Deserialize, Serialize)]
struct Baseline {
    #[serde(flatten)]
    provenance: Provenance,
    rustc: String,
    /// Instructions per sample, by `SCENE/BACKEND`.
    figures: BTreeMap<String, u64>,
}

fn figure_ids() -> impl Iterator<Item = String> {
    SCENES.iter().flat_map(|scene| {
        BACKENDS
            .iter()
            .map(move |backend| format!("{scene}/{backend}"))
    })
}

/// The count in the script's last line, `SCENE BACKEND: N instructions per
/// sample`.
fn parse_count(output: &str) -> Option<u64> {
    output
        .lines()
        .last()?
        .strip_suffix(" instructions per sample")?
        .rsplit(": ")
        .next()?
        .parse()
        .ok()
}

/// Why a figure could not be measured here, if it cannot.
fn unavailable(scene: &str, backend: &str) -> Option<String> {
    let mesh = assets::assets().join("stanford/bunny/bun_zipper.ply");
    if scene == "bunny" && !mesh.is_file() {
        return Some(format!("{} is missing (set LUZ_ASSETS)", mesh.display()));
    }
    if backend == "embree" && !luz::accel::compiled_backends().contains(&"embree") {
        return Some("luz was built without Embree".into());
    }
    None
}

fn count(scene: &str, backend: &str) -> Result<u64, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let output = Command::new(root.join("tools/instructions_per_sample.sh"))
        .args([
            &format!("scenes/{scene}.toml"),
            backend,
            env!("CARGO_BIN_EXE_luz"),
        ])
        .current_dir(root)
        // Extra render arguments would change what is counted.
        .env_remove("LUZ_EXTRA_ARGS")
        .output()
        .map_err(|e| format!("tools/instructions_per_sample.sh: {e}"))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        return Err(format!(
            "tools/instructions_per_sample.sh {scene} {backend}: {}\n{}",
            output.status,
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    match parse_count(&stdout) {
        Some(0) | None => Err(format!(
            "tools/instructions_per_sample.sh {scene} {backend}: no count in `{}`",
            stdout.trim()
        )),
        Some(count) => Ok(count),
    }
}

/// The file of baseline `name`, apart from the regress bench's baselines.
fn instructions_baseline(name: &str) -> std::path::PathBuf {
    baseline_path(&format!("instructions-{name}"))
}

/// Checks, without counting, that the default baseline holds every figure,
/// that the script still prints its count in the line `parse_count` reads,
/// and that such a line is read.
fn check() -> Result<(), String> {
    let path = instructions_baseline("default");
    let baseline: Baseline = read_json(&path)?;
    let missing: Vec<String> = figure_ids()
        .filter(|id| !baseline.figures.contains_key(id))
        .collect();
    if !missing.is_empty() {
        return Err(format!(
            "{}: no figure for {}",
            path.display(),
            missing.join(", ")
        ));
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/instructions_per_sample.sh");
    let text =
        std::fs::read_to_string(&script).map_err(|e| format!("{}: {e}", script.display()))?;
    let last_echo = text
        .lines()
        .rfind(|l| l.starts_with("echo "))
        .unwrap_or_default();
    if !last_echo.ends_with(" instructions per sample\"") {
        return Err(format!(
            "{}: its last line no longer prints `N instructions per sample`",
            script.display()
        ));
    }
    let line = "scenes/bunny.toml embree: 4770 instructions per sample";
    if parse_count(line) != Some(4770) || parse_count("instructions per sample").is_some() {
        return Err(format!("the script's line `{line}` is misread"));
    }
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if !args.iter().any(|a| a == "--bench") {
        return match check() {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("instructions: {e}");
                ExitCode::FAILURE
            }
        };
    }
    let args = match Args::parse(&args, 2.0, "default") {
        Ok(args) => args,
        Err(e) => {
            eprintln!("instructions: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("instructions: {e}");
            ExitCode::from(2)
        }
    }
}

/// A count against its baseline's (`None`: no baseline; `Some(None)`: the
/// baseline lacks it): the baseline and ratio columns, and why the figure
/// fails the check, if it does.
fn compare(
    now: u64,
    then: Option<Option<u64>>,
    threshold: f64,
) -> (String, String, Option<String>) {
    let then = match then {
        None => return (String::new(), String::new(), None),
        Some(None) => {
            return (
                "none".into(),
                String::new(),
                Some("not in the baseline".into()),
            )
        }
        Some(Some(then)) => then,
    };
    let ratio = now as f64 / then as f64;
    let mut text = format!("{ratio:.3}");
    let mut regression = None;
    if ratio > 1.0 + threshold / 100.0 {
        regression = Some(format!("{now} against {then}"));
        text += " MORE";
    } else if ratio < 1.0 - threshold / 100.0 {
        // Not a failure, but the baseline no longer guards this figure.
        text += " fewer: refresh the baseline";
    }
    (then.to_string(), text, regression)
}

fn run(args: &Args) -> Result<ExitCode, String> {
    let path = instructions_baseline(&args.baseline);
    let rustc = command_output("rustc", &["--version"]);
    let baseline = if args.save {
        None
    } else {
        let b: Baseline =
            read_json(&path).map_err(|e| format!("{e}\n(record one with --save-baseline)"))?;
        if b.rustc != rustc {
            println!(
                "the baseline was counted with {}, this run with {rustc}",
                b.rustc
            );
        }
        Some(b)
    };
    if Command::new("valgrind").arg("--version").output().is_err() {
        return Err("valgrind is missing (apt-get install valgrind)".into());
    }
    let mut figures = BTreeMap::new();
    let mut regressions = Vec::new();
    println!(
        "{:<22} {:>12} {:>10} {:>12}",
        "figure", "instr/sample", "baseline", "ratio"
    );
    for id in figure_ids() {
        let (scene, backend) = id.split_once('/').expect("SCENE/BACKEND");
        if let Some(why) = unavailable(scene, backend) {
            println!("{id:<22} skipped: {why}");
            continue;
        }
        let now = count(scene, backend)?;
        figures.insert(id.clone(), now);
        let then = baseline.as_ref().map(|b| b.figures.get(&id).copied());
        let (then_text, ratio_text, regression) = compare(now, then, args.threshold);
        println!("{id:<22} {now:>12} {then_text:>10} {ratio_text:>12}");
        regressions.extend(regression.map(|why| format!("{id}: {why}")));
    }
    if args.save {
        let skipped: Vec<String> = figure_ids()
            .filter(|id| !figures.contains_key(id))
            .collect();
        if !skipped.is_empty() {
            return Err(format!(
                "a baseline needs every figure; skipped: {}",
                skipped.join(", ")
            ));
        }
        let baseline = Baseline {
            provenance: Provenance::here(args.note.clone()),
            rustc,
            figures,
        };
        write_json(&path, &baseline)?;
        println!("saved {}", path.display());
        return Ok(ExitCode::SUCCESS);
    }
    if regressions.is_empty() {
        println!("no count rose by more than {}%", args.threshold);
        Ok(ExitCode::SUCCESS)
    } else {
        println!(
            "{} counts rose by more than {}% or have no baseline:\n  {}",
            regressions.len(),
            args.threshold,
            regressions.join("\n  ")
        );
        Ok(ExitCode::FAILURE)
    }
}
