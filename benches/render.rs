//! End-to-end renders (see `renders/mod.rs`):
//! `cargo bench --bench render [-- FILTER]`.

mod renders;

criterion::criterion_group!(benches, renders::renders);
criterion::criterion_main!(benches);
