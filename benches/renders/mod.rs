//! End-to-end renders of the peer scenes at 128×128, 16 spp, per compiled
//! backend: the figure users feel. Throughput is in rays/s (camera, bounce
//! and shadow rays), counted by a first render: the image, and so its ray
//! count, is the same on every run.

use criterion::{Criterion, SamplingMode, Throughput};
use luz::accel::{BackendKind, BuildOptions};
use luz::render::{build_accel, render_with, RenderOptions};
use std::path::Path;
use std::sync::Arc;

pub fn renders(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut group = c.benchmark_group("render");
    // A render takes a tenth of a second or more: few samples of one each.
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    for name in ["cornell-area", "bunny"] {
        let path = root.join("scenes").join(format!("{name}.toml"));
        let mut scene = match luz::scene::load(&path) {
            Ok(scene) => scene,
            Err(e) => {
                eprintln!("skipped {name}: {e}");
                continue;
            }
        };
        scene.camera.width = 128;
        scene.camera.height = 128;
        scene.render.spp = 16;
        let scene = Arc::new(scene);
        let options = RenderOptions::from_scene(&scene);
        for backend in luz::accel::compiled_backends() {
            let kind = backend
                .parse::<BackendKind>()
                .expect("compiled backends parse");
            let accel = build_accel(&scene, kind, &BuildOptions::default()).expect("builds");
            let (_, stats) = render_with(&scene, &accel, &options, &());
            group.throughput(Throughput::Elements(stats.rays.total()));
            group.bench_function(format!("{name}-128x128-16spp/{backend}"), |b| {
                b.iter(|| render_with(&scene, &accel, &options, &()))
            });
        }
    }
    group.finish();
}
