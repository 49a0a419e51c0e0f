//! The two backends agree pixel by pixel: every scene in `scenes/`, rendered
//! by both at low resolution with the same seed, gives images whose pixels
//! are equal within 1e-4 relative for at least 99.9% of them; the rest (a
//! path that grazed an edge one backend saw and the other did not) must lie
//! within the noise bound of the two estimates.

mod common;

use common::embree_compiled;

use luz::accel::{BackendKind, BuildOptions};
use luz::image::metrics;
use luz::render::{build_accel, render_with, RenderOptions};
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn assets_present() -> bool {
    let dir = std::env::var_os("LUZ_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/assets"));
    dir.join("stanford/bunny/bun_zipper.ply").is_file()
}

#[test]
fn every_scene_agrees_across_backends() {
    if !embree_compiled() {
        assert!(
            std::env::var_os("LUZ_REQUIRE_EMBREE").is_none(),
            "LUZ_REQUIRE_EMBREE is set but Embree is not compiled in"
        );
        eprintln!("skipped: Embree is not compiled into this build");
        return;
    }
    std::env::set_current_dir(env!("CARGO_MANIFEST_DIR")).unwrap();
    let mut scenes: Vec<PathBuf> = std::fs::read_dir("scenes")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 10);
    let mut checked = 0;
    for path in &scenes {
        let text = std::fs::read_to_string(path).unwrap();
        if text.contains("$LUZ_ASSETS") && !assets_present() {
            eprintln!("skipped {}: $LUZ_ASSETS not present", path.display());
            continue;
        }
        let mut scene = luz::scene::load(path).unwrap();
        scene.camera.width = 48;
        scene.camera.height = 48;
        scene.render.spp = 4;
        let scene = Arc::new(scene);
        let options = RenderOptions::from_scene(&scene);
        let render = |kind| {
            let accel = build_accel(&scene, kind, &BuildOptions::default()).unwrap();
            render_with(&scene, &accel, &options, &()).0
        };
        let native = render(BackendKind::Rust);
        let embree = render(BackendKind::Embree);
        let (a, b) = (native.image(), embree.image());
        let close = metrics::compare(&a, &b, 0.0, 1e-4).unwrap();
        let (va, vb) = (native.variance_of_mean(), embree.variance_of_mean());
        let mut outside_noise = 0;
        for i in 0..a.pixels.len() {
            for c in 0..3 {
                let d = (a.pixels[i][c] - b.pixels[i][c]).abs() as f64;
                let sigma = ((va.pixels[i][c] + vb.pixels[i][c]) as f64).sqrt();
                // 6 sigma: under 2e-9 false alarms per value if Gaussian; a
                // floor for pixels whose estimates have no variance.
                if d > 6.0 * sigma + 1e-4 * (a.pixels[i][c].abs() as f64).max(1e-3) {
                    outside_noise += 1;
                }
            }
        }
        println!(
            "{}: {:.4}% of pixels within 1e-4 relative, {} values outside the noise bound",
            path.display(),
            100.0 * close.fraction_within,
            outside_noise
        );
        assert!(
            close.fraction_within >= 0.999,
            "{}: only {:.4}% of pixels agree\n{close}",
            path.display(),
            100.0 * close.fraction_within
        );
        assert_eq!(outside_noise, 0, "{}", path.display());
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} scenes checked");
}
