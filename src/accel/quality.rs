//! Build quality: what `--bvh-quality` and `--embree-quality` ask for, and
//! the rule `auto` follows.
//!
//! A better tree costs build time and saves trace time, so the choice
//! depends on how many samples the tree will serve per triangle. Measured
//! on the subdivided bunny (`cargo bench --bench scale`, 2 threads; see
//! docs/performance.md): at 17.8M triangles, 256×256 and 16 spp (0.06
//! samples per triangle) the Morton build saves 7 s of the SAH build's 9
//! and Embree's low compact build 3.4 s of its medium one's 4.9, while
//! tracing slows by 10–25%; at the bunny's 240 samples per triangle the
//! build is under 0.1 s and tracing speed is all that counts. `auto` picks
//! `low` below a break-even number of samples per triangle and `medium`
//! above, one per backend. Embree's lies near one sample per triangle or
//! above. The native one lies near a fifth of a sample per triangle since
//! the `low` tree's leaves gather their triangles from the meshes
//! (2026-12-06): at 17.8M triangles the Morton build saves about 3.6 s of
//! build and 550 MB of memory, and its trace costs about 1.1 s more per
//! million samples on two threads (docs/performance.md). For Embree,
//! `auto`'s `low` is also compact (`RTC_SCENE_FLAG_COMPACT`: half the
//! memory, 14% slower rays on the 17.8M mesh).

use super::bvh::BuildQuality;
use super::EmbreeQuality;
use crate::geometry::Geometry;

/// A build quality preset, or `Auto`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Quality {
    /// Chosen from the samples per triangle (module docs).
    #[default]
    Auto,
    Low,
    Medium,
    High,
}

/// Samples per triangle below which `Auto` builds `Low`: the native
/// backend's and Embree's.
const NATIVE_LOW_BELOW: f64 = 0.2;
const EMBREE_LOW_BELOW: f64 = 1.0;

impl Quality {
    pub const ALL: [Quality; 4] = [Self::Auto, Self::Low, Self::Medium, Self::High];

    /// The name `FromStr` accepts.
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Low => "low",
            Self::Medium => "medium",
            Self::High => "high",
        }
    }

    /// `Low`, `Medium` or `High`: `Auto` resolved for `work` by the
    /// break-even `low_below` (samples per triangle).
    fn resolve(self, work: Work, low_below: f64) -> Quality {
        match self {
            Self::Auto if work.samples_per_triangle() < low_below => Self::Low,
            Self::Auto => Self::Medium,
            q => q,
        }
    }

    /// The native BVH's preset for `work`.
    pub fn native(self, work: Work) -> BuildQuality {
        match self.resolve(work, NATIVE_LOW_BELOW) {
            Self::Low => BuildQuality::Low,
            Self::High => BuildQuality::High,
            _ => BuildQuality::Medium,
        }
    }

    /// Embree's quality for `work`, and whether its scene is compact.
    pub fn embree(self, work: Work) -> (EmbreeQuality, bool) {
        match (self, self.resolve(work, EMBREE_LOW_BELOW)) {
            (Self::Auto, Self::Low) => (EmbreeQuality::Low, true),
            (_, Self::Low) => (EmbreeQuality::Low, false),
            (_, Self::High) => (EmbreeQuality::High, false),
            _ => (EmbreeQuality::Medium, false),
        }
    }
}

impl std::str::FromStr for Quality {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        crate::names::parse(s, &Self::ALL, Self::name, "build quality")
    }
}

/// How much tracing a build will serve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Work {
    pub samples: f64,
    pub triangles: f64,
}

impl Work {
    /// `samples` traced through `shapes`.
    pub fn of(samples: f64, shapes: &[Geometry]) -> Self {
        let triangles = shapes.iter().map(Geometry::primitive_count).sum::<usize>();
        Self {
            samples,
            triangles: triangles as f64,
        }
    }

    fn samples_per_triangle(self) -> f64 {
        self.samples / self.triangles.max(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_is_low_below_each_backends_break_even() {
        let few = Work {
            samples: 1e6,
            triangles: 17.8e6,
        };
        // 0.24 samples per triangle: the native SAH build pays, Embree's
        // does not yet.
        let between = Work {
            samples: 4.2e6,
            triangles: 17.8e6,
        };
        assert_eq!(Quality::Auto.native(between), BuildQuality::Medium);
        assert_eq!(Quality::Auto.embree(between), (EmbreeQuality::Low, true));
        let many = Work {
            samples: 16.7e6,
            triangles: 69e3,
        };
        assert_eq!(Quality::Auto.native(few), BuildQuality::Low);
        assert_eq!(Quality::Auto.native(many), BuildQuality::Medium);
        assert_eq!(Quality::Auto.embree(few), (EmbreeQuality::Low, true));
        assert_eq!(Quality::Auto.embree(many), (EmbreeQuality::Medium, false));
        assert_eq!(Quality::Low.embree(many), (EmbreeQuality::Low, false));
        assert_eq!(Quality::High.native(few), BuildQuality::High);
        assert_eq!("auto".parse::<Quality>(), Ok(Quality::Auto));
    }
}
