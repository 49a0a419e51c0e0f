//! `luz study` end to end on a tiny scene: the CSV's shape, errors that fall
//! with the sample count, efficiency from the measured numbers, plots, a
//! saved reference that gives the same errors when read back, and one-line
//! refusals of bad arguments. No timing is asserted.

mod common;

use common::{embree_compiled, luz, temp_dir};

use std::path::Path;

const SCENE: &str = r#"[camera]
eye = [0, 1, 3.5]
target = [0, 1, 0]
fov = 40
resolution = [16, 16]
[render]
max_depth = 4
russian_roulette = false
[materials.white]
kd = 0.7
[materials.red]
kd = [0.7, 0.1, 0.1]
[materials.light]
kd = 0
emission = 10
[[shapes]]
type = "quad"
corners = [[-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1]]
material = "white"
[[shapes]]
type = "quad"
corners = [[-1, 0, -1], [1, 0, -1], [1, 2, -1], [-1, 2, -1]]
material = "red"
[[shapes]]
type = "quad"
corners = [[-0.5, 1.9, -0.5], [0.5, 1.9, -0.5], [0.5, 1.9, 0.5], [-0.5, 1.9, 0.5]]
material = "light"
nee = true
[[shapes]]
type = "sphere"
center = [0, 0.5, 0]
radius = 0.5
material = "white"
"#;

const SPP: [u32; 6] = [1, 2, 4, 8, 16, 32];

#[derive(Debug)]
struct Row {
    setting: String,
    spp: u32,
    time_s: f64,
    rmse: f64,
    rel_mse: f64,
    estimated_rel_mse: f64,
    sampling: String,
    efficiency: f64,
}

/// Reads study.csv, checking its header and that every row has every column.
fn read_csv(path: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header, luz::study::CSV_COLUMNS);
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f.len(), header.len(), "{line}");
            let num = |name: &str| -> f64 { f[col(name)].parse().unwrap() };
            Row {
                setting: f[col("setting")].to_owned(),
                spp: f[col("spp")].parse().unwrap(),
                time_s: num("time_s"),
                rmse: num("rmse"),
                rel_mse: num("rel_mse"),
                estimated_rel_mse: num("estimated_rel_mse"),
                sampling: f[col("sampling")].to_owned(),
                efficiency: num("efficiency"),
            }
        })
        .collect()
}

/// Least-squares slope of ln(relMSE) against ln(spp): about -1 for an
/// unbiased estimator against an exact reference.
fn slope(rows: &[&Row]) -> f64 {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| ((r.spp as f64).ln(), r.rel_mse.ln()))
        .collect();
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    sxy / sxx
}

#[test]
fn a_study_measures_every_setting_and_writes_its_outputs() {
    let dir = temp_dir("sweep");
    let scene = dir.join("box.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join("out");
    let reference = dir.join("reference.exr");
    let spp = SPP.map(|s| s.to_string()).join(",");
    let args = [
        "study",
        scene.to_str().unwrap(),
        "--spp",
        &spp,
        "--vary",
        "nee",
        "--reference-spp",
        "1024",
        "--save-reference",
        reference.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let run = luz(&args);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("rendering one first (1024 spp"), "{stderr}");
    assert!(reference.is_file());

    let rows = read_csv(&out.join("study.csv"));
    let mut settings = vec![];
    for backend in ["rust", "embree"] {
        if backend == "rust" || embree_compiled() {
            settings.push(format!("{backend} / NEE on"));
            settings.push(format!("{backend} / NEE off"));
        }
    }
    assert_eq!(rows.len(), settings.len() * SPP.len());
    for setting in &settings {
        let series: Vec<&Row> = rows.iter().filter(|r| &r.setting == setting).collect();
        let counts: Vec<u32> = series.iter().map(|r| r.spp).collect();
        assert_eq!(counts, SPP, "{setting}");
        let s = slope(&series);
        assert!(s < -0.6, "{setting}: relMSE falls as spp^{s}");
        assert!(series[5].rmse < series[0].rmse, "{setting}");
    }
    for r in &rows {
        assert!(r.time_s > 0.0 && r.rel_mse > 0.0);
        let expected = 1.0 / (r.rel_mse * r.time_s);
        assert!(
            (r.efficiency - expected).abs() <= 1e-9 * expected,
            "{}: {} vs {expected}",
            r.setting,
            r.efficiency
        );
    }
    // NEE finds the small light far more often than hitting it does.
    let mean = |label: &str| -> f64 {
        let e: Vec<f64> = rows
            .iter()
            .filter(|r| r.setting == label)
            .map(|r| r.rel_mse)
            .collect();
        e.iter().sum::<f64>() / e.len() as f64
    };
    assert!(mean("rust / NEE on") < mean("rust / NEE off"));

    for stem in ["relmse", "rmse"] {
        let png = image::open(out.join(format!("{stem}.png")))
            .unwrap()
            .to_rgb8();
        assert_eq!(png.dimensions(), (900, 600));
        let first = png.get_pixel(0, 0);
        assert!(png.pixels().any(|p| p != first), "{stem}.png is blank");
        let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        assert!(svg.starts_with("<svg"), "{stem}.svg");
        for setting in &settings {
            assert!(svg.contains(setting.as_str()), "{stem}.svg lacks {setting}");
        }
    }
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    for setting in &settings {
        assert!(summary.contains(setting.as_str()), "{summary}");
    }

    // The saved reference, read back, judges the same images the same way.
    let again = dir.join("again");
    let run = luz(&[
        "study",
        scene.to_str().unwrap(),
        "--spp",
        &spp,
        "--vary",
        "nee",
        "--reference",
        reference.to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(run.stderr.is_empty());
    let rows_again = read_csv(&again.join("study.csv"));
    assert_eq!(rows_again.len(), rows.len());
    for (a, b) in rows.iter().zip(&rows_again) {
        assert_eq!((&a.setting, a.spp), (&b.setting, b.spp));
        assert_eq!((a.rmse, a.rel_mse), (b.rmse, b.rel_mse), "{}", a.setting);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_sampling_study_sets_uniform_against_adaptive_and_estimates_their_errors() {
    let dir = temp_dir("sampling");
    let scene = dir.join("box.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join("out");
    let run = luz(&[
        "study",
        scene.to_str().unwrap(),
        "--spp",
        "4,16,64",
        "--backends",
        "rust",
        "--vary",
        "sampling",
        "--sampler",
        "independent",
        "--resolution",
        "64x64",
        "--reference-spp",
        "4096",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let rows = read_csv(&out.join("study.csv"));
    let kinds: Vec<(&str, &str, u32)> = rows
        .iter()
        .map(|r| (r.setting.as_str(), r.sampling.as_str(), r.spp))
        .collect();
    assert_eq!(
        kinds,
        [
            ("rust / uniform", "uniform", 4),
            ("rust / uniform", "uniform", 16),
            ("rust / uniform", "uniform", 64),
            ("rust / adaptive", "adaptive", 4),
            ("rust / adaptive", "adaptive", 16),
            ("rust / adaptive", "adaptive", 64),
        ]
    );
    for r in &rows {
        // Over 8 seeds the estimated/actual ratio ranged 0.68–1.15 (mean
        // 0.97, spread 0.1), so a factor of two either way is a false alarm
        // rarer than once in 10^5 studies.
        let ratio = r.estimated_rel_mse / r.rel_mse;
        assert!(
            (0.5..2.0).contains(&ratio),
            "{} at {} spp: estimated relMSE {} against {}",
            r.setting,
            r.spp,
            r.estimated_rel_mse,
            r.rel_mse
        );
    }
    // At an equal budget of 64 spp, adaptive over uniform relMSE was
    // 0.57–0.68 over the same 8 seeds.
    assert!(rows[5].rel_mse < rows[2].rel_mse, "{rows:?}");
    assert!(rows[5].rel_mse < rows[3].rel_mse / 4.0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_arguments_get_one_line_and_status_2() {
    let dir = temp_dir("bad");
    let scene = dir.join("box.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let scene = scene.to_str().unwrap();
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    let missing = dir.join("missing.exr");
    let mut cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--spp", "0,4"], "--spp"),
        (vec!["--max-depths", "3,5"], "--vary max-depth"),
        (
            vec!["--vary", "max-depth", "--max-depths", "0"],
            "--max-depths",
        ),
        (vec!["--target-rel-mse", "0"], "--target-rel-mse"),
        (
            vec!["--reference", missing.to_str().unwrap()],
            "missing.exr",
        ),
        (
            vec!["--backends", "rust", "--vary", "embree-quality"],
            "Embree",
        ),
    ];
    if !embree_compiled() {
        cases.push((vec!["--backends", "embree"], "not compiled"));
    }
    for (extra, needle) in cases {
        let mut args = vec!["study", scene, "--out", out];
        args.extend(&extra);
        let run = luz(&args);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{extra:?}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{extra:?}: {stderr}");
        assert!(stderr.contains(needle), "{extra:?}: {stderr}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
