//! `vectors.svg` / `vectors.png`: the K21 vector magnitudes of one UAV over sim time (seed 000
//! Figs. 6.3 and 6.4): above, cohesion, separation, avoidance and navigation (seed 000 eq. 4.1,
//! each clipped to unit length, so dimensionless); below, the command's speed, capped by the speed
//! scale kf. A term that stays 0 for the whole flight lies on the axis: its legend entry says so.
//! A failure of the UAV (freeze, kill) is a dashed line: what its agent computes after it is not
//! flown.

use super::data::{Run, VECTORS};
use super::style::{beside_legend, color, legend_strip, segments, time_chart, y_top, DrawResult, Figure, FAMILY};
use plotters::coord::Shift;
use plotters::prelude::*;
use swarm_types::UavId;

/// Picture size [px].
const SIZE: (u32, u32) = (1000, 680);

/// The vectors figure of UAV `uav`.
pub struct VectorsFigure<'a> {
    /// The run.
    pub run: &'a Run,
    /// Which UAV.
    pub uav: UavId,
}

impl Figure for VectorsFigure<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let title = format!("{}: K21 vectors of UAV {}", self.run.title, self.uav);
        let area = root.titled(&title, (FAMILY, 18))?;
        let (top, bottom) = area.split_vertically(area.dim_in_pixel().1 * 3 / 5);
        self.panel(&top, "magnitudes of the K21 vectors (seed 000 Fig. 6.3)", "magnitude (dimensionless, ≤ 1)", 0..4)?;
        self.panel(&bottom, "speed of the command (seed 000 Fig. 6.4)", "[m/s]", 4..5)
    }
}

impl VectorsFigure<'_> {
    /// One panel with the vectors `which` (indices into [`VECTORS`]).
    fn panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        caption: &str,
        y_label: &str,
        which: std::ops::Range<usize>,
    ) -> DrawResult<DB> {
        let states = self.run.states.get(&self.uav).map(Vec::as_slice).unwrap_or_default();
        let (plot, strip) = beside_legend(area);
        let y_hi = y_top(states.iter().flat_map(|s| s.vectors[which.clone()].to_vec()), 0.5);
        let mut chart = time_chart(&plot, caption, y_label, self.run.t_end(), y_hi)?;
        let mut entries = Vec::new();
        for k in which {
            let c = color(k);
            let pts: Vec<(f64, f64)> =
                states.iter().filter(|s| s.vectors[k].is_finite()).map(|s| (s.t_s, s.vectors[k])).collect();
            // A term that stays 0 lies on the axis, hidden: the legend says so.
            let zero = pts.iter().all(|p| p.1 == 0.0);
            chart.draw_series(segments(pts, c.stroke_width(2)))?;
            let label = if zero { format!("{} (0 throughout)", VECTORS[k].1) } else { VECTORS[k].1.to_string() };
            entries.push((label, c.stroke_width(2)));
        }
        // This UAV's failures (a freeze, a kill): after one, its agent's vectors are no longer
        // flown (a frozen body hovers), which the curves alone do not say.
        for f in self.run.timeline.failures().iter().filter(|f| f.uav == self.uav && f.at_s <= self.run.t_end()) {
            let name = f.kind.name();
            chart.draw_series(DashedLineSeries::new([(f.at_s, 0.0), (f.at_s, y_hi)], 6, 4, BLACK.stroke_width(1)))?;
            let note = format!("{name} at {:.0} s: not flown after", f.at_s);
            chart.draw_series([Text::new(note, (f.at_s + 0.01 * self.run.t_end(), y_hi * 0.97), (FAMILY, 11))])?;
        }
        legend_strip(&strip, &entries)
    }
}
