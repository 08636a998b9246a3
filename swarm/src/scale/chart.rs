//! The `swarm scale` picture: x real time (left) and resident memory per UAV (right) against the
//! UAV count on a log axis, one line per localization mode, as SVG and PNG, drawn like every
//! figure of [`swarm_plot`] (plotters, the embedded font).

use super::ScaleRow;
use anyhow::Result;
use std::collections::BTreeMap;
use std::path::Path;
use swarm_plot::plotters::coord::Shift;
use swarm_plot::plotters::prelude::*;
use swarm_plot::{color, write_pair, DrawResult, Figure, FAMILY};

/// Picture size [px].
const SIZE: (u32, u32) = (1200, 520);

/// Writes the picture of `rows` to `svg` and `png`.
pub fn write(rows: &[ScaleRow], svg: &Path, png: &Path) -> Result<()> {
    write_pair(&ScaleChart(rows), svg, png)
}

struct ScaleChart<'a>(&'a [ScaleRow]);

impl Figure for ScaleChart<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let root = root.titled("swarm scale: the full stack as the swarm grows", (FAMILY, 22))?;
        let (left, right) = root.split_horizontally(SIZE.0 / 2);
        panel(&left, self.0, "x real time", "sim s per wall s", |r| r.x_real_time)?;
        panel(&right, self.0, "resident memory per UAV", "MiB per UAV (peak, all processes)", |r| r.rss_per_uav_mib)
    }
}

/// Points `(UAVs, value)` per localization mode, in UAV order.
fn series(rows: &[ScaleRow], value: fn(&ScaleRow) -> f64) -> BTreeMap<&str, Vec<(f64, f64)>> {
    let mut by_mode: BTreeMap<&str, Vec<(f64, f64)>> = BTreeMap::new();
    for r in rows.iter().filter(|r| value(r).is_finite()) {
        by_mode.entry(r.localization.as_str()).or_default().push((r.uavs as f64, value(r)));
    }
    by_mode.values_mut().for_each(|v| v.sort_by(|a, b| a.0.total_cmp(&b.0)));
    by_mode
}

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    rows: &[ScaleRow],
    caption: &str,
    y_label: &str,
    value: fn(&ScaleRow) -> f64,
) -> DrawResult<DB> {
    let lines = series(rows, value);
    let named: Vec<(&str, &[(f64, f64)])> = lines.iter().map(|(mode, pts)| (*mode, pts.as_slice())).collect();
    by_uavs(area, &named, caption, y_label, 1e-3)
}

/// One panel: each named line's points `(UAVs, value)` against the UAV count on a log axis, the
/// value axis from 0 to 15 % above the largest value and at least to `y_top`. The UAV axis is
/// labelled only at the sizes drawn: a log axis's own key points crowd each other near 1000.
/// `swarm mesh --sizes` draws its panels with it too.
pub(crate) fn by_uavs<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    lines: &[(&str, &[(f64, f64)])],
    caption: &str,
    y_label: &str,
    y_top: f64,
) -> DrawResult<DB> {
    let sizes: Vec<f64> = lines.iter().flat_map(|(_, p)| p.iter().map(|q| q.0)).collect();
    let (x_lo, x_hi) = sizes.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), &x| (lo.min(x), hi.max(x)));
    let (x_lo, x_hi) = if x_lo.is_finite() { (x_lo / 1.5, x_hi * 1.5) } else { (1.0, 10.0) };
    let y_hi = (lines.iter().flat_map(|(_, p)| p.iter().map(|q| q.1)).fold(0.0_f64, f64::max) * 1.15).max(y_top);
    let label = |v: &f64| {
        if sizes.iter().any(|s| (s - v).abs() < 1e-6 * s.max(1.0)) {
            format!("{v:.0}")
        } else {
            String::new()
        }
    };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FAMILY, 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((x_lo..x_hi).log_scale(), 0.0..y_hi)?;
    chart.configure_mesh().x_desc("UAVs").y_desc(y_label).x_label_formatter(&label).label_style((FAMILY, 13)).draw()?;
    for (i, (name, pts)) in lines.iter().enumerate() {
        let c = color(i);
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
    }
    chart.configure_series_labels().label_font((FAMILY, 13)).background_style(WHITE.mix(0.8)).border_style(BLACK).draw()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_an_svg_with_text_and_a_png() {
        let row = |uavs: usize, mode: &str, x: f64| ScaleRow { x_real_time: x, ..crate::scale::test_row(uavs, mode) };
        let rows = [
            row(5, "broadcast", 40.0),
            row(40, "broadcast", 8.0),
            row(40, "icp", 2.0),
            row(1000, "broadcast", f64::NAN),
        ];
        let dir = std::env::temp_dir().join(format!("scale-chart-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let (svg, png) = (dir.join("s.svg"), dir.join("s.png"));
        write(&rows, &svg, &png).expect("draws");
        let text = std::fs::read_to_string(&svg).expect("svg written");
        assert!(text.contains("resident memory per UAV") && text.contains("icp"), "captions and legend are in the SVG");
        let bytes = std::fs::read(&png).expect("png written");
        assert_eq!(&bytes[1..4], b"PNG");
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(
            series(&rows, |r| r.x_real_time)["broadcast"],
            vec![(5.0, 40.0), (40.0, 8.0)],
            "NaN points are left out"
        );
    }
}
