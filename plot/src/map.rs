//! `run.svg` / `run.png`: the picture of a run. Left, the map: trees, walls, the goal disc (whole,
//! inside the map), each UAV's path from its start (circle) to its end (triangle), where a UAV
//! froze or its agent was killed (square), collisions (red crosses). Right, over sim time, each
//! UAV's distance to the nearest obstacle surface and to the nearest other UAV (seed 000 Figs.
//! 6.5 and 6.6), with the contact distance and the separation invariant as dashed lines, and
//! the network's faults behind: spans where some link is cut shaded, each failure a dashed line.

use super::connectivity::{spans, CUT, IMPAIRED};
use super::data::{Pose, Run};
use super::style::{color, legend, thin_keeping_minima, tick, time_chart, DrawResult, Figure, FAMILY};
use plotters::coord::Shift;
use plotters::prelude::*;
use swarm_types::UavId;

/// Picture size [px]; the map takes the left [`MAP_W`].
const SIZE: (u32, u32) = (1400, 680);
const MAP_W: u32 = 760;
/// Layout of the map chart [px], to give it equal scales on both axes.
const MARGIN: u32 = 10;
const X_LABELS: u32 = 36;
const Y_LABELS: u32 = 50;
const TITLE_H: u32 = 34;
/// Free space around the paths and the goal [m].
const BORDER_M: f64 = 4.0;
/// Distances above this are cut off in the time panels [m] (far from anything is not news).
const DISTANCE_CAP_M: f64 = 15.0;
/// Points per distance curve at most (thinned keeping the minima).
const MAX_POINTS: usize = 1500;
/// Paths are named in a legend up to this many UAVs.
const LEGEND_MAX: usize = 10;

const TREE: RGBColor = RGBColor(91, 70, 54);
const GOAL: RGBColor = RGBColor(44, 160, 44);

/// The palette's entry that reads as the trees' brown, skipped for paths.
const BROWN: usize = 5;

/// The colour of the `i`th path: the palette without its brown (the trees' colour).
fn path_color(i: usize) -> RGBColor {
    let k = i % 9;
    color(if k >= BROWN { k + 1 } else { k })
}

/// The run figure.
pub struct RunFigure<'a>(pub &'a Run);

impl Figure for RunFigure<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = root.titled(&self.0.title, (FAMILY, 18))?;
        let (left, right) = area.split_horizontally(MAP_W);
        map(&left, self.0)?;
        let (top, bottom) = right.split_vertically((SIZE.1 - TITLE_H) / 2);
        let radius = self.0.world.as_ref().map(|w| w.body_radius_m);
        // Contact with an obstacle: the surface within a body radius of the centre.
        let obstacle_lines: Vec<(f64, &str)> = radius.map(|r| (r, "contact")).into_iter().collect();
        distances(&top, self.0, "distance to the nearest obstacle surface", |p| p.obstacle_m, &obstacle_lines)?;
        // Between UAVs: contact at two radii, and the run's separation invariant.
        let mut uav_lines: Vec<(f64, &str)> = radius.map(|r| (2.0 * r, "contact")).into_iter().collect();
        uav_lines.extend(self.0.min_separation_m.map(|m| (m, "separation invariant")));
        distances(&bottom, self.0, "distance to the nearest other UAV", |p| p.agent_m, &uav_lines)
    }
}

/// The map's bounds `(x, y)`: every path and the goal plus a border, the shorter side grown so
/// both axes have the same scale.
fn bounds(run: &Run) -> ((f64, f64), (f64, f64)) {
    // The goal disc whole, not only its centre.
    let r = run.goal_radius_m.max(0.0);
    let goal =
        run.world.as_ref().map_or(Vec::new(), |w| vec![(w.goal[0] - r, w.goal[1] - r), (w.goal[0] + r, w.goal[1] + r)]);
    let pts = run.tracks.values().flatten().map(|p| (p.x_m, p.y_m)).chain(goal);
    let (x0, x1, y0, y1) = pts
        .fold((f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY), |b, (x, y)| {
            (b.0.min(x), b.1.max(x), b.2.min(y), b.3.max(y))
        });
    let (x0, x1, y0, y1) = if x0.is_finite() { (x0, x1, y0, y1) } else { (0.0, 1.0, 0.0, 1.0) };
    let px_w = f64::from(MAP_W - 2 * MARGIN - Y_LABELS);
    let px_h = f64::from(SIZE.1 - TITLE_H - 2 * MARGIN - X_LABELS);
    let (w, h) = (x1 - x0 + 2.0 * BORDER_M, y1 - y0 + 2.0 * BORDER_M);
    let m_per_px = (w / px_w).max(h / px_h);
    let (half_w, half_h) = (m_per_px * px_w / 2.0, m_per_px * px_h / 2.0);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    ((cx - half_w, cx + half_w), (cy - half_h, cy + half_h))
}

/// A disc as a polygon of `n` corners in data coordinates (so its radius scales with the axes).
fn disc(cx: f64, cy: f64, r: f64, n: u32) -> Vec<(f64, f64)> {
    (0..n)
        .map(|k| f64::from(k) * std::f64::consts::TAU / f64::from(n))
        .map(|a| (cx + r * a.cos(), cy + r * a.sin()))
        .collect()
}

/// A wall `[x1, y1, x2, y2, thickness]` as a rectangle, clipped to the box `b` (Liang–Barsky on
/// its centre line); `None` when it lies outside.
fn wall(w: &[f64; 5], b: ((f64, f64), (f64, f64))) -> Option<Vec<(f64, f64)>> {
    let (d_x, d_y) = (w[2] - w[0], w[3] - w[1]);
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    for (p, q) in [(-d_x, w[0] - b.0 .0), (d_x, b.0 .1 - w[0]), (-d_y, w[1] - b.1 .0), (d_y, b.1 .1 - w[1])] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else if p < 0.0 {
            t0 = t0.max(q / p);
        } else {
            t1 = t1.min(q / p);
        }
    }
    if t0 > t1 {
        return None;
    }
    let len = d_x.hypot(d_y).max(1e-9);
    let (nx, ny) = (-d_y / len * w[4] / 2.0, d_x / len * w[4] / 2.0);
    let (a, c) = ((w[0] + t0 * d_x, w[1] + t0 * d_y), (w[0] + t1 * d_x, w[1] + t1 * d_y));
    Some(vec![(a.0 + nx, a.1 + ny), (c.0 + nx, c.1 + ny), (c.0 - nx, c.1 - ny), (a.0 - nx, a.1 - ny)])
}

fn map<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, run: &Run) -> DrawResult<DB> {
    let b = bounds(run);
    let mut chart = ChartBuilder::on(area)
        .margin(MARGIN)
        .x_label_area_size(X_LABELS)
        .y_label_area_size(Y_LABELS)
        .build_cartesian_2d(b.0 .0..b.0 .1, b.1 .0..b.1 .1)?;
    chart
        .configure_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style((FAMILY, 12))
        .max_light_lines(0)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    if let Some(w) = &run.world {
        let goal = disc(w.goal[0], w.goal[1], run.goal_radius_m, 72);
        chart.draw_series([Polygon::new(goal.clone(), GOAL.mix(0.12).filled())])?;
        chart.draw_series(LineSeries::new(goal.iter().chain(goal.first()).copied(), GOAL.stroke_width(1)))?;
        let inside = |t: &&[f64; 3]| {
            t[0] + t[2] >= b.0 .0 && t[0] - t[2] <= b.0 .1 && t[1] + t[2] >= b.1 .0 && t[1] - t[2] <= b.1 .1
        };
        chart.draw_series(
            w.trees.iter().filter(inside).map(|t| Polygon::new(disc(t[0], t[1], t[2], 16), TREE.filled())),
        )?;
        chart.draw_series(
            w.walls.iter().filter_map(|wl| wall(wl, b)).map(|p| Polygon::new(p, BLACK.mix(0.8).filled())),
        )?;
    }
    for (i, (id, track)) in run.tracks.iter().enumerate() {
        let c = path_color(i);
        let s = chart.draw_series(LineSeries::new(track.iter().map(|p| (p.x_m, p.y_m)), c.stroke_width(2)))?;
        if run.tracks.len() <= LEGEND_MAX {
            s.label(format!("UAV {id}"))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        }
        if let (Some(a), Some(z)) = (track.first(), track.last()) {
            chart.draw_series([Circle::new((a.x_m, a.y_m), 4, c.filled())])?;
            chart.draw_series([TriangleMarker::new((z.x_m, z.y_m), 6, c.filled())])?;
        }
    }
    failures_on_map(&mut chart, run)?;
    chart.draw_series(run.collisions.iter().map(|p| Cross::new((p[0], p[1]), 6, RED.stroke_width(3))))?;
    if run.tracks.len() <= LEGEND_MAX {
        legend(&mut chart)?;
    }
    Ok(())
}

/// Where each failure of the timeline (a freeze, a kill) caught its UAV: a black square with
/// its name beside it.
fn failures_on_map<DB: DrawingBackend>(chart: &mut super::style::TimeChart<'_, DB>, run: &Run) -> DrawResult<DB> {
    for f in run.timeline.failures() {
        let Some(track) = run.tracks.get(&f.uav) else { continue };
        let Some(at) = track.iter().find(|p| p.t_s >= f.at_s - 1e-9).or(track.last()) else { continue };
        let name = f.kind.name();
        chart.draw_series([Rectangle::new(
            [(at.x_m - 0.3, at.y_m - 0.3), (at.x_m + 0.3, at.y_m + 0.3)],
            BLACK.stroke_width(2),
        )])?;
        chart.draw_series([Text::new(
            format!("{name} {} at {:.0} s", f.uav, f.at_s),
            (at.x_m + 0.5, at.y_m + 0.5),
            (FAMILY, 12),
        )])?;
    }
    Ok(())
}

/// One distance panel: each UAV's curve over the timeline's faults, with reference `lines`
/// (distance, name) dashed across.
fn distances<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    run: &Run,
    caption: &str,
    value: fn(&Pose) -> f64,
    lines: &[(f64, &str)],
) -> DrawResult<DB> {
    let y_hi = super::style::y_top(run.tracks.values().flatten().map(value), 1.0).min(DISTANCE_CAP_M * 1.05);
    let (t_end, y_hi) = (run.t_end(), y_hi.max(lines.iter().map(|l| l.0 * 1.2).fold(0.0, f64::max)));
    let mut chart = time_chart(area, caption, "[m]", t_end, y_hi)?;
    let ids: Vec<UavId> = run.tracks.keys().copied().collect();
    for s in spans(&run.timeline, &ids, t_end) {
        let (c, what) = match s.2 {
            netem::LinkClass::Cut => (CUT, "some link cut"),
            _ => (IMPAIRED, "some link impaired"),
        };
        chart.draw_series([Rectangle::new([(s.0, 0.0), (s.1, y_hi)], c.mix(0.12).filled())])?;
        // Named where there is room, so the shading is read without the connectivity figure.
        if s.1 - s.0 >= 0.12 * t_end {
            let at = (s.0 + 0.01 * t_end, y_hi * 0.97);
            chart.draw_series([Text::new(what, at, (FAMILY, 11).into_font().color(&c.mix(0.9)))])?;
        }
    }
    for f in run.timeline.failures().iter().filter(|f| f.at_s <= t_end) {
        chart.draw_series(DashedLineSeries::new(
            [(f.at_s, 0.0), (f.at_s, y_hi)],
            6,
            4,
            BLACK.mix(0.5).stroke_width(1),
        ))?;
    }
    for (i, track) in run.tracks.values().enumerate() {
        let pts: Vec<(f64, f64)> =
            track.iter().filter(|p| value(p).is_finite()).map(|p| (p.t_s, value(p).min(y_hi))).collect();
        chart.draw_series(LineSeries::new(thin_keeping_minima(&pts, MAX_POINTS), path_color(i).stroke_width(1)))?;
    }
    for (i, &(d, name)) in lines.iter().enumerate() {
        chart.draw_series(DashedLineSeries::new([(0.0, d), (t_end, d)], 8, 4, RED.stroke_width(1)))?;
        // Side by side, not on top of each other when two lines are close.
        let x = t_end * (0.01 + 0.3 * i as f64);
        // Just above its line (a text hangs from its anchor), not struck through by it.
        let y = d + 0.06 * y_hi;
        chart.draw_series([Text::new(format!("{name} {d:.2} m"), (x, y), (FAMILY, 11))])?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::synthetic_run_folder;

    #[test]
    fn bounds_have_equal_scales_and_hold_every_path() {
        let dir = std::env::temp_dir().join(format!("plot-map-{}", std::process::id()));
        synthetic_run_folder(&dir);
        let run = Run::read(&dir).expect("reads");
        let ((x0, x1), (y0, y1)) = bounds(&run);
        let px_w = f64::from(MAP_W - 2 * MARGIN - Y_LABELS);
        let px_h = f64::from(SIZE.1 - TITLE_H - 2 * MARGIN - X_LABELS);
        assert!(((x1 - x0) / px_w - (y1 - y0) / px_h).abs() < 1e-9, "same metres per pixel");
        assert!(x0 <= 0.2 - BORDER_M + 1e-9 && x1 >= 6.0 + BORDER_M && y0 <= 1.0 - BORDER_M && y1 >= 2.0 + BORDER_M);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn walls_are_clipped_to_the_map() {
        let b = ((0.0, 10.0), (0.0, 10.0));
        let w = wall(&[-5.0, 5.0, 5.0, 5.0, 0.2], b).expect("crosses the box");
        assert!(w.iter().all(|p| p.0 >= -1e-9 && p.0 <= 5.0 + 1e-9), "{w:?}");
        assert!(w.iter().any(|p| (p.1 - 5.1).abs() < 1e-9), "thickness across the line: {w:?}");
        assert!(wall(&[-5.0, 20.0, 5.0, 20.0, 0.2], b).is_none(), "outside");
    }
}
