//! The `swarm sweep-seeds` picture: one panel per headline metric, each run a dot (spread along
//! x in seed order so none hides another), the mean as a line and its 95 % interval as a band;
//! the success rate's Wilson interval in the title. SVG and PNG, drawn with plotters and the
//! embedded font, like every figure of [`swarm_plot`] (no system font needed).

use super::{Report, METRICS};
use crate::stats::mean_pm;
use anyhow::Result;
use std::path::Path;
use swarm_plot::plotters::coord::Shift;
use swarm_plot::plotters::prelude::*;
use swarm_plot::{write_pair, DrawResult, Figure, FAMILY};

/// Picture size [px]: five panels a row.
const SIZE: (u32, u32) = (1500, 700);

/// Panels per row.
const COLUMNS: usize = 5;

/// Writes the picture of `report` to `svg` and `png`.
pub fn write(report: &Report, svg: &Path, png: &Path) -> Result<()> {
    write_pair(&SweepChart(report), svg, png)
}

struct SweepChart<'a>(&'a Report);

impl Figure for SweepChart<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        draw(root, self.0)
    }
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, report: &Report) -> DrawResult<DB> {
    let s = &report.success;
    let title = format!(
        "{} ({}), {} seeds: success {}/{} (95 % Wilson {:.0}–{:.0} %); mean and 95 % CI per metric",
        report.scenario,
        report.localization,
        report.runs.len(),
        s.k,
        s.n,
        100.0 * s.lo,
        100.0 * s.hi
    );
    let root = root.titled(&title, (FAMILY, 20))?;
    let rows = METRICS.len().div_ceil(COLUMNS);
    for (i, area) in root.split_evenly((rows, COLUMNS)).iter().enumerate().take(METRICS.len()) {
        panel(area, report, i)?;
    }
    Ok(())
}

/// A panel's y range: from 0 (every metric is a count, a time or a distance) unless a value is
/// below it, to above every value and the 95 % band, so the band never fills the panel; a
/// metric that is 0 in every run gets 0 to 1 (not ±0.001).
fn y_range(values: impl Iterator<Item = f64>, mean: f64, half_width: f64) -> (f64, f64) {
    let mut lo: f64 = 0.0;
    let mut hi: f64 = f64::NEG_INFINITY;
    for v in values.chain([mean - half_width, mean + half_width]).filter(|v| v.is_finite()) {
        (lo, hi) = (lo.min(v), hi.max(v));
    }
    if !hi.is_finite() || hi - lo < 1e-9 {
        return (lo, lo + 1.0);
    }
    (lo - if lo < 0.0 { 0.1 * (hi - lo) } else { 0.0 }, hi + 0.1 * (hi - lo))
}

/// The panel of metric `i`.
fn panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, report: &Report, i: usize) -> DrawResult<DB> {
    let stats = &report.metrics[i].stats;
    let values: Vec<(usize, f64)> =
        report.runs.iter().enumerate().map(|(k, r)| (k, r.values[i])).filter(|(_, v)| v.is_finite()).collect();
    let (y0, y1) = y_range(values.iter().map(|v| v.1), stats.mean, stats.half_width);
    let n = report.runs.len().max(1) as f64;
    let mut chart = ChartBuilder::on(area)
        .caption(METRICS[i].label, (FAMILY, 14))
        .margin(8)
        .x_label_area_size(24)
        .y_label_area_size(52)
        .build_cartesian_2d(0.0..1.0, y0..y1)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .x_desc(format!("runs in seed order; {}", mean_pm(stats)))
        .y_label_formatter(&swarm_plot::tick)
        .label_style((FAMILY, 12))
        .draw()?;
    if stats.half_width.is_finite() {
        let band = [(0.05, stats.mean - stats.half_width), (0.95, stats.mean + stats.half_width)];
        chart.draw_series(std::iter::once(Rectangle::new(band, RGBColor(31, 119, 180).mix(0.2).filled())))?;
    }
    if stats.mean.is_finite() {
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(0.05, stats.mean), (0.95, stats.mean)],
            RGBColor(31, 119, 180).stroke_width(2),
        )))?;
    }
    let x = |k: usize| 0.1 + 0.8 * (k as f64 + 0.5) / n;
    chart.draw_series(values.iter().map(|&(k, v)| Circle::new((x(k), v), 3, BLACK.filled())))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_fits_the_axis_from_zero_and_all_zero_counts_get_a_unit_range() {
        let (lo, hi) = y_range([10.0, 12.0].into_iter(), 11.0, 5.0);
        assert_eq!(lo, 0.0);
        assert!(hi > 16.0, "the band's top is inside: {hi}");
        assert_eq!(y_range([0.0, 0.0].into_iter(), 0.0, 0.0), (0.0, 1.0));
        assert!(y_range([-1.0, 1.0].into_iter(), 0.0, 0.5).0 < -1.0);
    }
}
