//! luz: a physically based path tracer with two interchangeable
//! ray-intersection backends (Embree through FFI, and a native Rust BVH)
//! feeding one Monte Carlo integrator.

pub mod accel;
pub mod bsdf;
pub mod distributed;
pub mod echo;
pub mod geometry;
pub mod image;
pub mod job;
mod location;
pub mod math;
mod memory;
pub mod meter;
mod names;
pub mod render;
pub mod sampling;
pub mod scene;
pub(crate) mod simd;
pub mod study;
