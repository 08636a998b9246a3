//! The studies' charts (`swarm sweep-error`'s `sweep.svg`): curves over a shared x axis, y from
//! 0, with an optional red dashed threshold line.

use super::style::{color, legend, range, svg_string, tick, y_top, DrawResult, Figure, FAMILY};
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Picture size [px].
const SIZE: (u32, u32) = (960, 460);

/// One curve of a [`line_chart`].
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// `(x, y)` points; non-finite ones are skipped.
    pub points: Vec<[f64; 2]>,
    /// Drawn dashed.
    pub dashed: bool,
}

struct LineChart<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    series: &'a [Series],
    threshold: Option<f64>,
}

impl LineChart<'_> {
    fn points(&self) -> impl Iterator<Item = &[f64; 2]> + '_ {
        self.series.iter().flat_map(|c| &c.points).filter(|p| p[0].is_finite() && p[1].is_finite())
    }
}

impl Figure for LineChart<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let x_hi = range(self.points().map(|p| p[0])).map_or(1.0, |(_, hi)| hi.max(1.0));
        let y_hi = y_top(self.points().map(|p| p[1]).chain(self.threshold), 1.0);
        let mut chart = ChartBuilder::on(root)
            .caption(self.title, (FAMILY, 16))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(0.0..x_hi, 0.0..y_hi)?;
        chart
            .configure_mesh()
            .x_desc(self.x_label)
            .y_desc(self.y_label)
            .label_style((FAMILY, 12))
            .max_light_lines(0)
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .draw()?;
        if let Some(t) = self.threshold {
            chart.draw_series(DashedLineSeries::new([(0.0, t), (x_hi, t)], 6, 4, RED.stroke_width(1)))?;
        }
        for (i, c) in self.series.iter().enumerate() {
            let (col, pts) =
                (color(i), c.points.iter().filter(|p| p[0].is_finite() && p[1].is_finite()).map(|p| (p[0], p[1])));
            let style = col.stroke_width(2);
            let drawn = if c.dashed {
                chart.draw_series(DashedLineSeries::new(pts.collect::<Vec<_>>(), 8, 4, style))?
            } else {
                chart.draw_series(LineSeries::new(pts, style))?
            };
            drawn.label(&c.label).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
        }
        legend(&mut chart)
    }
}

/// The chart of `series` as SVG text.
pub fn line_chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    threshold: Option<f64>,
) -> Result<String> {
    svg_string(&LineChart { title, x_label, y_label, series, threshold })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_chart_draws_every_series_and_the_threshold() {
        let series = [
            Series { label: "a".into(), points: vec![[0.0, 1.0], [2.0, 3.0]], dashed: false },
            Series { label: "b <x>".into(), points: vec![[0.0, 2.0], [1.0, f64::NAN], [2.0, 1.0]], dashed: true },
        ];
        let svg = line_chart("t", "δa [m]", "[m]", &series, Some(0.6)).expect("draws");
        assert!(svg.contains("b &lt;x&gt;") && svg.contains("δa [m]"), "legend and axis text, escaped");
        assert!(svg.contains("#FF0000"), "the threshold in red");
        assert!(!svg.contains("NaN"), "non-finite points are skipped");
    }
}
