//! `localization.svg` / `localization.png`: above, each agent's localization error over sim time
//! (the mean distance between its neighbour estimates and the truth at that tick, in its body
//! frame) and the swarm's mean; below, each agent's neighbour count and the swarm's mean (seed
//! 000 6.1 reports both: mean error 0.052 m, the neighbour count stable 89 % of the time).

use super::data::Run;
use super::style::{beside_legend, color, legend_strip, segments, time_chart, y_top, DrawResult, Figure, FAMILY};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::collections::BTreeMap;

/// Picture size [px].
const SIZE: (u32, u32) = (1000, 680);

/// The localization figure.
pub struct LocalizationFigure<'a>(pub &'a Run);

impl Figure for LocalizationFigure<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let run = self.0;
        let area = root.titled(&format!("{}: localization", run.title), (FAMILY, 18))?;
        let (top, bottom) = area.split_vertically(area.dim_in_pixel().1 / 2);
        panel(&top, run, "localization error (mean over each agent's estimates)", "[m]", &run.loc_error)?;
        let counts: BTreeMap<u32, Vec<(f64, f64)>> =
            run.states.iter().map(|(&id, s)| (id, s.iter().map(|s| (s.t_s, s.neighbours)).collect())).collect();
        panel(&bottom, run, "neighbours each agent holds an estimate of", "neighbours", &counts)
    }
}

/// The mean over the series at each sim time (times matched to the millisecond).
fn mean_by_time(series: &BTreeMap<u32, Vec<(f64, f64)>>) -> Vec<(f64, f64)> {
    let mut at: BTreeMap<i64, (f64, f64, u32)> = BTreeMap::new();
    for &(t, v) in series.values().flatten().filter(|p| p.1.is_finite()) {
        let e = at.entry((t * 1000.0).round() as i64).or_insert((t, 0.0, 0));
        e.1 += v;
        e.2 += 1;
    }
    at.values().map(|&(t, sum, n)| (t, sum / f64::from(n))).collect()
}

/// One thin line per agent and the swarm's mean in black, the legend beside the plot.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    run: &Run,
    caption: &str,
    y_label: &str,
    series: &BTreeMap<u32, Vec<(f64, f64)>>,
) -> DrawResult<DB> {
    let (plot, strip) = beside_legend(area);
    let y_hi = y_top(series.values().flatten().map(|p| p.1), 0.1);
    let mut chart = time_chart(&plot, caption, y_label, run.t_end(), y_hi)?;
    let mut entries = Vec::new();
    for (i, (id, pts)) in series.iter().enumerate() {
        let c = color(i);
        chart.draw_series(LineSeries::new(
            pts.iter().copied().filter(|p| p.1.is_finite()),
            c.mix(0.7).stroke_width(1),
        ))?;
        if series.len() <= 10 {
            entries.push((format!("UAV {id}"), c.stroke_width(1)));
        }
    }
    chart.draw_series(segments(mean_by_time(series), BLACK.stroke_width(2)))?;
    entries.push(("mean over the swarm".to_string(), BLACK.stroke_width(2)));
    legend_strip(&strip, &entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_matches_times_to_the_millisecond() {
        let s: BTreeMap<u32, Vec<(f64, f64)>> =
            [(1, vec![(0.1, 1.0), (0.2, 2.0)]), (2, vec![(0.1000001, 3.0), (0.3, f64::NAN)])].into();
        assert_eq!(mean_by_time(&s), vec![(0.1, 2.0), (0.2, 2.0)]);
    }
}
