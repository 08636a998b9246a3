//! What every figure shares: the embedded font, the colours, and [`Figure`], one drawing written
//! as SVG and as PNG through the same code. Text goes through ab_glyph with DejaVu Sans embedded
//! in the binary, so a figure needs no system font (no fontconfig) and draws the same everywhere.

use anyhow::{anyhow, Result};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// The font family every text asks for; registered once from the embedded DejaVu Sans.
pub const FAMILY: &str = "sans-serif";

/// One colour per series, in turn (matplotlib's tab10, so figures look like the seeds').
const PALETTE: [RGBColor; 10] = [
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

/// The colour of the `i`th series.
pub fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// What a drawing returns: plotters' error of its backend.
pub type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A figure drawn the same way on any backend (SVG, PNG).
pub trait Figure {
    /// Size [px].
    fn size(&self) -> (u32, u32);
    /// Draws the whole figure on `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB>;
}

fn register_font() -> Result<()> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *ONCE
        .get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, dejavu::sans::regular()).is_ok());
    if ok {
        Ok(())
    } else {
        Err(anyhow!("the embedded font did not load"))
    }
}

fn render<DB: DrawingBackend, F: Figure>(fig: &F, root: DrawingArea<DB, Shift>) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    fig.draw(&root)?;
    root.present()
}

/// Writes `fig` to `svg` and `png`.
pub fn write_pair<F: Figure>(fig: &F, svg: &Path, png: &Path) -> Result<()> {
    register_font()?;
    render(fig, SVGBackend::new(svg, fig.size()).into_drawing_area()).map_err(|e| anyhow!("{}: {e}", svg.display()))?;
    render(fig, BitMapBackend::new(png, fig.size()).into_drawing_area())
        .map_err(|e| anyhow!("{}: {e}", png.display()))?;
    Ok(())
}

/// Writes `fig` as `<stem>.svg` and `<stem>.png` in `dir`; returns both paths.
pub fn write<F: Figure>(fig: &F, dir: &Path, stem: &str) -> Result<[PathBuf; 2]> {
    let (svg, png) = (dir.join(format!("{stem}.svg")), dir.join(format!("{stem}.png")));
    write_pair(fig, &svg, &png)?;
    Ok([svg, png])
}

/// `fig` as SVG text.
pub fn svg_string<F: Figure>(fig: &F) -> Result<String> {
    register_font()?;
    let mut s = String::new();
    render(fig, SVGBackend::with_string(&mut s, fig.size()).into_drawing_area()).map_err(|e| anyhow!("svg: {e}"))?;
    Ok(s)
}

/// `(lo, hi)` of the finite values, or `None`.
pub fn range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |r, v| Some(r.map_or((v, v), |(lo, hi): (f64, f64)| (lo.min(v), hi.max(v)))))
}

/// The upper end of a y axis from 0 over `values`: 5 % headroom, at least `floor`.
pub fn y_top(values: impl Iterator<Item = f64>, floor: f64) -> f64 {
    range(values).map_or(floor, |(_, hi)| hi.max(floor)) * 1.05
}

/// The last sim time among `values`, at least 1 s (an x axis from 0).
pub fn t_end(values: impl Iterator<Item = f64>) -> f64 {
    range(values).map_or(1.0, |(_, hi)| hi.max(1.0))
}

/// At most `max` points of a time series: each run of consecutive points becomes the one with
/// the smallest value, so minima (closest approaches) survive the thinning. Short series are
/// returned whole.
pub fn thin_keeping_minima(points: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max == 0 {
        return points.to_vec();
    }
    let per = points.len().div_ceil(max);
    points.chunks(per).filter_map(|c| c.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1))).collect()
}

/// An axis label: at most four decimals, no trailing zeros (`2`, `0.5`, `-1.25`, `0.035`): enough
/// for the 1-2-5 steps of a small range (0.005 apart), which two decimals printed as repeats.
pub fn tick(v: &f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

/// A chart with sim time [s] across and a value up.
pub type TimeChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A time-series chart: x is sim time from 0 to `t_max`, y from 0 to `y_hi`, mesh and labels
/// drawn.
pub fn time_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    y_label: &str,
    t_max: f64,
    y_hi: f64,
) -> Result<TimeChart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FAMILY, 16))
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(56)
        .build_cartesian_2d(0.0..t_max, 0.0..y_hi)?;
    chart
        .configure_mesh()
        .x_desc("sim time [s]")
        .y_desc(y_label)
        .label_style((FAMILY, 12))
        .max_light_lines(0)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    Ok(chart)
}

/// Width of the legend strip beside a chart whose legend would cover its data [px].
const LEGEND_STRIP_PX: u32 = 170;

/// A thick polyline as separate two-point segments. Why: plotters joins a thick polyline's
/// segments with miters, and at a sharp reversal (a value that jumps 0 → 1 → 0 between ticks)
/// the miter shoots far out of the plot, across the captions and the other panel.
pub fn segments(points: Vec<(f64, f64)>, style: ShapeStyle) -> Vec<PathElement<(f64, f64)>> {
    points.windows(2).map(|w| PathElement::new(vec![w[0], w[1]], style)).collect()
}

/// `area` split into the chart's part and a strip on its right for [`legend_strip`], so a legend
/// never covers the lines (time series that fill the whole plot: localization, vectors).
pub fn beside_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
) -> (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>) {
    let width = area.dim_in_pixel().0;
    area.split_horizontally(width.saturating_sub(LEGEND_STRIP_PX))
}

/// Draws a legend of `entries` (label, line style) down `strip`, from the height of the chart's
/// plotting area.
pub fn legend_strip<DB: DrawingBackend>(
    strip: &DrawingArea<DB, Shift>,
    entries: &[(String, ShapeStyle)],
) -> DrawResult<DB> {
    for (i, (label, style)) in entries.iter().enumerate() {
        let y = 44 + 16 * i32::try_from(i).unwrap_or(i32::MAX / 32);
        strip.draw(&PathElement::new(vec![(4, y), (24, y)], *style))?;
        strip.draw(&Text::new(label.clone(), (30, y - 6), (FAMILY, 12)))?;
    }
    Ok(())
}

/// Draws the legend of `chart`'s labelled series in its upper right corner.
pub fn legend<'a, DB: DrawingBackend + 'a, X: Ranged, Y: Ranged>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
) -> DrawResult<DB> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FAMILY, 12))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .draw()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thick_line_is_drawn_as_joinless_segments() {
        let pts = vec![(0.0, 0.0), (0.1, 1.0), (0.2, 0.0), (0.3, 1.0)];
        assert_eq!(
            segments(pts, BLACK.stroke_width(2)).len(),
            3,
            "one two-point segment per pair of neighbours, so no miter joins"
        );
        assert!(segments(vec![(0.0, 1.0)], BLACK.into()).is_empty(), "a single point draws nothing");
    }

    #[test]
    fn thinning_keeps_each_runs_minimum() {
        let pts: Vec<(f64, f64)> = (0..10).map(|i| (f64::from(i), if i == 7 { -1.0 } else { f64::from(i) })).collect();
        assert_eq!(thin_keeping_minima(&pts, 20), pts, "short series whole");
        let thin = thin_keeping_minima(&pts, 5);
        assert_eq!(thin.len(), 5);
        assert!(thin.contains(&(7.0, -1.0)), "{thin:?}");
        assert_eq!(range([3.0, f64::NAN, -2.0].into_iter()), Some((-2.0, 3.0)));
        assert_eq!(y_top(std::iter::empty(), 1.0), 1.05);
        assert_eq!(t_end([0.5].into_iter()), 1.0);
        assert_eq!([2.0, 0.5, -1.25, -0.00001, 10.0].map(|v| tick(&v)), ["2", "0.5", "-1.25", "0", "10"]);
        // A small range's 0.005 steps stay apart; float noise is not printed.
        assert_eq!([0.035, 0.025, 0.1 + 0.2].map(|v| tick(&v)), ["0.035", "0.025", "0.3"]);
    }
}
