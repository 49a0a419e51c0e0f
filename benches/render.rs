//! End-to-end renders of the peer scenes at 128×128, 16 spp, per compiled
//! backend: the figure users feel. Throughput is reported in samples/s.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use luz::accel::{Accel, BackendKind, BuildOptions};
use luz::render::{render_with, RenderOptions};
use std::path::Path;
use std::sync::Arc;

fn renders(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut group = c.benchmark_group("render-128x128-16spp");
    group.sample_size(10);
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
        group.throughput(Throughput::Elements(128 * 128 * 16));
        for backend in luz::accel::compiled_backends() {
            let kind = backend
                .parse::<BackendKind>()
                .expect("compiled backends parse");
            let accel = Accel::build(&scene, kind, &BuildOptions::default()).expect("builds");
            group.bench_function(format!("{name}/{backend}"), |b| {
                b.iter(|| render_with(&scene, &accel, &options, &()))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, renders);
criterion_main!(benches);
