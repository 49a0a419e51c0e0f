//! What the benches that keep a baseline share: the baseline's file, where
//! and from what its figures were measured, and the arguments that pick,
//! compare with or refresh it.

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;

/// `[--threshold PCT] [--baseline NAME] [--save-baseline [--note TEXT]]`,
/// and the `--bench` that cargo adds.
pub struct Args {
    /// The change allowed, in percent.
    pub threshold: f64,
    /// The baseline's name; each bench maps it to its file under
    /// `benches/baseline/`.
    pub baseline: String,
    /// Write this run's figures as the baseline instead of comparing.
    pub save: bool,
    /// What else ran meanwhile, kept with a saved baseline.
    pub note: String,
}

impl Args {
    pub fn parse(
        args: &[String],
        default_threshold: f64,
        default_baseline: &str,
    ) -> Result<Self, String> {
        let mut parsed = Self {
            threshold: default_threshold,
            baseline: default_baseline.into(),
            save: false,
            note: String::new(),
        };
        let mut it = args.iter();
        while let Some(arg) = it.next() {
            let mut value = || it.next().ok_or(format!("{arg} needs a value"));
            match arg.as_str() {
                "--bench" => {}
                "--threshold" => {
                    let v = value()?;
                    parsed.threshold = v
                        .parse()
                        .ok()
                        .filter(|t: &f64| t.is_finite() && *t >= 0.0)
                        .ok_or(format!("--threshold: expected a percentage, got `{v}`"))?;
                }
                "--baseline" => parsed.baseline = value()?.clone(),
                "--note" => parsed.note = value()?.clone(),
                "--save-baseline" => parsed.save = true,
                _ => return Err(format!("unknown argument `{arg}`")),
            }
        }
        Ok(parsed)
    }
}

/// The machine, the date and the commit behind a baseline's figures.
#[derive(Debug, Deserialize, Serialize)]
pub struct Provenance {
    pub machine: String,
    pub cpu: String,
    pub date: String,
    pub luz_commit: String,
    /// What else ran meanwhile, or anything a reader should know.
    pub note: String,
}

impl Provenance {
    /// This machine, now, at the working tree's commit.
    pub fn here(note: String) -> Self {
        Self {
            machine: hostname(),
            cpu: cpu_model(),
            date: command_output("date", &["-u", "+%Y-%m-%dT%H:%M:%SZ"]),
            luz_commit: command_output("git", &["describe", "--always", "--dirty", "--abbrev=12"]),
            note,
        }
    }
}

/// `benches/baseline/NAME.json`.
pub fn baseline_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("benches/baseline")
        .join(format!("{name}.json"))
}

/// A JSON file, with its path in any error.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Writes `value` as pretty JSON, creating its directory.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), String> {
    let json = serde_json::to_string_pretty(value).expect("serialisable");
    std::fs::create_dir_all(path.parent().expect("a file in a directory"))
        .and_then(|()| std::fs::write(path, json + "\n"))
        .map_err(|e| format!("{}: {e}", path.display()))
}

fn hostname() -> String {
    std::fs::read_to_string("/etc/hostname")
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| "unknown".into())
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| {
            info.lines()
                .find_map(|l| l.strip_prefix("model name"))
                .map(|rest| rest.trim_start_matches([' ', '\t', ':']).to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

/// A command's trimmed standard output, run in the crate's directory, or
/// `unknown` when it fails.
pub fn command_output(program: &str, args: &[&str]) -> String {
    Command::new(program)
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into())
}
