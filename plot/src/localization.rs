//! `localization.svg` / `localization.png`: above, the localization error over sim time (each
//! agent's mean distance between its neighbour estimates and the truth at that tick, in its
//! body frame); below, the neighbour count each agent holds (seed 000 6.1 reports both: mean
//! error 0.052 m, the neighbour count stable 89 % of the time). Each panel shows the swarm's
//! median over its agents and the band of their 10th to 90th percentiles, readable at any swarm
//! size; each agent's own line only on request (`swarm plot --per-uav`).

use super::data::Run;
use super::style::{beside_legend, color, legend_strip, segments, time_chart, y_top, DrawResult, Figure, FAMILY};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::collections::BTreeMap;
use swarm_types::UavId;

/// Picture size [px].
const SIZE: (u32, u32) = (1000, 680);

/// The localization figure; `per_uav` adds each agent's own line.
pub struct LocalizationFigure<'a> {
    /// The run.
    pub run: &'a Run,
    /// Draw each agent's line too.
    pub per_uav: bool,
}

impl Figure for LocalizationFigure<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let run = self.run;
        let area = root.titled(&format!("{}: localization", run.title), (FAMILY, 18))?;
        let (top, bottom) = area.split_vertically(area.dim_in_pixel().1 / 2);
        let error = "localization error (each agent's mean over its estimates)";
        panel(&top, run, error, "error [m]", &run.loc_error, self.per_uav)?;
        let counts: BTreeMap<UavId, Vec<(f64, f64)>> =
            run.states.iter().map(|(&id, s)| (id, s.iter().map(|s| (s.t_s, s.neighbours)).collect())).collect();
        panel(&bottom, run, "neighbours each agent holds an estimate of", "neighbours", &counts, self.per_uav)
    }
}

/// At each sim time (times matched to the millisecond): the 10th, 50th and 90th percentiles
/// over the series' finite values.
fn quantiles_by_time(series: &BTreeMap<UavId, Vec<(f64, f64)>>) -> Vec<(f64, [f64; 3])> {
    let mut at: BTreeMap<i64, (f64, Vec<f64>)> = BTreeMap::new();
    for &(t, v) in series.values().flatten().filter(|p| p.1.is_finite()) {
        at.entry((t * 1000.0).round() as i64).or_insert((t, Vec::new())).1.push(v);
    }
    at.into_values()
        .map(|(t, mut vs)| {
            vs.sort_by(f64::total_cmp);
            let q = |p: f64| vs[((vs.len() - 1) as f64 * p).round() as usize];
            (t, [q(0.1), q(0.5), q(0.9)])
        })
        .collect()
}

/// The swarm's median in black over the band of its agents' 10th-90th percentiles (and, with
/// `per_uav`, one thin line per agent), the legend beside the plot.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    run: &Run,
    caption: &str,
    y_label: &str,
    series: &BTreeMap<UavId, Vec<(f64, f64)>>,
    per_uav: bool,
) -> DrawResult<DB> {
    let (plot, strip) = beside_legend(area);
    let q = quantiles_by_time(series);
    let y_hi =
        y_top(q.iter().map(|(_, v)| v[2]).chain(series.values().flatten().map(|p| p.1).filter(|_| per_uav)), 0.1);
    let mut chart = time_chart(&plot, caption, y_label, run.t_end(), y_hi)?;
    let band = RGBColor(70, 130, 180);
    let mut outline: Vec<(f64, f64)> = q.iter().map(|&(t, v)| (t, v[2])).collect();
    outline.extend(q.iter().rev().map(|&(t, v)| (t, v[0])));
    if outline.len() > 2 {
        chart.draw_series(std::iter::once(Polygon::new(outline, band.mix(0.25).filled())))?;
    }
    let mut entries = vec![("10th-90th percentile".to_string(), band.mix(0.5).stroke_width(8))];
    if per_uav {
        for (i, (id, pts)) in series.iter().enumerate() {
            let c = color(i);
            chart.draw_series(LineSeries::new(
                pts.iter().copied().filter(|p| p.1.is_finite()),
                c.mix(0.6).stroke_width(1),
            ))?;
            if series.len() <= 10 {
                entries.push((format!("UAV {id}"), c.stroke_width(1)));
            }
        }
    }
    chart.draw_series(segments(q.iter().map(|&(t, v)| (t, v[1])).collect(), BLACK.stroke_width(2)))?;
    entries.push((format!("median of {} UAVs", series.len()), BLACK.stroke_width(2)));
    legend_strip(&strip, &entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_quantiles_match_times_to_the_millisecond() {
        let s: BTreeMap<UavId, Vec<(f64, f64)>> =
            [(1, vec![(0.1, 1.0), (0.2, 2.0)]), (2, vec![(0.1000001, 3.0), (0.3, f64::NAN)]), (3, vec![(0.1, 2.0)])]
                .map(|(id, v)| (UavId::new(id), v))
                .into();
        assert_eq!(quantiles_by_time(&s), vec![(0.1, [1.0, 2.0, 3.0]), (0.2, [2.0, 2.0, 2.0])]);
    }
}
