//! Renders split in time and across machines: sample ranges rendered in
//! passes with checkpoints between them ([`passes`]), saved as self-checking
//! EXR parts ([`part`]), shared among the tasks of an array job ([`task`]),
//! and added up again exactly ([`merge`]).

pub mod merge;
pub mod part;
pub mod passes;
mod scene_hash;
pub mod task;
