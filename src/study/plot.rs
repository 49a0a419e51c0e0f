//! Log-log plots of a study's error against render time, one curve per
//! setting, as PNG and SVG.
//!
//! plotters rasterises the PNG's text itself (its `ab_glyph` feature) with a
//! font compiled into luz, a subset of DejaVu Sans
//! (`DejaVuSans-LICENSE.txt`), so neither fontconfig nor any system font is
//! needed; its pixels are encoded by the `image` crate luz already has,
//! rather than plotters' own encoder, which pulls in a second `image`.

use super::{Report, StudyError};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

const FONT: &[u8] = include_bytes!("DejaVuSans-subset.ttf");
const SIZE: (u32, u32) = (900, 600);

/// Tableau's ten colours: distinct for the usual handful of settings.
const COLOURS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    RelMse,
    Rmse,
}

impl Metric {
    /// The plot's file name, without extension.
    pub fn file_stem(self) -> &'static str {
        match self {
            Self::RelMse => "relmse",
            Self::Rmse => "rmse",
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::RelMse => "relMSE",
            Self::Rmse => "RMSE",
        }
    }

    fn of(self, row: &super::Row) -> f64 {
        match self {
            Self::RelMse => row.rel_mse,
            Self::Rmse => row.rmse,
        }
    }
}

/// Writes `dir/<metric>.png` and `dir/<metric>.svg`.
pub fn error_against_time(report: &Report, metric: Metric, dir: &Path) -> Result<(), StudyError> {
    register_font();
    let png = dir.join(format!("{}.png", metric.file_stem()));
    let plot_error = |path: &Path, e: &dyn std::fmt::Display| StudyError::Plot {
        path: path.to_path_buf(),
        message: e.to_string(),
    };

    let mut pixels = vec![0u8; SIZE.0 as usize * SIZE.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
        draw(&root, report, metric).map_err(|e| plot_error(&png, &e))?;
        root.present().map_err(|e| plot_error(&png, &e))?;
    }
    image::save_buffer(
        &png,
        &pixels,
        SIZE.0,
        SIZE.1,
        image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| plot_error(&png, &e))?;

    let svg = dir.join(format!("{}.svg", metric.file_stem()));
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, SIZE).into_drawing_area();
        draw(&root, report, metric).map_err(|e| plot_error(&svg, &e))?;
        root.present().map_err(|e| plot_error(&svg, &e))?;
    }
    std::fs::write(&svg, text).map_err(|source| StudyError::Write { path: svg, source })
}

fn register_font() {
    static DONE: OnceLock<()> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .unwrap_or_else(|_| panic!("the embedded font is a valid TrueType font"));
    });
}

type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    report: &Report,
    metric: Metric,
) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    // Log axes: only positive, finite values can be drawn.
    let points = |i: usize| -> Vec<(f64, f64)> {
        report
            .series(i)
            .map(|r| (r.time_s, metric.of(r)))
            .filter(|&(t, e)| t > 0.0 && e > 0.0 && t.is_finite() && e.is_finite())
            .collect()
    };
    let all: Vec<(f64, f64)> = (0..report.settings.len()).flat_map(points).collect();
    let target = (metric == Metric::RelMse).then_some(report.target_rel_mse);
    let range = |values: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        if lo.is_finite() {
            (lo / 1.5, hi * 1.5)
        } else {
            (1e-3, 1.0)
        }
    };
    let (x0, x1) = range(&mut all.iter().map(|p| p.0));
    let (y0, y1) = range(&mut all.iter().map(|p| p.1).chain(target));

    let caption = format!(
        "{}: {} against render time ({}x{}, {} threads)",
        report.scene,
        metric.name(),
        report.width,
        report.height,
        report.threads
    );
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 20))
        .margin(16)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("render time (s)")
        .y_desc(metric.name())
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()?;

    if let Some(target) = target {
        let grey = RGBColor(90, 90, 90);
        chart
            .draw_series(DashedLineSeries::new(
                [(x0, target), (x1, target)],
                6,
                4,
                grey.stroke_width(1),
            ))?
            .label(format!("target relMSE {target:e}"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], grey.stroke_width(1)));
    }
    for (i, setting) in report.settings.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let series = points(i);
        chart
            .draw_series(LineSeries::new(series.clone(), colour.stroke_width(2)))?
            .label(setting.label.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(2)));
        chart.draw_series(
            series
                .into_iter()
                .map(|p| Circle::new(p, 3, colour.filled())),
        )?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
}

/// Tick labels: plain numbers where they are short, powers of ten elsewhere.
fn tick(v: &f64) -> String {
    let a = v.abs();
    if (1e-2..1e4).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        format!("{v:.0e}")
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn ticks_are_short() {
        assert_eq!(super::tick(&2.0), "2");
        assert_eq!(super::tick(&0.25), "0.25");
        assert_eq!(super::tick(&1e-3), "1e-3");
        assert_eq!(super::tick(&1e5), "1e5");
    }
}
