//! The settings a study compares: which backends and varied options, every
//! combination of them, each with its label.

use super::StudyError;
use crate::accel::{AccelError, BackendKind, BuildOptions, Quality};
use crate::sampling::SamplerKind;
use crate::scene::Scene;
use std::fmt::Write as _;

/// A dimension of the sweep; several vary together as every combination.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Vary {
    /// Next-event estimation of area lights on and off.
    Nee,
    RussianRoulette,
    MaxDepth,
    EmbreeQuality,
    EmbreeRobust,
    /// Independent numbers against Sobol' points.
    Sampler,
    /// Every pixel alike against the same budget spent where the relative
    /// error is largest (`--adaptive`).
    Sampling,
}

impl std::str::FromStr for Vary {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "rr" {
            return Ok(Self::RussianRoulette);
        }
        crate::names::parse(s, &Self::ALL, Self::name, "study dimension")
    }
}

impl Vary {
    const ALL: [Vary; 7] = [
        Self::Nee,
        Self::RussianRoulette,
        Self::MaxDepth,
        Self::EmbreeQuality,
        Self::EmbreeRobust,
        Self::Sampler,
        Self::Sampling,
    ];

    /// The name `FromStr` accepts (which also takes `rr`).
    fn name(self) -> &'static str {
        match self {
            Self::Nee => "nee",
            Self::RussianRoulette => "russian-roulette",
            Self::MaxDepth => "max-depth",
            Self::EmbreeQuality => "embree-quality",
            Self::EmbreeRobust => "embree-robust",
            Self::Sampler => "sampler",
            Self::Sampling => "sampling",
        }
    }

    fn embree_only(self) -> bool {
        matches!(self, Self::EmbreeQuality | Self::EmbreeRobust)
    }
}

/// Maximum depths of `--vary max-depth` when none are given.
pub const DEFAULT_MAX_DEPTHS: [u32; 3] = [3, 5, 8];

/// One way of rendering the scene: a curve of the plots.
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    /// `Rust` or `Embree`, never `Auto`.
    pub backend: BackendKind,
    /// `None`: as the scene file says.
    pub nee: Option<bool>,
    pub russian_roulette: bool,
    pub max_depth: u32,
    pub sampler: SamplerKind,
    /// Each spp of the sweep as a budget spent adaptively, not uniformly.
    pub adaptive: bool,
    pub build: BuildOptions,
    /// The backend and the varied values, e.g. `embree / NEE off / RR on`.
    pub label: String,
}

/// The backends and settings of a study from its options: the backends
/// resolved, the varied dimensions without repeats (those that only Embree
/// has need the Embree backend) and their values checked.
pub(super) fn plan(
    scene: &Scene,
    backends: &[BackendKind],
    asked_vary: Vec<Vary>,
    max_depths: Option<Vec<u32>>,
    build: BuildOptions,
) -> Result<(Vec<BackendKind>, Vec<Setting>), StudyError> {
    let invalid = |m: String| Err(StudyError::Invalid(m));
    let backends = resolve_backends(backends)?;
    let mut vary = Vec::new();
    for v in asked_vary {
        if !vary.contains(&v) {
            vary.push(v);
        }
    }
    if let Some(v) = vary.iter().find(|v| v.embree_only()) {
        if !backends.contains(&BackendKind::Embree) {
            return invalid(format!(
                "--vary {}: only the Embree backend has that option, and --backends leaves it out",
                v.name()
            ));
        }
    }
    let max_depths = match max_depths {
        Some(_) if !vary.contains(&Vary::MaxDepth) => {
            return invalid("--max-depths needs --vary max-depth".into())
        }
        Some(d) if d.is_empty() || d.contains(&0) => {
            return invalid("--max-depths: give depths of at least 1".into())
        }
        Some(d) => d,
        None => DEFAULT_MAX_DEPTHS.to_vec(),
    };
    let settings = enumerate(scene, &backends, &vary, &max_depths, build);
    Ok((backends, settings))
}

fn resolve_backends(asked: &[BackendKind]) -> Result<Vec<BackendKind>, StudyError> {
    let embree = cfg!(luz_embree);
    let asked = if asked.is_empty() {
        if embree {
            vec![BackendKind::Rust, BackendKind::Embree]
        } else {
            vec![BackendKind::Rust]
        }
    } else {
        asked.to_vec()
    };
    let mut backends = Vec::new();
    for kind in asked {
        let kind = match kind {
            BackendKind::Auto if embree => BackendKind::Embree,
            BackendKind::Auto => BackendKind::Rust,
            BackendKind::Embree if !embree => return Err(AccelError::EmbreeMissing.into()),
            k => k,
        };
        if !backends.contains(&kind) {
            backends.push(kind);
        }
    }
    Ok(backends)
}

/// Every combination of the backends and the varied values, in the order
/// given; Embree's options vary only for Embree.
pub(super) fn enumerate(
    scene: &Scene,
    backends: &[BackendKind],
    vary: &[Vary],
    max_depths: &[u32],
    build: BuildOptions,
) -> Vec<Setting> {
    let mut settings: Vec<Setting> = backends
        .iter()
        .map(|&backend| Setting {
            backend,
            nee: None,
            russian_roulette: scene.render.russian_roulette,
            max_depth: scene.render.max_depth,
            sampler: scene.render.sampler,
            adaptive: false,
            build,
            label: backend.name().to_owned(),
        })
        .collect();
    for &v in vary {
        settings = settings
            .into_iter()
            .flat_map(|s| {
                if v.embree_only() && s.backend != BackendKind::Embree {
                    return vec![s];
                }
                let both = |f: fn(&mut Setting, bool), name: &str| {
                    variants(&s, [true, false], f, |on| format!("{name} {}", on_off(on)))
                };
                match v {
                    Vary::Nee => both(|t, on| t.nee = Some(on), "NEE"),
                    Vary::RussianRoulette => both(|t, on| t.russian_roulette = on, "RR"),
                    Vary::EmbreeRobust => both(|t, on| t.build.embree_robust = on, "robust"),
                    Vary::Sampling => variants(
                        &s,
                        [false, true],
                        |t, adaptive| t.adaptive = adaptive,
                        |adaptive| sampling_name(adaptive).to_owned(),
                    ),
                    Vary::MaxDepth => variants(
                        &s,
                        max_depths.iter().copied(),
                        |t, d| t.max_depth = d,
                        |d| format!("depth {d}"),
                    ),
                    Vary::Sampler => variants(
                        &s,
                        SamplerKind::ALL,
                        |t, kind| t.sampler = kind,
                        |kind| kind.name().to_owned(),
                    ),
                    Vary::EmbreeQuality => variants(
                        &s,
                        [Quality::Low, Quality::Medium, Quality::High],
                        |t, q| t.build.embree_quality = q,
                        |q| format!("{} quality", q.name()),
                    ),
                }
            })
            .collect();
    }
    settings
}

/// One copy of `setting` per value, each with `apply` done and
/// ` / {label(value)}` added to its label.
fn variants<T: Copy>(
    setting: &Setting,
    values: impl IntoIterator<Item = T>,
    apply: impl Fn(&mut Setting, T),
    label: impl Fn(T) -> String,
) -> Vec<Setting> {
    values
        .into_iter()
        .map(|value| {
            let mut t = setting.clone();
            apply(&mut t, value);
            let _ = write!(t.label, " / {}", label(value));
            t
        })
        .collect()
}

pub(super) fn sampling_name(adaptive: bool) -> &'static str {
    if adaptive {
        "adaptive"
    } else {
        "uniform"
    }
}

pub(super) fn on_off(b: bool) -> &'static str {
    if b {
        "on"
    } else {
        "off"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::test_scene as scene;

    #[test]
    fn settings_are_every_combination_and_embree_options_vary_only_embree() {
        let s = scene();
        let both = [BackendKind::Rust, BackendKind::Embree];
        let t = enumerate(
            &s,
            &both,
            &[Vary::Nee, Vary::RussianRoulette],
            &[],
            BuildOptions::default(),
        );
        let labels: Vec<&str> = t.iter().map(|t| t.label.as_str()).collect();
        assert_eq!(
            labels,
            [
                "rust / NEE on / RR on",
                "rust / NEE on / RR off",
                "rust / NEE off / RR on",
                "rust / NEE off / RR off",
                "embree / NEE on / RR on",
                "embree / NEE on / RR off",
                "embree / NEE off / RR on",
                "embree / NEE off / RR off",
            ]
        );
        assert!(t.iter().all(|t| t.max_depth == 7));
        assert_eq!(t[3].nee, Some(false));
        assert!(!t[3].russian_roulette);

        let t = enumerate(
            &s,
            &both,
            &[Vary::EmbreeQuality, Vary::MaxDepth],
            &[2, 9],
            BuildOptions::default(),
        );
        assert_eq!(t.len(), 2 + 3 * 2);
        assert_eq!(t[0].label, "rust / depth 2");
        assert_eq!(t[7].label, "embree / high quality / depth 9");
        assert_eq!(t[7].build.embree_quality, Quality::High);

        let t = enumerate(
            &s,
            &[BackendKind::Rust],
            &[Vary::Sampler],
            &[],
            BuildOptions::default(),
        );
        let kinds: Vec<(&str, SamplerKind)> =
            t.iter().map(|t| (t.label.as_str(), t.sampler)).collect();
        assert_eq!(
            kinds,
            [
                ("rust / independent", SamplerKind::Independent),
                ("rust / sobol", SamplerKind::Sobol)
            ]
        );

        let t = enumerate(
            &s,
            &[BackendKind::Rust],
            &[Vary::Sampling, Vary::Sampler],
            &[],
            BuildOptions::default(),
        );
        let labels: Vec<(&str, bool)> = t.iter().map(|t| (t.label.as_str(), t.adaptive)).collect();
        assert_eq!(
            labels,
            [
                ("rust / uniform / independent", false),
                ("rust / uniform / sobol", false),
                ("rust / adaptive / independent", true),
                ("rust / adaptive / sobol", true),
            ]
        );
        assert_eq!("sampling".parse::<Vary>(), Ok(Vary::Sampling));
    }
}
