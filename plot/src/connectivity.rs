//! `connectivity.svg` / `connectivity.png`: the connected components of the estimate graph ("i
//! holds an estimate of j") over sim time, beside the agents that reported, on the scenario's
//! netem timeline: spans where some link is cut (blocked or held, or from a frozen UAV, which
//! says nothing but still hears: the graph may stay one component) shaded red, where some link
//! is only impaired (loss, delay, ...) shaded orange, and each failure (freeze, kill, restart,
//! link fault) a dashed line with its name. The caption and the legend say so.

use super::data::Run;
use super::style::{legend, time_chart, DrawResult, Figure, FAMILY};
use netem::LinkClass;
use plotters::coord::Shift;
use plotters::prelude::*;
use swarm_types::UavId;

/// Picture size [px].
const SIZE: (u32, u32) = (1000, 460);

/// The shading of a span where some link is cut, and where some link is only impaired (this
/// figure's and the run figure's distance panels).
pub(super) const CUT: RGBColor = RGBColor(214, 39, 40);
pub(super) const IMPAIRED: RGBColor = RGBColor(255, 127, 14);

/// The worst class of any link between `ids` at `t_s`, either direction (cut beats impaired
/// beats clean).
fn links_at(tl: &netem::Timeline, t_s: f64, ids: &[UavId]) -> LinkClass {
    let mut worst = LinkClass::Clean;
    for (k, &i) in ids.iter().enumerate() {
        for &j in &ids[k + 1..] {
            match tl.class_between(t_s, i, j) {
                LinkClass::Cut => return LinkClass::Cut,
                LinkClass::Impaired => worst = LinkClass::Impaired,
                LinkClass::Clean => {}
            }
        }
    }
    worst
}

/// The spans `(from_s, to_s, state)` of the timeline over `[0, t_end]` whose links are not
/// clean; the state can change only at a rule's or a failure's time.
pub fn spans(tl: &netem::Timeline, ids: &[UavId], t_end: f64) -> Vec<(f64, f64, LinkClass)> {
    let mut times: Vec<f64> =
        tl.rules().iter().map(|r| r.at_s).chain(tl.failures().iter().map(|f| f.at_s)).filter(|t| *t < t_end).collect();
    times.push(0.0);
    times.sort_by(f64::total_cmp);
    times.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let ends = times.iter().skip(1).copied().chain([t_end]);
    times
        .iter()
        .zip(ends)
        .map(|(&a, b)| (a, b, links_at(tl, a.max(0.0), ids)))
        .filter(|s| s.2 != LinkClass::Clean)
        .collect()
}

/// A series as steps: each value holds until the next sample.
fn steps(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    for (t, v) in points {
        if let Some(&(_, prev)) = out.last() {
            out.push((t, prev));
        }
        out.push((t, v));
    }
    out
}

/// The connectivity figure.
pub struct ConnectivityFigure<'a>(pub &'a Run);

impl Figure for ConnectivityFigure<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let run = self.0;
        let area = root.titled(&format!("{}: connectivity", run.title), (FAMILY, 18))?;
        let y_hi = run.components.iter().map(|c| c.reporting.max(c.components)).fold(1.0, f64::max) + 0.5;
        let t_end = run.t_end();
        let caption = "components of the estimate graph (an estimate either way joins two UAVs), on the netem timeline";
        let mut chart = time_chart(&area, caption, "count", t_end, y_hi)?;
        let ids: Vec<UavId> =
            if run.uavs > 0 { UavId::all(run.uavs as usize).collect() } else { run.tracks.keys().copied().collect() };
        let spans = spans(&run.timeline, &ids, t_end);
        // What a span means: some link, not every link; a frozen UAV's links count as cut (it
        // says nothing) while it still hears the others, so the graph may stay one component.
        let (cut, impaired) =
            ("some link cut (blocked, held, or from a frozen UAV)", "some link impaired (loss, delay, ...)");
        for (kind, c, label) in [(LinkClass::Cut, CUT, cut), (LinkClass::Impaired, IMPAIRED, impaired)] {
            let boxes = spans
                .iter()
                .filter(|s| s.2 == kind)
                .map(|s| Rectangle::new([(s.0, 0.0), (s.1, y_hi)], c.mix(0.18).filled()));
            let drawn = chart.draw_series(boxes.collect::<Vec<_>>())?;
            if spans.iter().any(|s| s.2 == kind) {
                drawn
                    .label(label)
                    .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], c.mix(0.3).filled()));
            }
        }
        for f in run.timeline.failures().iter().filter(|f| f.at_s <= t_end) {
            chart.draw_series(DashedLineSeries::new(
                [(f.at_s, 0.0), (f.at_s, y_hi)],
                6,
                4,
                BLACK.mix(0.6).stroke_width(1),
            ))?;
            let name = f.kind.name();
            chart.draw_series([Text::new(format!("{name} {}", f.uav), (f.at_s, y_hi * 0.97), (FAMILY, 12))])?;
        }
        let grey = super::style::color(7);
        chart
            .draw_series(DashedLineSeries::new(
                steps(run.components.iter().map(|c| (c.t_s, c.reporting))),
                8,
                4,
                grey.stroke_width(2),
            ))?
            .label("agents reporting")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey.stroke_width(2)));
        let blue = super::style::color(0);
        chart
            .draw_series(LineSeries::new(
                steps(run.components.iter().map(|c| (c.t_s, c.components))),
                blue.stroke_width(2),
            ))?
            .label("components")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], blue.stroke_width(2)));
        legend(&mut chart)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn timeline(tables: &str) -> netem::Timeline {
        netem::Timeline::from(toml::from_str::<swarm_config::Timeline>(tables).expect("valid tables"))
    }

    #[test]
    fn spans_follow_the_timeline() {
        let tl = timeline(
            "[[netem]]\nat_s = 1.0\nfrom = [2]\nrule = { delay_s = 0.1 }\n\n[[netem]]\nat_s = 2.0\npartition = { scheme = \"halves\", nodes = [1, 2] }\n\n[[netem]]\nat_s = 3.0\npartition = { scheme = \"healed\" }\n\n[[failures]]\nat_s = 5.0\nuav = 1\nkind = \"freeze\"\n",
        );
        let s = spans(&tl, &[UavId::new(1), UavId::new(2)], 6.0);
        assert_eq!(
            s,
            vec![
                (1.0, 2.0, LinkClass::Impaired),
                (2.0, 3.0, LinkClass::Cut),
                (3.0, 5.0, LinkClass::Impaired),
                (5.0, 6.0, LinkClass::Cut)
            ]
        );
        assert!(
            spans(&netem::Timeline::default(), &[UavId::new(1), UavId::new(2)], 6.0).is_empty(),
            "no timeline, nothing shaded"
        );
        assert_eq!(spans(&tl, &[UavId::new(1)], 6.0), vec![], "one UAV has no links");
    }

    #[test]
    fn steps_hold_each_value_until_the_next_sample() {
        assert_eq!(steps([(0.0, 1.0), (1.0, 2.0)].into_iter()), vec![(0.0, 1.0), (1.0, 1.0), (1.0, 2.0)]);
    }
}
