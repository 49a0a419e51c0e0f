//! A finished study's measurements, and what they say: the time each
//! setting takes to reach the target relMSE, the ranking and its one-line
//! conclusion, and the files written from them.

use super::settings::Setting;
use super::{plot, StudyError};
use std::fmt::Write as _;
use std::path::Path;

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
    /// The relMSE the render's own samples estimate (see
    /// [`crate::render::film::Film::error_estimate`]).
    pub estimated_rel_mse: f64,
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

    /// Settings by the time they take to reach the target relMSE, fastest
    /// first; those that never reach it last.
    pub(super) fn ranking(&self) -> Vec<(usize, Reach)> {
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
    use crate::accel::{BackendKind, BuildOptions};
    use crate::study::settings::{enumerate, Vary};
    use crate::study::test_scene as scene;

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
                    estimated_rel_mse: c / time_s,
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
}
