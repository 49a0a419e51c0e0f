//! Running a study: the checked plan, the reference, and the timed sweep of
//! renders each compared with it.

use super::settings::{self, Setting};
use super::{ReferenceSource, Report, Row, StudyError, StudyOptions, REFERENCE_SPP_FACTOR};
use crate::accel::{BackendKind, BuildOptions};
use crate::geometry::Geometry;
use crate::image::io::{self as imageio, WriteOptions};
use crate::image::{metrics, Image};
use crate::render::{
    build_accel, render_with, IntegratorSettings, Progress, RenderOptions, Sampling,
};
use crate::scene::Scene;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

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
        let (backends, settings) = settings::plan(
            &scene,
            &options.backends,
            options.vary,
            options.max_depths,
            options.build,
        )?;
        let reference = Reference::plan(&scene, options.reference, &spp, backends[0])?;
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
            let accel = build_accel(&scene, setting.backend, &setting.build)?;
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
                    sampling: if setting.adaptive {
                        Sampling::Budget { spp }
                    } else {
                        Sampling::Uniform
                    },
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
                    estimated_rel_mse: film.error_estimate().rel_mse,
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
        let accel = build_accel(&scene, r.backend, &self.build)?;
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

impl Reference {
    /// Reads the reference file `source` names, or plans its render at
    /// `backend` for the sample counts `spp` (sorted, not empty).
    fn plan(
        scene: &Scene,
        source: ReferenceSource,
        spp: &[u32],
        backend: BackendKind,
    ) -> Result<Self, StudyError> {
        let invalid = |m: String| Err(StudyError::Invalid(m));
        let (width, height) = (scene.camera.width, scene.camera.height);
        Ok(match source {
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
                    backend,
                    save,
                })
            }
        })
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::test_scene as scene;

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
