//! `run.svg`: the picture of a run. Left, the map: trees, walls, each UAV's path from its start
//! (circle) to its end (triangle), collisions (red crosses), the goal disc. Right, over sim time,
//! each UAV's distance to the nearest obstacle surface and to the nearest other UAV (seed 000
//! Figs. 6.5 and 6.6). Plain SVG written by hand: no plotting dependency, opens in any browser.
//! [`line_chart`] draws the studies' curves (`swarm sweep-error`) with the same axes and colours.

use std::fmt::Write as _;
use swarm_wire::TruthWorld;

/// One UAV's samples over the run.
#[derive(Debug, Clone, Default)]
pub struct Track {
    /// UAV id.
    pub id: u32,
    /// `(t_s, x_m, y_m, obstacle_distance_m, agent_distance_m)` per tick.
    pub samples: Vec<[f64; 5]>,
}

const COLORS: [&str; 10] = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];

/// A linear map from data to pixels.
#[derive(Clone, Copy)]
struct Axis {
    lo: f64,
    hi: f64,
    px_lo: f64,
    px_hi: f64,
}

impl Axis {
    fn at(&self, v: f64) -> f64 {
        self.px_lo + (v - self.lo) / (self.hi - self.lo).max(1e-9) * (self.px_hi - self.px_lo)
    }
    fn scale(&self) -> f64 {
        (self.px_hi - self.px_lo).abs() / (self.hi - self.lo).max(1e-9)
    }
}

fn color(i: usize) -> &'static str {
    COLORS[i % COLORS.len()]
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// The map bounds: every path and the goal, plus a margin; trees outside are clipped.
fn map_bounds(world: &TruthWorld, tracks: &[Track]) -> (f64, f64, f64, f64) {
    let mut b = (world.goal[0], world.goal[0], world.goal[1], world.goal[1]);
    for s in tracks.iter().flat_map(|t| &t.samples) {
        b = (b.0.min(s[1]), b.1.max(s[1]), b.2.min(s[2]), b.3.max(s[2]));
    }
    let m = 4.0;
    let (w, h) = (b.1 - b.0 + 2.0 * m, b.3 - b.2 + 2.0 * m);
    // Equal scale on both axes: grow the shorter side.
    let side = w.max(h * 1.2);
    let cx = (b.0 + b.1) / 2.0;
    let cy = (b.2 + b.3) / 2.0;
    (cx - side / 2.0, cx + side / 2.0, cy - side / 2.4, cy + side / 2.4)
}

/// Renders the whole picture.
pub fn run_svg(title: &str, world: &TruthWorld, tracks: &[Track], collisions: &[[f64; 2]], goal_radius_m: f64) -> String {
    let (w, h) = (1400.0, 650.0);
    let mut s = String::new();
    let _ = writeln!(s, r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#);
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/><text x="20" y="24" font-size="16">{}</text>"#, escape(title));
    map_panel(&mut s, world, tracks, collisions, goal_radius_m);
    let t_max = tracks.iter().flat_map(|t| t.samples.last()).map(|v| v[0]).fold(1.0, f64::max);
    series_panel(&mut s, tracks, 3, "distance to nearest obstacle surface [m]", 50.0, t_max);
    series_panel(&mut s, tracks, 4, "distance to nearest other UAV [m]", 335.0, t_max);
    legend(&mut s, tracks);
    s.push_str("</svg>\n");
    s
}

fn map_panel(s: &mut String, world: &TruthWorld, tracks: &[Track], collisions: &[[f64; 2]], goal_r: f64) {
    let (x0, x1, y0, y1) = map_bounds(world, tracks);
    let ax = Axis { lo: x0, hi: x1, px_lo: 60.0, px_hi: 760.0 };
    let ay = Axis { lo: y0, hi: y1, px_lo: 600.0, px_hi: 40.0 };
    let _ = writeln!(s, r#"<defs><clipPath id="map"><rect x="60" y="40" width="700" height="560"/></clipPath></defs>"#);
    let _ = writeln!(s, r##"<rect x="60" y="40" width="700" height="560" fill="#fbfbf7" stroke="#999"/>"##);
    axis_ticks(s, ax, ay, "x [m]", "y [m]");
    let _ = writeln!(s, r#"<g clip-path="url(#map)">"#);
    let _ = writeln!(
        s,
        r##"<circle cx="{:.1}" cy="{:.1}" r="{:.1}" fill="#2ca02c" fill-opacity="0.12" stroke="#2ca02c" stroke-dasharray="4 3"/>"##,
        ax.at(world.goal[0]),
        ay.at(world.goal[1]),
        goal_r * ax.scale()
    );
    for t in &world.trees {
        let _ = writeln!(s, r##"<circle cx="{:.1}" cy="{:.1}" r="{:.2}" fill="#5b4636"/>"##, ax.at(t[0]), ay.at(t[1]), (t[2] * ax.scale()).max(1.0));
    }
    for wl in &world.walls {
        let _ = writeln!(
            s,
            r##"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="#333" stroke-width="{:.1}"/>"##,
            ax.at(wl[0]),
            ay.at(wl[1]),
            ax.at(wl[2]),
            ay.at(wl[3]),
            (wl[4] * ax.scale()).max(1.5)
        );
    }
    for (i, t) in tracks.iter().enumerate() {
        let pts: String = t.samples.iter().map(|v| format!("{:.1},{:.1} ", ax.at(v[1]), ay.at(v[2]))).collect();
        let _ = writeln!(s, r#"<polyline points="{pts}" fill="none" stroke="{}" stroke-width="1.5"/>"#, color(i));
        if let (Some(a), Some(b)) = (t.samples.first(), t.samples.last()) {
            let _ = writeln!(s, r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{}"/>"#, ax.at(a[1]), ay.at(a[2]), color(i));
            let (px, py) = (ax.at(b[1]), ay.at(b[2]));
            let _ = writeln!(s, r#"<path d="M{:.1},{:.1} l5,9 l-10,0 z" fill="{}"/>"#, px, py - 6.0, color(i));
        }
    }
    for c in collisions {
        let (px, py) = (ax.at(c[0]), ay.at(c[1]));
        let _ = writeln!(s, r#"<path d="M{:.1},{:.1} l10,10 m0,-10 l-10,10" stroke="red" stroke-width="2.5"/>"#, px - 5.0, py - 5.0);
    }
    s.push_str("</g>\n");
}

fn axis_ticks(s: &mut String, ax: Axis, ay: Axis, xl: &str, yl: &str) {
    for (a, horizontal) in [(ax, true), (ay, false)] {
        let step = nice_step(a.hi - a.lo);
        let mut v = (a.lo / step).ceil() * step;
        while v <= a.hi + 1e-9 {
            let p = a.at(v);
            if horizontal {
                let _ = writeln!(s, r##"<text x="{p:.1}" y="{:.1}" text-anchor="middle" fill="#555">{}</text>"##, ay.px_lo + 16.0, fmt_tick(v));
            } else {
                let _ = writeln!(s, r##"<text x="{:.1}" y="{:.1}" text-anchor="end" fill="#555">{}</text>"##, ax.px_lo - 6.0, p + 4.0, fmt_tick(v));
            }
            v += step;
        }
    }
    let _ = writeln!(s, r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{xl}</text>"#, (ax.px_lo + ax.px_hi) / 2.0, ay.px_lo + 32.0);
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" transform="rotate(-90 {:.1} {:.1})">{yl}</text>"#,
        ax.px_lo - 40.0,
        (ay.px_lo + ay.px_hi) / 2.0,
        ax.px_lo - 40.0,
        (ay.px_lo + ay.px_hi) / 2.0
    );
}

fn series_panel(s: &mut String, tracks: &[Track], col: usize, label: &str, top: f64, t_max: f64) {
    let y_max = tracks.iter().flat_map(|t| &t.samples).filter_map(|v| finite(v[col])).fold(1.0, f64::max).min(15.0);
    let ax = Axis { lo: 0.0, hi: t_max, px_lo: 860.0, px_hi: 1380.0 };
    let ay = Axis { lo: 0.0, hi: y_max * 1.05, px_lo: top + 230.0, px_hi: top };
    let _ = writeln!(s, r##"<rect x="860" y="{top}" width="520" height="230" fill="#fbfbf7" stroke="#999"/>"##);
    let _ = writeln!(s, r#"<text x="865" y="{:.1}">{}</text>"#, top - 6.0, escape(label));
    axis_ticks(s, ax, ay, "sim time [s]", "");
    for (i, t) in tracks.iter().enumerate() {
        let pts: String = t
            .samples
            .iter()
            .filter_map(|v| finite(v[col]).map(|d| format!("{:.1},{:.1} ", ax.at(v[0]), ay.at(d.min(ay.hi)))))
            .collect();
        let _ = writeln!(s, r#"<polyline points="{pts}" fill="none" stroke="{}" stroke-width="1"/>"#, color(i));
    }
}

fn legend(s: &mut String, tracks: &[Track]) {
    for (i, t) in tracks.iter().enumerate() {
        let x = 860.0 + 60.0 * i as f64;
        let _ = writeln!(s, r#"<rect x="{x}" y="8" width="12" height="12" fill="{}"/><text x="{:.0}" y="19">UAV {}</text>"#, color(i), x + 16.0, t.id);
    }
}

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

/// A chart of curves over a shared x axis, y from 0, with an optional red dashed threshold line.
pub fn line_chart(title: &str, x_label: &str, y_label: &str, series: &[Series], threshold: Option<f64>) -> String {
    let pts = || series.iter().flat_map(|c| &c.points).filter(|p| p[0].is_finite() && p[1].is_finite());
    let x_hi = pts().map(|p| p[0]).fold(1.0, f64::max);
    let y_hi = pts().map(|p| p[1]).chain(threshold).fold(1.0, f64::max) * 1.05;
    let ax = Axis { lo: 0.0, hi: x_hi, px_lo: 70.0, px_hi: 650.0 };
    let ay = Axis { lo: 0.0, hi: y_hi, px_lo: 400.0, px_hi: 40.0 };
    let mut s = String::new();
    let _ = writeln!(s, r#"<svg xmlns="http://www.w3.org/2000/svg" width="960" height="460" font-family="sans-serif" font-size="12">"#);
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(s, r#"<text x="70" y="24" font-size="15">{}</text>"#, escape(title));
    let _ = writeln!(s, r##"<rect x="70" y="40" width="580" height="360" fill="#fbfbf7" stroke="#999"/>"##);
    axis_ticks(&mut s, ax, ay, &escape(x_label), &escape(y_label));
    if let Some(t) = threshold {
        let _ = writeln!(s, r#"<line x1="70" y1="{0:.1}" x2="650" y2="{0:.1}" stroke="red" stroke-dasharray="4 4"/>"#, ay.at(t));
    }
    for (i, c) in series.iter().enumerate() {
        let line: String = c
            .points
            .iter()
            .filter(|p| p[0].is_finite() && p[1].is_finite())
            .map(|p| format!("{:.1},{:.1} ", ax.at(p[0]), ay.at(p[1])))
            .collect();
        let dash = if c.dashed { r#" stroke-dasharray="6 3""# } else { "" };
        let _ = writeln!(s, r#"<polyline points="{line}" fill="none" stroke="{}" stroke-width="2"{dash}/>"#, color(i));
        let y = 50.0 + 16.0 * i as f64;
        let _ = writeln!(s, r#"<rect x="665" y="{:.0}" width="12" height="12" fill="{}"/><text x="683" y="{:.0}">{}</text>"#, y, color(i), y + 11.0, escape(&c.label));
    }
    s.push_str("</svg>\n");
    s
}

fn nice_step(span: f64) -> f64 {
    let raw = span.max(1e-9) / 8.0;
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|&v| v >= raw).unwrap_or(10.0 * mag)
}

fn fmt_tick(v: f64) -> String {
    if (v - v.round()).abs() < 1e-9 {
        format!("{}", v.round() + 0.0) // + 0.0 turns -0 into 0
    } else {
        format!("{v:.1}")
    }
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
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
        let svg = line_chart("t", "δa [m]", "[m]", &series, Some(0.6));
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert_eq!(svg.matches("stroke-dasharray=\"6 3\"").count(), 1);
        assert!(svg.contains("stroke=\"red\"") && svg.contains("b &lt;x&gt;"));
        assert!(!svg.contains("NaN"), "non-finite points are skipped");
    }

    #[test]
    fn svg_has_every_tree_path_and_collision() {
        let world = TruthWorld {
            trees: vec![[5.0, 0.0, 0.3], [8.0, 2.0, 0.2]],
            walls: vec![[0.0, -5.0, 10.0, -5.0, 0.2]],
            starts: vec![[0.0, 0.0, 0.0]],
            goal: [10.0, 0.0],
            body_radius_m: 0.3,
        };
        let tracks = vec![
            Track { id: 1, samples: vec![[0.0, 0.0, 0.0, 2.0, 1.0], [1.0, 1.0, 0.5, 1.5, f64::INFINITY]] },
            Track { id: 2, samples: vec![[0.0, 0.0, 1.0, 2.0, 1.0]] },
        ];
        let svg = run_svg("a <run>", &world, &tracks, &[[1.0, 0.5]], 2.0);
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches(r##"fill="#5b4636""##).count(), 2, "one disc per tree");
        assert!(svg.contains("stroke=\"red\""), "collision marked");
        assert!(svg.contains("a &lt;run&gt;"), "title escaped");
        assert!(svg.contains("UAV 2"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "non-finite samples skipped");
    }

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(40.0), 5.0);
        assert_eq!(nice_step(8.0), 1.0);
        assert_eq!(nice_step(150.0), 20.0);
    }
}
