//! Numerical extremes, on every compiled backend (Embree with `embree_robust`
//! off and on): re-intersection of spheres from 1e-4 to 1e6, a scene far
//! from the origin, grazing rays, degenerate and sliver triangles, a closed
//! mesh probed from inside, renders at extreme settings and a 4096×4096
//! film, and non-finite samples kept out of written images. Every check
//! prints one row of a table:
//!
//! `extreme | backend | rays | self-hits | missed exits | escapes | non-finite`

#[path = "../common/mod.rs"]
mod common;
mod rays;
mod renders;

use common::embree_compiled;

use luz::accel::{Backend, BackendKind, BuildOptions};
use luz::geometry::Geometry;
use luz::geometry::{Mesh, Quad, Sphere};
use luz::image::io::{read, write, WriteOptions};
use luz::math::{reflect, spawn_ray, Ray, Rgb, Vec3};
use luz::render::{build_accel, render_with, Film, PixelSum, RenderOptions};
use luz::sampling::{uniform_sphere, Rng};
use luz::scene::{load_str, Scene};
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// Every backend configuration: native, and Embree with robust off and on.
fn configs() -> Vec<(&'static str, BackendKind, BuildOptions)> {
    let mut v = vec![("rust", BackendKind::Rust, BuildOptions::default())];
    if embree_compiled() {
        for (name, robust) in [("embree", false), ("embree-robust", true)] {
            v.push((
                name,
                BackendKind::Embree,
                BuildOptions {
                    embree_robust: robust,
                    ..BuildOptions::default()
                },
            ));
        }
    }
    v
}

thread_local! {
    /// This test's rows of the table (each test runs on its own thread).
    static ROWS: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
}

fn row(extreme: &str, backend: &str, rays: u64, self_hits: u64, missed: u64, esc: u64, nf: u64) {
    ROWS.with(|r| {
        r.borrow_mut().push(format!(
            "| {extreme:<34} | {backend:<13} | {rays:>9} | {self_hits:>9} | {missed:>12} | {esc:>7} | {nf:>10} |"
        ))
    });
}

/// Prints this test's table in one piece when dropped, also on a failed
/// assertion (tests run in parallel, so rows are not printed one by one).
struct Table;

impl Drop for Table {
    fn drop(&mut self) {
        print_table();
    }
}

fn print_table() {
    let rows = ROWS.with(|r| std::mem::take(&mut *r.borrow_mut()));
    let mut out = String::from(
        "| extreme                            | backend       |      rays | self-hits | missed exits | escapes | non-finite |\n",
    );
    for r in rows {
        out += &r;
        out.push('\n');
    }
    eprint!("{out}");
}

fn scene_of(shapes: Vec<Geometry>) -> Arc<Scene> {
    Arc::new(Scene::of_geometry(shapes))
}

fn scene(text: &str) -> Arc<Scene> {
    Arc::new(load_str(text, Path::new("inline.toml")).expect("valid scene"))
}

/// Mean and standard error of the mean of the luminance-free channel sum
/// over all pixels and samples.
fn mean_and_se(film: &Film) -> (f64, f64) {
    let n = (film.samples * film.sum.len() as u64) as f64;
    let s: f64 = film.sum.iter().map(|p| p[0] + p[1] + p[2]).sum();
    // Upper bound on the variance of the channel sum: 3 × Σ per-channel.
    let q: f64 = film.sum_sq.iter().map(|p| p[0] + p[1] + p[2]).sum();
    let mean = s / n;
    let var = 3.0 * (q / n).max(0.0);
    (mean, (var / n).sqrt())
}

/// Renders `scene` on a backend config and checks the film: every pixel of
/// `image()` finite and `non_finite == 0`. Returns the film.
fn render_checked(
    scene: &Arc<Scene>,
    kind: BackendKind,
    options: &BuildOptions,
    what: &str,
    name: &str,
) -> Film {
    let accel = build_accel(scene, kind, options).unwrap();
    let film = render_with(scene, &accel, &RenderOptions::from_scene(scene), &()).0;
    let img = film.image();
    let bad = (0..film.height)
        .flat_map(|y| (0..film.width).map(move |x| (x, y)))
        .filter(|&(x, y)| !img.get(x, y).is_finite())
        .count();
    row(what, name, 0, 0, 0, 0, film.non_finite + bad as u64);
    assert_eq!(film.non_finite, 0, "{what} on {name}: non-finite samples");
    assert_eq!(bad, 0, "{what} on {name}: non-finite pixels");
    film
}
