//! The scale benchmark: the bunny scene with its mesh replaced by flat
//! midpoint subdivisions of itself (69k, 278k, 1.1M, 4.4M and 17.8M
//! triangles), rendered whole-process by the `luz` binary with each backend
//! and, when Mitsuba 3 is installed, by `tools/mitsuba_peer.py`, back to
//! back. Prints one table row per level and tool: wall time, the load and
//! build times of luz's summary, and peak RSS.
//!
//! ```text
//! cargo bench --bench scale -- [--levels 0..=4]
//!     [--resolution 256] [--spp 16] [--threads 2] [--no-mitsuba]
//! ```
//!
//! The meshes are written once into `target/scale/` (338 MB for level 4),
//! and each is read through once before its level's runs, so that every
//! tool finds it in the file cache; a `PLY read` row then times luz's
//! reader alone on it, in this process.
//! Every level must render the image of level 0: each level's image is
//! compared with level 0's of the same backend by a z-test on 8×8-pixel
//! blocks (|z| ≤ 4.5 for every block and channel; with the pooled sample
//! variance, which also holds the spread between a block's pixels, the test
//! is conservative: under 1e-3 false alarms in a 64×64 run), and the run
//! fails when one differs. Under `cargo test` (no `--bench`) it renders
//! levels 0 and 1 at 64×64, 16 spp.

mod assets;
#[path = "scale/subdivide.rs"]
mod subdivide;

use assets::assets;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::Instant;

struct Options {
    levels: std::ops::RangeInclusive<u32>,
    resolution: u32,
    spp: u32,
    threads: u32,
    mitsuba: bool,
    /// Only write the meshes (the child process `main` starts).
    generate: bool,
}

fn parse_options() -> Result<Options, String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let benching = args.iter().any(|a| a == "--bench");
    let mut o = if benching {
        Options {
            levels: 0..=4,
            resolution: 256,
            spp: 16,
            threads: 2,
            mitsuba: true,
            generate: false,
        }
    } else {
        Options {
            levels: 0..=1,
            resolution: 64,
            spp: 16,
            threads: 2,
            mitsuba: false,
            generate: false,
        }
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{name} needs a value"))
        };
        match a.as_str() {
            "--bench" => {}
            "--levels" => {
                let v = value("--levels")?;
                let (a, b) = v
                    .split_once("..=")
                    .ok_or("--levels: expected A..=B such as 0..=4")?;
                let parse = |s: &str| s.parse::<u32>().map_err(|_| format!("--levels: `{v}`"));
                o.levels = parse(a)?..=parse(b)?;
            }
            "--resolution" => o.resolution = number(&value("--resolution")?, "--resolution")?,
            "--spp" => o.spp = number(&value("--spp")?, "--spp")?,
            "--threads" => o.threads = number(&value("--threads")?, "--threads")?,
            "--no-mitsuba" => o.mitsuba = false,
            "--generate" => o.generate = true,
            other => return Err(format!("unknown argument `{other}`")),
        }
    }
    Ok(o)
}

fn number(s: &str, flag: &str) -> Result<u32, String> {
    s.parse()
        .map_err(|_| format!("{flag}: expected a positive integer, found `{s}`"))
}

/// Writes the meshes of `levels` that are not there yet.
fn meshes(dir: &Path, bunny: &Path, levels: &std::ops::RangeInclusive<u32>) {
    std::fs::create_dir_all(dir).expect("create target/scale");
    let path = |l: u32| dir.join(format!("bunny-level{l}.ply"));
    if levels.clone().all(|l| path(l).exists()) {
        return;
    }
    let mut mesh = luz::scene::mesh_io::load_mesh(bunny).expect("load the bunny");
    for level in 0..=*levels.end() {
        let path = path(level);
        if levels.contains(&level) && !path.exists() {
            let tmp = path.with_extension("ply.tmp");
            subdivide::write_ply(&mesh, &tmp).expect("write a level");
            std::fs::rename(&tmp, &path).expect("rename a level");
            eprintln!(
                "scale: wrote {} ({} triangles)",
                path.display(),
                mesh.indices.len()
            );
        }
        if level < *levels.end() {
            mesh = subdivide::subdivide(&mesh);
        }
    }
}

/// The bunny scene of `scenes/bunny.toml` with `mesh` as its mesh.
fn scene_for(mesh: &Path, o: &Options) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("scenes/bunny.toml")).expect("read bunny.toml");
    let text = text.replace(
        "$LUZ_ASSETS/stanford/bunny/bun_zipper.ply",
        &mesh.display().to_string(),
    );
    let text = text.replace(
        "resolution = [512, 512]",
        &format!("resolution = [{0}, {0}]", o.resolution),
    );
    text.replace("spp = 64", &format!("spp = {}", o.spp))
}

struct Run {
    wall: f64,
    peak_rss_mb: f64,
    stderr: String,
}

/// Runs `cmd` to completion; its wall time and peak RSS (from `wait4`).
fn measure(mut cmd: Command) -> Result<Run, String> {
    let start = Instant::now();
    let child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("{cmd:?}: {e}"))?;
    let pid = child.id() as libc::pid_t;
    let mut stderr = child.stderr.expect("piped stderr");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut s).ok();
        s
    });
    let mut status = 0;
    // SAFETY: zeroed rusage is a valid value; wait4 fills it for our child.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    let wall = start.elapsed().as_secs_f64();
    let stderr = reader.join().unwrap_or_default();
    if r != pid || !libc::WIFEXITED(status) || libc::WEXITSTATUS(status) != 0 {
        return Err(format!("{cmd:?} failed: {stderr}"));
    }
    Ok(Run {
        wall,
        peak_rss_mb: usage.ru_maxrss as f64 / 1024.0,
        stderr,
    })
}

/// Whether the renders `a` and `b` estimate the same image: the largest
/// |z| over 8×8 blocks and channels, or why they differ.
fn same_image(a: &Path, b: &Path) -> Result<f64, String> {
    const BLOCK: u32 = 8;
    const LIMIT: f64 = 4.5;
    let read = |p: &Path| luz::distributed::part::read(p).map_err(|e| e.to_string());
    let (a, b) = (read(a)?.film, read(b)?.film);
    if (a.width, a.height) != (b.width, b.height) {
        return Err("the images differ in size".into());
    }
    let mut worst = 0.0f64;
    for by in 0..a.height.div_ceil(BLOCK) {
        for bx in 0..a.width.div_ceil(BLOCK) {
            for c in 0..3 {
                let (ma, va) = block_mean_var(&a, bx * BLOCK, by * BLOCK, BLOCK, c);
                let (mb, vb) = block_mean_var(&b, bx * BLOCK, by * BLOCK, BLOCK, c);
                let se = (va + vb).sqrt();
                let z = if se > 0.0 {
                    (ma - mb).abs() / se
                } else if ma == mb {
                    0.0
                } else {
                    f64::INFINITY
                };
                if z > LIMIT {
                    return Err(format!(
                        "block ({bx}, {by}) channel {c}: means {ma:.4} and {mb:.4}, z = {z:.1}"
                    ));
                }
                worst = worst.max(z);
            }
        }
    }
    Ok(worst)
}

/// Mean of a block's samples and its variance (of the mean).
fn block_mean_var(
    film: &luz::render::film::Film,
    x0: u32,
    y0: u32,
    size: u32,
    c: usize,
) -> (f64, f64) {
    let (mut sum, mut sum_sq, mut n) = (0.0, 0.0, 0.0);
    for y in y0..(y0 + size).min(film.height) {
        for x in x0..(x0 + size).min(film.width) {
            let i = (y * film.width + x) as usize;
            sum += film.sum[i][c];
            sum_sq += film.sum_sq[i][c];
            n += film.samples as f64;
        }
    }
    let mean = sum / n;
    let var = (sum_sq / n - mean * mean).max(0.0) / n;
    (mean, var)
}

/// The stage times of luz's summary line, as printed.
fn stages(stderr: &str) -> String {
    stderr
        .lines()
        .rfind(|l| l.contains("backend"))
        .and_then(|l| Some(l[l.find('(')? + 1..l.find(')')?].to_string()))
        .unwrap_or_default()
}

fn main() -> ExitCode {
    let o = match parse_options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("scale: {e}");
            return ExitCode::from(2);
        }
    };
    let bunny = assets().join("stanford/bunny/bun_zipper.ply");
    if !bunny.exists() {
        eprintln!(
            "scale: skipped, {} is missing (set LUZ_ASSETS)",
            bunny.display()
        );
        return ExitCode::SUCCESS;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target"));
    let dir = target.join("scale");
    // The binary cargo built with this bench: release under `cargo bench`.
    let luz = Path::new(env!("CARGO_BIN_EXE_luz"));
    if o.generate {
        meshes(&dir, &bunny, &o.levels);
        return ExitCode::SUCCESS;
    }
    // The meshes are made in a child process: a child's peak RSS counts
    // its parent's at fork, so this process must stay small.
    let made = Command::new(std::env::current_exe().expect("own path"))
        .arg("--generate")
        .args([
            "--levels",
            &format!("{}..={}", o.levels.start(), o.levels.end()),
        ])
        .status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("scale: making the meshes failed");
        return ExitCode::FAILURE;
    }
    let mut failed = false;
    let image = |level: u32, backend: &str| dir.join(format!("level{level}-{backend}.exr"));
    println!("| level | triangles | tool | wall s | stages | peak RSS MB |");
    println!("|---|---|---|---|---|---|");
    for level in o.levels.clone() {
        let mesh = dir.join(format!("bunny-level{level}.ply"));
        let triangles = 69_451u64 << (2 * level);
        let scene = dir.join(format!("bunny-level{level}.toml"));
        std::fs::write(&scene, scene_for(&mesh, &o)).expect("write the scene");
        // Every tool starts with the mesh in the file cache (otherwise the
        // first one alone pays for reading it from the disk); then this
        // process reads the PLY once more, timed: a row of its own.
        match ply_read(&mesh, o.threads as usize) {
            Ok((secs, bytes)) => println!(
                "| {level} | {triangles} | PLY read | {secs:.3} | {:.1} MB, {:.2} GB/s | - |",
                bytes / 1e6,
                bytes / secs / 1e9
            ),
            Err(e) => {
                eprintln!("scale: reading {}: {e}", mesh.display());
                return ExitCode::FAILURE;
            }
        }
        let mut tools: Vec<(&str, Command)> = Vec::new();
        for backend in ["rust", "embree"] {
            let mut cmd = Command::new(luz);
            cmd.arg("render").arg(&scene).args(["--backend", backend]);
            cmd.args(["--threads", &o.threads.to_string()]);
            cmd.arg("-o")
                .arg(dir.join(format!("level{level}-{backend}.exr")));
            tools.push((backend, cmd));
        }
        if o.mitsuba {
            let mut cmd = Command::new("python3");
            cmd.arg(root.join("tools/mitsuba_peer.py")).arg("bunny");
            cmd.arg("--mesh").arg(&mesh).arg("--whole");
            cmd.args(["--resolution", &o.resolution.to_string()]);
            cmd.args(["--spp", &o.spp.to_string()]);
            cmd.args(["--threads", &o.threads.to_string()]);
            tools.push(("mitsuba", cmd));
        }
        for (name, cmd) in tools {
            match measure(cmd) {
                Ok(run) => println!(
                    "| {level} | {triangles} | {name} | {:.2} | {} | {:.0} |",
                    run.wall,
                    stages(&run.stderr),
                    run.peak_rss_mb
                ),
                Err(e) if name == "embree" && e.contains("not compiled") => {
                    println!("| {level} | {triangles} | embree | - | not compiled in | - |")
                }
                Err(e) => {
                    eprintln!("scale: {e}");
                    failed = true;
                }
            }
        }
        for backend in ["rust", "embree"] {
            let (a, b) = (image(level, backend), image(*o.levels.start(), backend));
            if level == *o.levels.start() || !a.exists() {
                continue;
            }
            match same_image(&a, &b) {
                Ok(z) => eprintln!(
                    "scale: level {level} = level {}, {backend}: largest |z| {z:.2}",
                    o.levels.start()
                ),
                Err(e) => {
                    eprintln!("scale: {backend}, level {level}: {e}");
                    failed = true;
                }
            }
        }
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// Reads `path` through once, so that it is in the file cache; then loads
/// it as a mesh on `threads` threads (`luz`'s reader alone: no placing, no
/// tree). Returns the load's seconds and the file's bytes.
fn ply_read(path: &Path, threads: usize) -> Result<(f64, f64), String> {
    let mut file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let bytes = std::io::copy(&mut file, &mut std::io::sink()).map_err(|e| e.to_string())?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;
    let start = Instant::now();
    let mesh = pool
        .install(|| luz::scene::mesh_io::load_mesh(path))
        .map_err(|e| e.to_string())?;
    let secs = start.elapsed().as_secs_f64();
    drop(mesh);
    Ok((secs, bytes as f64))
}
