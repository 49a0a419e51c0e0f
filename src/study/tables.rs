//! The study's tables: every render as CSV, and the Markdown summary that
//! ranks the settings.

use super::settings::{on_off, sampling_name};
use super::{Reach, Report};
use crate::accel::BackendKind;
use std::fmt::Write as _;

/// The CSV's columns, in order.
pub const CSV_COLUMNS: [&str; 17] = [
    "setting",
    "backend",
    "nee",
    "russian_roulette",
    "max_depth",
    "sampler",
    "sampling",
    "embree_quality",
    "embree_robust",
    "spp",
    "time_s",
    "build_s",
    "rmse",
    "rel_mse",
    "estimated_rel_mse",
    "mean_bias",
    "efficiency",
];

impl Report {
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
                "{},{},{},{},{},{},{},{quality},{robust},{},{},{},{},{},{},{},{}",
                t.label,
                t.backend.name(),
                t.nee.map_or("scene", on_off),
                on_off(t.russian_roulette),
                t.max_depth,
                t.sampler.name(),
                sampling_name(t.adaptive),
                r.spp,
                r.time_s,
                r.build_s,
                r.rmse,
                r.rel_mse,
                r.estimated_rel_mse,
                r.mean_bias,
                r.efficiency
            );
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
}

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}
