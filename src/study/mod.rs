//! `luz study`: how fast each way of rendering a scene gets how close to the
//! right answer.
//!
//! Every setting (backend × the varied integrator or build options) renders
//! the scene at every sample count of the sweep; each image is compared with
//! one reference, read from a file or rendered first at many more samples
//! with a different seed, so its noise is independent of the images it
//! judges. The measured wall time and error give the Monte Carlo efficiency
//! 1/(relMSE·time), the time each setting needs to reach a target relMSE
//! (interpolated on the log-log curve), a CSV of every render, a Markdown
//! summary and log-log plots of error against time.

pub mod plot;
mod report;
mod runs;
mod settings;
mod tables;

pub use report::{time_to, Reach, Report, Row};
pub use runs::{ReferenceRender, Study};
pub use settings::{Setting, Vary, DEFAULT_MAX_DEPTHS};
pub use tables::CSV_COLUMNS;

use crate::accel::{AccelError, BackendKind, BuildOptions};
use crate::image::ImageError;
use std::path::PathBuf;

/// How many times the study's largest sample count a rendered reference
/// takes: its error then adds about 1/16 to the smallest measured relMSE.
pub const REFERENCE_SPP_FACTOR: u32 = 16;

/// Where the reference comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum ReferenceSource {
    File(PathBuf),
    /// Rendered first with the scene's own settings; `spp` defaults to
    /// [`REFERENCE_SPP_FACTOR`] times the study's largest.
    Render {
        spp: Option<u32>,
        save: Option<PathBuf>,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct StudyOptions {
    pub spp: Vec<u32>,
    /// Empty: every backend compiled into this build.
    pub backends: Vec<BackendKind>,
    pub vary: Vec<Vary>,
    /// Values of `--vary max-depth`; `None`: [`DEFAULT_MAX_DEPTHS`].
    pub max_depths: Option<Vec<u32>>,
    /// Embree's options where they are not varied.
    pub build: BuildOptions,
    pub reference: ReferenceSource,
    /// The relMSE whose time-to-reach the summary ranks settings by.
    pub target_rel_mse: f64,
    /// Directory of the CSV, the summary and the plots.
    pub out: PathBuf,
}

#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error("{0}")]
    Invalid(String),
    #[error(transparent)]
    Accel(#[from] AccelError),
    #[error("reference: {0}")]
    Reference(ImageError),
    #[error("{}: {source}", path.display())]
    OutDir {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: {source}", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("writing the reference: {0}")]
    WriteReference(ImageError),
    #[error("{}: {message}", path.display())]
    Plot { path: PathBuf, message: String },
}

impl StudyError {
    /// Whether the user's input (arguments, files) is at fault rather than
    /// the machine.
    pub fn is_input(&self) -> bool {
        matches!(
            self,
            Self::Invalid(_) | Self::Accel(_) | Self::Reference(_) | Self::OutDir { .. }
        )
    }
}

/// A tiny scene for the tests: an emissive sphere above an emissive plane.
#[cfg(test)]
fn test_scene() -> crate::scene::Scene {
    crate::scene::load_str(
        r#"[camera]
eye = [0, 0, 4]
target = [0, 0, 0]
resolution = [4, 4]
[render]
max_depth = 7
russian_roulette = false
[materials.light]
emission = 1
[materials.floor]
emission = 1
[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "light"
[[shapes]]
type = "plane"
point = [0, -1, 0]
normal = [0, 1, 0]
material = "floor"
"#,
        std::path::Path::new("t.toml"),
    )
    .unwrap()
}
