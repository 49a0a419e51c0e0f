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

use crate::accel::{Accel, AccelError, BackendKind, BuildOptions, Quality};
use crate::geometry::Geometry;
use crate::image::io::{self as imageio, ImageError, WriteOptions};
use crate::image::{metrics, Image};
use crate::render::{render_with, IntegratorSettings, Progress, RenderOptions};
use crate::sampling::SamplerKind;
use crate::scene::Scene;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

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
    const ALL: [Vary; 6] = [
        Self::Nee,
        Self::RussianRoulette,
        Self::MaxDepth,
        Self::EmbreeQuality,
        Self::EmbreeRobust,
        Self::Sampler,
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
        }
    }

    fn embree_only(self) -> bool {
        matches!(self, Self::EmbreeQuality | Self::EmbreeRobust)
    }
}

/// Maximum depths of `--vary max-depth` when none are given.
pub const DEFAULT_MAX_DEPTHS: [u32; 3] = [3, 5, 8];

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
    pub build: BuildOptions,
    /// The backend and the varied values, e.g. `embree / NEE off / RR on`.
    pub label: String,
}

/// One render of the sweep, measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// Index into [`Report::settings`].
    pub setting: usize,
    pub spp: u32,
    /// The acceleration structure's build, once per setting (not in `time_s`).
    pub build_s: f64,
    /// Wall time of the render.
    pub time_s: f64,
    pub rmse: f64,
    pub rel_mse: f64,
    /// Mean of (image - reference) over all channel values.
    pub mean_bias: f64,
    /// 1 / (relMSE · time).
    pub efficiency: f64,
}

/// When a setting's relMSE curve reaches the target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// Between two measured renders: the time interpolated on the log-log
    /// curve.
    At(f64),
    /// Already at the smallest sample count, which took this long.
    Before(f64),
    /// Not within the sweep.
    Never,
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

enum Reference {
    Loaded { image: Image, path: PathBuf },
    Render(ReferenceRender),
}

/// The reference a study renders before its sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceRender {
    pub spp: u32,
    pub seed: u64,
    pub backend: BackendKind,
    pub save: Option<PathBuf>,
}

/// A planned study: arguments checked, settings enumerated, reference read.
pub struct Study {
    scene: Arc<Scene>,
    name: String,
    spp: Vec<u32>,
    settings: Vec<Setting>,
    reference: Reference,
    build: BuildOptions,
    target_rel_mse: f64,
    out: PathBuf,
}

/// The study's images use the scene's seed; the reference's seed differs by
/// this, so the two are independent.
const REFERENCE_SEED_OFFSET: u64 = 0x9E37_79B9_7F4A_7C15;

impl Study {
    /// Checks `options` against `scene` (already loaded with the command
    /// line's overrides), reads a reference file, and creates the output
    /// directory, so a study that cannot finish fails before rendering.
    pub fn new(scene: Scene, name: &str, options: StudyOptions) -> Result<Self, StudyError> {
        let invalid = |m: String| Err(StudyError::Invalid(m));
        let mut spp = options.spp;
        spp.sort_unstable();
        spp.dedup();
        if spp.is_empty() || spp[0] == 0 {
            return invalid("--spp: give sample counts of at least 1".into());
        }
        if !(options.target_rel_mse > 0.0 && options.target_rel_mse.is_finite()) {
            return invalid(format!(
                "--target-rel-mse must be positive, found {}",
                options.target_rel_mse
            ));
        }
        let backends = resolve_backends(&options.backends)?;
        let mut vary = Vec::new();
        for v in options.vary {
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
        let max_depths = match options.max_depths {
            Some(_) if !vary.contains(&Vary::MaxDepth) => {
                return invalid("--max-depths needs --vary max-depth".into())
            }
            Some(d) if d.is_empty() || d.contains(&0) => {
                return invalid("--max-depths: give depths of at least 1".into())
            }
            Some(d) => d,
            None => DEFAULT_MAX_DEPTHS.to_vec(),
        };
        let settings = enumerate(&scene, &backends, &vary, &max_depths, options.build);

        let (width, height) = (scene.camera.width, scene.camera.height);
        let reference = match options.reference {
            ReferenceSource::File(path) => {
                let image = imageio::read(&path).map_err(StudyError::Reference)?;
                if (image.width, image.height) != (width, height) {
                    return invalid(format!(
                        "the reference {} is {}x{} but the study renders {width}x{height} (see --resolution)",
                        path.display(),
                        image.width,
                        image.height
                    ));
                }
                Reference::Loaded { image, path }
            }
            ReferenceSource::Render { spp: ref_spp, save } => {
                let largest = *spp.last().expect("checked non-empty");
                let ref_spp = match ref_spp {
                    Some(0) => return invalid("--reference-spp must be at least 1".into()),
                    Some(n) => n,
                    None => largest.checked_mul(REFERENCE_SPP_FACTOR).ok_or_else(|| {
                        StudyError::Invalid(format!("--spp {largest} is too large"))
                    })?,
                };
                if let Some(path) = &save {
                    imageio::check_output_path(path).map_err(StudyError::Reference)?;
                }
                Reference::Render(ReferenceRender {
                    spp: ref_spp,
                    seed: scene.render.seed.wrapping_add(REFERENCE_SEED_OFFSET),
                    backend: backends[0],
                    save,
                })
            }
        };
        std::fs::create_dir_all(&options.out).map_err(|source| StudyError::OutDir {
            path: options.out.clone(),
            source,
        })?;
        Ok(Self {
            scene: Arc::new(scene),
            name: name.to_owned(),
            spp,
            settings,
            reference,
            build: options.build,
            target_rel_mse: options.target_rel_mse,
            out: options.out,
        })
    }

    pub fn settings(&self) -> &[Setting] {
        &self.settings
    }

    /// The reference this study renders first, if it reads none.
    pub fn reference_render(&self) -> Option<&ReferenceRender> {
        match &self.reference {
            Reference::Render(r) => Some(r),
            Reference::Loaded { .. } => None,
        }
    }

    /// Rows × samples the whole study renders, reference included: the
    /// length of a progress bar whose `row_done` calls [`Study::run`] makes.
    pub fn work(&self) -> u64 {
        // The sweep, plus the untimed warm-up render at the smallest spp.
        let per_setting: u64 = self.spp.iter().map(|&s| s as u64).sum::<u64>() + self.spp[0] as u64;
        let reference = self.reference_render().map_or(0, |r| r.spp as u64);
        self.scene.camera.height as u64 * (reference + per_setting * self.settings.len() as u64)
    }

    /// Renders the reference (if needed) and the sweep, then writes
    /// `study.csv`, `summary.md` and the plots into the output directory.
    /// `progress` is told of every row with the samples rendered in it.
    pub fn run(&self, progress: &dyn Progress) -> Result<Report, StudyError> {
        let (reference, reference_note) = match &self.reference {
            Reference::Loaded { image, path } => (image.clone(), format!("{}", path.display())),
            Reference::Render(r) => (self.render_reference(r, progress)?, reference_note(r)),
        };
        let mut rows = Vec::new();
        for (index, setting) in self.settings.iter().enumerate() {
            let scene = self.variant(setting);
            let start = Instant::now();
            let accel = Accel::build(&scene, setting.backend, &setting.build)?;
            let build_s = start.elapsed().as_secs_f64();
            let render = |spp: u32| {
                let options = RenderOptions {
                    samples: 0..spp,
                    seed: scene.render.seed,
                    sampler: setting.sampler,
                    integrator: IntegratorSettings {
                        max_depth: setting.max_depth,
                        russian_roulette: setting.russian_roulette,
                    },
                    sampling: crate::render::Sampling::Uniform,
                };
                render_with(&scene, &accel, &options, progress)
            };
            // A setting's first render pays for cold caches and page faults
            // in a freshly built structure; it would skew the smallest spp.
            render(self.spp[0]);
            for &spp in &self.spp {
                let (film, stats) = render(spp);
                let c = metrics::compare(&film.image(), &reference, 0.0, 0.0)
                    .expect("the reference's size was checked");
                let time_s = stats.wall.as_secs_f64();
                rows.push(Row {
                    setting: index,
                    spp,
                    build_s,
                    time_s,
                    rmse: c.rmse,
                    rel_mse: c.rel_mse,
                    mean_bias: c.mean_a - c.mean_b,
                    efficiency: 1.0 / (c.rel_mse * time_s),
                });
            }
        }
        let report = Report {
            scene: self.name.clone(),
            width: self.scene.camera.width,
            height: self.scene.camera.height,
            threads: rayon::current_num_threads(),
            seed: self.scene.render.seed,
            reference: reference_note,
            target_rel_mse: self.target_rel_mse,
            settings: self.settings.clone(),
            rows,
        };
        report.write(&self.out)?;
        Ok(report)
    }

    fn render_reference(
        &self,
        r: &ReferenceRender,
        progress: &dyn Progress,
    ) -> Result<Image, StudyError> {
        let scene = Arc::clone(&self.scene);
        let accel = Accel::build(&scene, r.backend, &self.build)?;
        let mut options = RenderOptions::from_scene(&scene);
        options.samples = 0..r.spp;
        options.seed = r.seed;
        let image = render_with(&scene, &accel, &options, progress).0.image();
        if let Some(path) = &r.save {
            imageio::write(path, &image, &WriteOptions::default())
                .map_err(StudyError::WriteReference)?;
        }
        Ok(image)
    }

    /// The scene as `setting` renders it.
    /// The scene as `setting` renders it: shared unless NEE is varied.
    fn variant(&self, setting: &Setting) -> Arc<Scene> {
        match setting.nee {
            Some(nee) => {
                let mut scene = Scene::clone(&self.scene);
                set_nee(&mut scene, nee);
                Arc::new(scene)
            }
            None => Arc::clone(&self.scene),
        }
    }
}

fn reference_note(r: &ReferenceRender) -> String {
    format!(
        "rendered first ({r}) with the scene's own NEE, Russian roulette, max depth and sampler"
    )
}

impl std::fmt::Display for ReferenceRender {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} spp, seed {}, {} backend",
            self.spp,
            self.seed,
            self.backend.name()
        )
    }
}

/// Samples every emitter NEE can sample (all but planes), or none. Point
/// lights can only be sampled, so they stay as they are.
fn set_nee(scene: &mut Scene, on: bool) {
    for shape in &mut scene.shapes {
        shape.nee = on
            && scene.materials[shape.material as usize].is_emissive()
            && !matches!(shape.geometry, Geometry::Plane(_));
    }
    scene.rebuild_lights();
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
fn enumerate(
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
                let both = |f: fn(&mut Setting, bool), name: &str| -> Vec<Setting> {
                    [true, false]
                        .into_iter()
                        .map(|on| {
                            let mut t = s.clone();
                            f(&mut t, on);
                            let _ = write!(t.label, " / {name} {}", on_off(on));
                            t
                        })
                        .collect()
                };
                match v {
                    Vary::Nee => both(|t, on| t.nee = Some(on), "NEE"),
                    Vary::RussianRoulette => both(|t, on| t.russian_roulette = on, "RR"),
                    Vary::EmbreeRobust => both(|t, on| t.build.embree_robust = on, "robust"),
                    Vary::MaxDepth => max_depths
                        .iter()
                        .map(|&d| {
                            let mut t = s.clone();
                            t.max_depth = d;
                            let _ = write!(t.label, " / depth {d}");
                            t
                        })
                        .collect(),
                    Vary::Sampler => SamplerKind::ALL
                        .into_iter()
                        .map(|kind| {
                            let mut t = s.clone();
                            t.sampler = kind;
                            let _ = write!(t.label, " / {}", kind.name());
                            t
                        })
                        .collect(),
                    Vary::EmbreeQuality => [Quality::Low, Quality::Medium, Quality::High]
                        .into_iter()
                        .map(|q| {
                            let mut t = s.clone();
                            t.build.embree_quality = q;
                            let _ = write!(t.label, " / {} quality", q.name());
                            t
                        })
                        .collect(),
                }
            })
            .collect();
    }
    settings
}

fn on_off(b: bool) -> &'static str {
    if b {
        "on"
    } else {
        "off"
    }
}

/// A finished study's measurements.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The scene file's name.
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub threads: usize,
    pub seed: u64,
    /// Where the reference came from, in words.
    pub reference: String,
    pub target_rel_mse: f64,
    pub settings: Vec<Setting>,
    pub rows: Vec<Row>,
}

/// The CSV's columns, in order.
pub const CSV_COLUMNS: [&str; 15] = [
    "setting",
    "backend",
    "nee",
    "russian_roulette",
    "max_depth",
    "sampler",
    "embree_quality",
    "embree_robust",
    "spp",
    "time_s",
    "build_s",
    "rmse",
    "rel_mse",
    "mean_bias",
    "efficiency",
];

impl Report {
    /// The renders of setting `index`, by increasing sample count.
    pub fn series(&self, index: usize) -> impl Iterator<Item = &Row> {
        self.rows.iter().filter(move |r| r.setting == index)
    }

    /// When setting `index` reaches relMSE `target`.
    pub fn time_to(&self, index: usize, target: f64) -> Reach {
        let points: Vec<(f64, f64)> = self.series(index).map(|r| (r.time_s, r.rel_mse)).collect();
        time_to(&points, target)
    }

    pub fn csv(&self) -> String {
        let mut s = CSV_COLUMNS.join(",");
        s.push('\n');
        for r in &self.rows {
            let t = &self.settings[r.setting];
            let (quality, robust) = if t.backend == BackendKind::Embree {
                (t.build.embree_quality.name(), on_off(t.build.embree_robust))
            } else {
                ("", "")
            };
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{quality},{robust},{},{},{},{},{},{},{}",
                t.label,
                t.backend.name(),
                t.nee.map_or("scene", on_off),
                on_off(t.russian_roulette),
                t.max_depth,
                t.sampler.name(),
                r.spp,
                r.time_s,
                r.build_s,
                r.rmse,
                r.rel_mse,
                r.mean_bias,
                r.efficiency
            );
        }
        s
    }

    /// Settings by the time they take to reach the target relMSE, fastest
    /// first; those that never reach it last.
    fn ranking(&self) -> Vec<(usize, Reach)> {
        let mut ranked: Vec<(usize, Reach)> = (0..self.settings.len())
            .map(|i| (i, self.time_to(i, self.target_rel_mse)))
            .collect();
        let key = |r: &Reach| match *r {
            Reach::At(t) | Reach::Before(t) => t,
            Reach::Never => f64::INFINITY,
        };
        ranked.sort_by(|a, b| key(&a.1).total_cmp(&key(&b.1)));
        ranked
    }

    /// One sentence: which setting reaches the target relMSE first, and how
    /// much longer the others take.
    pub fn conclusion(&self) -> String {
        let ranked = self.ranking();
        let target = self.target_rel_mse;
        let Some(&(best, Reach::At(best_t))) = ranked.first() else {
            return match ranked.first() {
                Some(&(i, Reach::Before(t))) => format!(
                    "{} is below relMSE {target:e} already at the smallest spp ({t:.3} s): start the sweep lower",
                    self.settings[i].label
                ),
                _ => format!("no setting reaches relMSE {target:e} within the sweep: add larger spp"),
            };
        };
        let mut s = format!(
            "fastest to relMSE {target:e}: {} in {best_t:.3} s",
            self.settings[best].label
        );
        for &(i, reach) in &ranked[1..] {
            let label = &self.settings[i].label;
            let _ = match reach {
                Reach::At(t) => write!(s, "; {label} {:.2}x as long", t / best_t),
                Reach::Before(_) => write!(s, "; {label} below it at the smallest spp"),
                Reach::Never => write!(s, "; {label} not within the sweep"),
            };
        }
        s
    }

    pub fn markdown(&self) -> String {
        let target = self.target_rel_mse;
        let spp: Vec<u32> = self.series(0).map(|r| r.spp).collect();
        let largest = spp.last().copied().unwrap_or(0);
        let mut s = format!("# luz study: {}\n\n", self.scene);
        let _ = writeln!(
            s,
            "{}x{} pixels, spp {}, {} threads, seed {}. Reference: {}.\n",
            self.width,
            self.height,
            spp.iter()
                .map(u32::to_string)
                .collect::<Vec<_>>()
                .join(", "),
            self.threads,
            self.seed,
            self.reference
        );
        s.push_str(
            "Time is each render's wall time, after one untimed warm-up render per setting; \
             the acceleration structure, built once per setting, is not in it (`build_s` in \
             study.csv). Efficiency is 1/(relMSE·time), \
             the median over the sweep. Times to reach the target are interpolated on the \
             log-log curve of relMSE against time.\n\n",
        );
        if self.settings.iter().any(|t| t.nee.is_some()) {
            s.push_str(
                "NEE on samples every emissive shape but infinite planes; NEE off finds area \
                 lights only by hitting them. Point lights cannot be hit, so every setting \
                 samples them.\n\n",
            );
        }
        let _ = writeln!(
            s,
            "| setting | time to relMSE {target:e} | vs fastest | efficiency | relMSE at {largest} spp | mean bias at {largest} spp |"
        );
        s.push_str("|---|---|---|---|---|---|\n");
        let ranking = self.ranking();
        let fastest = match ranking.first() {
            Some(&(_, Reach::At(t))) => Some(t),
            _ => None,
        };
        for &(i, reach) in &ranking {
            let (time, ratio) = match reach {
                Reach::At(t) => (
                    format!("{t:.3} s"),
                    fastest.map_or(String::new(), |f| format!("{:.2}×", t / f)),
                ),
                Reach::Before(t) => (format!("< {t:.3} s"), String::new()),
                Reach::Never => ("not reached".into(), String::new()),
            };
            let mut eff: Vec<f64> = self.series(i).map(|r| r.efficiency).collect();
            eff.sort_by(f64::total_cmp);
            let median = eff.get(eff.len() / 2).copied().unwrap_or(f64::NAN);
            let last = self.series(i).last();
            let _ = writeln!(
                s,
                "| {} | {time} | {ratio} | {median:.3} | {:.3e} | {:.2e} |",
                self.settings[i].label,
                last.map_or(f64::NAN, |r| r.rel_mse),
                last.map_or(f64::NAN, |r| r.mean_bias),
            );
        }
        let _ = writeln!(s, "\n**{}.**\n", capitalise(&self.conclusion()));
        s.push_str(
            "![relMSE against time](relmse.png)\n\n![RMSE against time](rmse.png)\n\n\
             Every render's numbers: [study.csv](study.csv).\n",
        );
        s
    }

    /// Writes `study.csv`, `summary.md`, `relmse.{png,svg}` and
    /// `rmse.{png,svg}` into `dir`, which must exist.
    pub fn write(&self, dir: &Path) -> Result<(), StudyError> {
        let write = |name: &str, text: String| {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|source| StudyError::Write { path, source })
        };
        write("study.csv", self.csv())?;
        write("summary.md", self.markdown())?;
        for metric in [plot::Metric::RelMse, plot::Metric::Rmse] {
            plot::error_against_time(self, metric, dir)?;
        }
        Ok(())
    }
}

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

/// The time at which the curve through `points` (time, error), in sweep
/// order, first falls to `target`, interpolated linearly in log-log space.
pub fn time_to(points: &[(f64, f64)], target: f64) -> Reach {
    match points.first() {
        None => return Reach::Never,
        Some(&(t, e)) if e <= target => return Reach::Before(t),
        _ => {}
    }
    for w in points.windows(2) {
        let ((t0, e0), (t1, e1)) = (w[0], w[1]);
        if e0 > target && e1 <= target {
            let f = (target.ln() - e0.ln()) / (e1.ln() - e0.ln());
            return Reach::At((t0.ln() + f * (t1.ln() - t0.ln())).exp());
        }
    }
    Reach::Never
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_to_interpolates_in_log_log_space() {
        // relMSE ∝ 1/time: 1e-1 at 1 s, 1e-3 at 100 s, so 1e-2 at 10 s.
        let points = [(1.0, 1e-1), (100.0, 1e-3)];
        match time_to(&points, 1e-2) {
            Reach::At(t) => assert!((t - 10.0).abs() < 1e-9, "{t}"),
            r => panic!("{r:?}"),
        }
        // The first crossing counts, even if noise lifts a later point.
        let points = [(1.0, 1.0), (2.0, 0.5), (4.0, 0.2), (8.0, 0.3), (16.0, 0.1)];
        match time_to(&points, 0.25) {
            Reach::At(t) => assert!(t > 2.0 && t < 4.0, "{t}"),
            r => panic!("{r:?}"),
        }
        assert_eq!(time_to(&points, 2.0), Reach::Before(1.0));
        assert_eq!(time_to(&points, 0.01), Reach::Never);
        assert_eq!(time_to(&[], 0.01), Reach::Never);
    }

    fn scene() -> Scene {
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
            Path::new("t.toml"),
        )
        .unwrap()
    }

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
    }

    #[test]
    fn the_conclusion_ranks_settings_by_the_time_to_reach_the_target() {
        let s = scene();
        let settings = enumerate(
            &s,
            &[BackendKind::Rust],
            &[Vary::Nee],
            &[],
            BuildOptions::default(),
        );
        // relMSE = 0.1 / time for NEE on, 0.3 / time for NEE off: the target
        // 1e-2 is reached at 10 s and 30 s.
        let rows = [(0, 0.1), (1, 0.3)]
            .into_iter()
            .flat_map(|(setting, c)| {
                [(1u32, 1.0), (100, 100.0)].map(|(spp, time_s)| Row {
                    setting,
                    spp,
                    build_s: 0.0,
                    time_s,
                    rmse: 0.0,
                    rel_mse: c / time_s,
                    mean_bias: 0.0,
                    efficiency: 1.0 / c,
                })
            })
            .collect();
        let report = Report {
            scene: "t.toml".into(),
            width: 4,
            height: 4,
            threads: 1,
            seed: 0,
            reference: "a file".into(),
            target_rel_mse: 1e-2,
            settings,
            rows,
        };
        assert_eq!(
            report.conclusion(),
            "fastest to relMSE 1e-2: rust / NEE on in 10.000 s; rust / NEE off 3.00x as long"
        );
        let md = report.markdown();
        assert!(md.contains("| rust / NEE off | 30.000 s | 3.00× |"), "{md}");
        assert!(md.contains("Point lights cannot be hit"), "{md}");
    }

    #[test]
    fn nee_off_samples_no_emitter_and_nee_on_every_one_but_planes() {
        let mut s = scene();
        set_nee(&mut s, true);
        assert!(s.shapes[0].nee && !s.shapes[1].nee);
        assert!(s.lights.is_sampled(0) && !s.lights.is_sampled(1));
        set_nee(&mut s, false);
        assert!(!s.shapes[0].nee && s.lights.is_empty());
    }
}
