//! Renders split into sample ranges, merged, checkpointed, interrupted and
//! resumed, through the `luz` binary: every way of cutting a render up must
//! give the image of the straight run.

mod common;

use common::temp_dir;

use luz::distributed::part::{self, Part};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::luz_command as luz;

fn run(args: &[&str]) -> Output {
    luz().args(args).output().expect("the luz binary runs")
}

fn scene() -> String {
    format!("{}/scenes/cornell-area.toml", env!("CARGO_MANIFEST_DIR"))
}

/// Renders the test scene at 24x24 with `extra` arguments into `out`.
fn render(out: &Path, spp: u32, extra: &[&str]) -> Output {
    let spp = spp.to_string();
    let mut args = vec![
        "render",
        &scene(),
        "--resolution",
        "24x24",
        "--spp",
        &spp,
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]
    .into_iter()
    .map(String::from)
    .collect::<Vec<_>>();
    args.extend(extra.iter().map(|s| s.to_string()));
    luz().args(&args).output().expect("the luz binary runs")
}

fn ok(out: Output) -> Output {
    assert!(
        out.status.success(),
        "luz failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn read(path: &Path) -> Part {
    part::read(path).unwrap_or_else(|e| panic!("{e}"))
}

/// A failure with exit status 2 and one line naming `needle`, leaving no
/// file at `output`.
fn assert_input_error(out: &Output, needle: &str, output: &Path) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(needle), "expected {needle:?} in {stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(!output.exists(), "{} must not be written", output.display());
}

#[test]
fn merged_tasks_equal_the_single_run() {
    for sampler in ["independent", "sobol"] {
        merged_tasks_equal_the_single_run_with(sampler);
    }
}

fn merged_tasks_equal_the_single_run_with(sampler: &str) {
    let dir = temp_dir(&format!("merge-{sampler}"));
    let full = dir.join("full.exr");
    ok(render(&full, 10, &["--sampler", sampler]));
    // Three tasks of 10 samples: shares of 3, 3 and 4, merged in any order.
    let parts: Vec<PathBuf> = (0..3).map(|i| dir.join(format!("part{i}.exr"))).collect();
    for (i, p) in parts.iter().enumerate() {
        let index = i.to_string();
        let task = ["--task-index", &index, "--task-count", "3"];
        ok(render(
            p,
            10,
            &[&task[..], &["--sampler", sampler]].concat(),
        ));
    }
    assert_eq!(read(&parts[2]).meta.ranges, vec![6..10]);
    let merged = dir.join("merged.exr");
    let mut args = vec!["merge", "--quiet", "-o", merged.to_str().unwrap()];
    args.extend(parts.iter().rev().map(|p| p.to_str().unwrap()));
    ok(run(&args));

    let (a, b) = (read(&merged), read(&full));
    assert_eq!(a.meta, b.meta);
    // Sums of sums differ from one running sum only by f64 rounding, which
    // f32 rounding of the mean hides but for the rare value next to a tie.
    let (ia, ib) = (a.film.image(), b.film.image());
    for (pa, pb) in ia.pixels.iter().zip(&ib.pixels) {
        for c in 0..3 {
            let tolerance = pb[c].abs() * f32::EPSILON;
            assert!(
                (pa[c] - pb[c]).abs() <= tolerance,
                "{sampler}: {pa} vs {pb}"
            );
        }
    }
    assert!(ib.mean().x > 0.01, "the test scene is not black");
}

#[test]
fn merge_refuses_foreign_overlapping_missing_and_corrupt_parts() {
    let dir = temp_dir("refuse");
    let out = dir.join("out.exr");
    let p = |name: &str| dir.join(name);
    ok(render(&p("a.exr"), 8, &["--samples", "0..4"]));
    ok(render(&p("b.exr"), 8, &["--samples", "4..8"]));
    ok(render(&p("overlap.exr"), 8, &["--samples", "3..6"]));
    ok(render(
        &p("seed.exr"),
        8,
        &["--samples", "4..8", "--seed", "9"],
    ));
    ok(render(
        &p("depth.exr"),
        8,
        &["--samples", "4..8", "--max-depth", "2"],
    ));
    // a.exr has the default sampler; the other is another render.
    let other = match luz::sampling::SamplerKind::default() {
        luz::sampling::SamplerKind::Sobol => "independent",
        luz::sampling::SamplerKind::Independent => "sobol",
    };
    ok(render(
        &p("sampler.exr"),
        8,
        &["--samples", "4..8", "--sampler", other],
    ));
    let merge = |parts: &[&str], extra: &[&str]| {
        let mut args = vec!["merge", "-o", out.to_str().unwrap()];
        args.extend(extra);
        let paths: Vec<String> = parts.iter().map(|n| p(n).display().to_string()).collect();
        args.extend(paths.iter().map(String::as_str));
        run(&args)
    };

    assert_input_error(&merge(&["a.exr", "seed.exr"], &[]), "seed 9 differs", &out);
    assert_input_error(&merge(&["a.exr", "depth.exr"], &[]), "luz:sceneHash", &out);
    assert_input_error(
        &merge(&["a.exr", "sampler.exr"], &[]),
        "luz:sceneHash",
        &out,
    );
    assert_input_error(
        &merge(&["a.exr", "overlap.exr"], &[]),
        "both hold samples 3..4",
        &out,
    );
    assert_input_error(
        &merge(&["b.exr"], &[]),
        "samples 0..4 of 8 per pixel are in no part",
        &out,
    );

    // A plain EXR is not a part; a truncated part is caught.
    let plain = p("plain.exr");
    ok(run(&[
        "tonemap",
        p("a.exr").to_str().unwrap(),
        plain.to_str().unwrap(),
    ]));
    assert_input_error(
        &merge(&["a.exr", "plain.exr"], &[]),
        "luz:version: missing",
        &out,
    );
    // A part cut short in its pixels is caught by its header's size before
    // any pixel is read; one cut in its header is no EXR at all.
    let bytes = std::fs::read(p("b.exr")).unwrap();
    std::fs::write(p("cut.exr"), &bytes[..bytes.len() / 2]).unwrap();
    assert_input_error(
        &merge(&["a.exr", "cut.exr"], &[]),
        "cut.exr: dataWindow: 24x24 pixels of 72 bytes need at least",
        &out,
    );
    std::fs::write(p("cut-header.exr"), &bytes[..100]).unwrap();
    assert_input_error(
        &merge(&["a.exr", "cut-header.exr"], &[]),
        "cut-header.exr: file:",
        &out,
    );

    // With --allow-gaps the merge goes through and says what is missing.
    let gaps = merge(&["b.exr"], &["--allow-gaps", "--quiet"]);
    let stderr = String::from_utf8_lossy(&gaps.stderr);
    assert!(gaps.status.success(), "{stderr}");
    assert!(
        stderr.contains("samples 0..4 of 8 per pixel are in no part"),
        "{stderr}"
    );
    assert_eq!(read(&out).meta.ranges, vec![4..8]);
}

#[test]
fn bad_ranges_and_tasks_are_input_errors() {
    let dir = temp_dir("args");
    let exr = dir.join("x.exr");
    let png = dir.join("x.png");
    let out = render(&exr, 8, &["--task-index", "4", "--task-count", "4"]);
    assert_input_error(&out, "task index 4 is not below the task count 4", &exr);
    let out = render(&png, 8, &["--samples", "0..4"]);
    assert_input_error(&out, "must be written to .exr", &png);
    let out = render(&exr, 8, &["--samples", "4..2"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("sample range 4..2 is empty"));
    assert!(!exr.exists());
    let out = render(&exr, 8, &["--checkpoint-every", "5 minutes"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected a duration such as"));
    assert!(!exr.exists());

    // The task index may come from Slurm or Kubernetes.
    let out = luz()
        .args([
            "render",
            &scene(),
            "--resolution",
            "8x8",
            "--spp",
            "8",
            "--quiet",
        ])
        .args(["-o", exr.to_str().unwrap()])
        .env("SLURM_ARRAY_TASK_ID", "3")
        .env("SLURM_ARRAY_TASK_MIN", "2")
        .env("SLURM_ARRAY_TASK_COUNT", "4")
        .output()
        .unwrap();
    ok(out);
    assert_eq!(read(&exr).meta.ranges, vec![2..4]);
    let out = luz()
        .args(["render", &scene(), "--spp", "8", "--quiet", "-o"])
        .arg(&png)
        .env("JOB_COMPLETION_INDEX", "1")
        .output()
        .unwrap();
    assert_input_error(&out, "pass --task-count", &png);
}

/// The checkpoint tests' sampler, named so that they hold whatever the
/// default: resuming must be exact for Sobol' points too.
const CHECKPOINT_SAMPLER: [&str; 2] = ["--sampler", "sobol"];

/// Starts a long render that checkpoints often, and waits for its first
/// checkpoint.
fn start_checkpointing(dir: &Path, spp: u32) -> (Child, PathBuf, PathBuf) {
    let out = dir.join("out.exr");
    let checkpoint = dir.join("out.checkpoint.exr");
    let child = luz()
        .args(["render", &scene(), "--resolution", "24x24", "--quiet"])
        .args(["--spp", &spp.to_string(), "--checkpoint-every", "20ms"])
        .args(CHECKPOINT_SAMPLER)
        .arg("-o")
        .arg(&out)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(120);
    while !checkpoint.exists() {
        assert!(Instant::now() < deadline, "no checkpoint appeared");
        std::thread::sleep(Duration::from_millis(5));
    }
    (child, out, checkpoint)
}

const LONG_SPP: u32 = 3000;

fn straight_run(dir: &Path) -> Part {
    let out = dir.join("straight.exr");
    let args = [&["--checkpoint-every", "off"][..], &CHECKPOINT_SAMPLER].concat();
    ok(render(&out, LONG_SPP, &args));
    read(&out)
}

#[test]
fn a_killed_render_resumes_to_the_straight_run_bit_for_bit() {
    let dir = temp_dir("kill");
    let (mut child, out, checkpoint) = start_checkpointing(&dir, LONG_SPP);
    child.kill().unwrap();
    child.wait().unwrap();
    let saved = read(&checkpoint).meta.sample_count();
    assert!(
        saved > 0 && saved < LONG_SPP as u64,
        "checkpoint holds {saved}"
    );
    assert!(!out.exists());

    let cp = checkpoint.to_str().unwrap();
    ok(render(
        &out,
        LONG_SPP,
        &[&["--resume", cp][..], &CHECKPOINT_SAMPLER].concat(),
    ));
    assert_eq!(read(&out), straight_run(&dir));
    assert!(
        !checkpoint.exists(),
        "a finished render removes its checkpoint"
    );
}

#[test]
fn sigint_saves_a_checkpoint_and_says_how_to_resume() {
    let dir = temp_dir("sigint");
    let (child, out, checkpoint) = start_checkpointing(&dir, LONG_SPP);
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let done = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert_eq!(done.status.code(), Some(130), "{stderr}");
    let partial = read(&out);
    assert_eq!(partial, read(&checkpoint));
    assert!(partial.film.samples < LONG_SPP as u64);

    let command = stderr
        .split("resume with: ")
        .nth(1)
        .unwrap_or_else(|| panic!("no resume command in {stderr}"));
    ok(Command::new("sh")
        .args(["-c", command.trim()])
        .output()
        .unwrap());
    assert_eq!(read(&out), straight_run(&dir));
}

#[test]
fn a_checkpoint_of_another_render_is_refused() {
    let dir = temp_dir("foreign");
    let seeded = dir.join("seeded.exr");
    ok(render(&seeded, 4, &["--seed", "5", "--samples", "0..2"]));
    let out = dir.join("out.exr");
    let args = ["--resume", seeded.to_str().unwrap()];
    assert_input_error(&render(&out, 4, &args), "luz:seed", &out);
    let small = dir.join("small.exr");
    ok(luz()
        .args(["render", &scene(), "--resolution", "8x8", "--spp", "4"])
        .args(["--samples", "0..2", "--quiet", "-o"])
        .arg(&small)
        .output()
        .unwrap());
    let args = ["--resume", small.to_str().unwrap()];
    assert_input_error(
        &render(&out, 4, &args),
        "dataWindow: the checkpoint has 8x8, this render 24x24",
        &out,
    );
    let other = dir.join("other.exr");
    ok(render(&other, 4, &["--samples", "1..2"]));
    let args = ["--resume", other.to_str().unwrap()];
    assert_input_error(&render(&out, 4, &args), "luz:samples", &out);
    std::fs::write(&other, b"v/1\x01 not really").unwrap();
    assert_input_error(&render(&out, 4, &args), "other.exr: file:", &out);
}
