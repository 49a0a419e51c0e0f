//! Mitsuba XML import: each feature on a small inline scene (the scene
//! structure in `structure`, materials and lights in `materials`), and the
//! shared Bitterli scenes (skipped when `LUZ_MITSUBA_SCENES` is absent)
//! with the Cornell box's brightness against Mitsuba 3's own render.

#[path = "../common/mod.rs"]
mod common;

use common::{luz, temp_dir};
use luz::accel::{BackendKind, BuildOptions};
use luz::geometry::Geometry;
use luz::math::Vec3;
use luz::render::{build_accel, render_with, RenderOptions};
use luz::scene::{load_with, LoadOptions, Opacity, Scene, SceneError};
use std::path::{Path, PathBuf};
use std::sync::Arc;

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
  <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
  <rfilter type="box"/></film></sensor>"#;

/// Writes `files` (name, text) into a fresh folder and loads the first.
fn load(test: &str, files: &[(&str, &str)], options: &LoadOptions) -> Result<Scene, SceneError> {
    let dir = temp_dir(test);
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    load_with(&dir.join(files[0].0), options)
}

/// A light, so that scenes meant to load without warnings earn none for
/// rendering black.
const LIGHT: &str = r#"<emitter type="point"><point name="position" value="0,0,3"/></emitter>"#;

fn scene(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>\n")
}

fn ok(test: &str, body: &str) -> Scene {
    load(test, &[("s.xml", &scene(body))], &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{test}: {e}"))
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-4
}

fn ok_err(test: &str, body: &str) -> String {
    load(test, &[("s.xml", &scene(body))], &LoadOptions::default())
        .unwrap_err()
        .to_string()
}

fn image(scene: &Scene, spp: u32) -> luz::image::Image {
    let scene = Arc::new(scene.clone());
    let accel = build_accel(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
    let mut options = RenderOptions::from_scene(&scene);
    options.samples = 0..spp;
    render_with(&scene, &accel, &options, &()).0.image()
}

fn mean(scene: &Scene, spp: u32) -> [f64; 3] {
    let scene = Arc::new(scene.clone());
    let accel = build_accel(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
    let mut options = RenderOptions::from_scene(&scene);
    options.samples = 0..spp;
    let (film, _) = render_with(&scene, &accel, &options, &());
    let img = film.image();
    let n = img.pixels.len() as f64;
    let mut sum = [0.0; 3];
    for p in &img.pixels {
        for c in 0..3 {
            sum[c] += p[c] as f64 / n;
        }
    }
    sum
}

mod materials;
mod shared;
mod structure;
