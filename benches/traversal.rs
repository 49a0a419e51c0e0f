//! Backend builds and traversal on the Stanford meshes (see
//! `backends/mod.rs`): `cargo bench --bench traversal [-- FILTER]`.

mod assets;
mod backends;

criterion::criterion_group!(benches, backends::backends);
criterion::criterion_main!(benches);
