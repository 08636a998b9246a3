//! The `swarm mesh --sizes` picture: border shares delivered and late commands (left), and the
//! cores each kind of piece kept busy beside the machine's whole (right), against the UAV count
//! on a log axis, as SVG and PNG, drawn like every figure of [`swarm_plot`].

use super::report::MeshReport;
use anyhow::Result;
use std::path::Path;
use swarm_plot::plotters::coord::Shift;
use swarm_plot::plotters::prelude::*;
use swarm_plot::{write_pair, DrawResult, Figure, FAMILY};

/// Picture size [px].
const SIZE: (u32, u32) = (1200, 520);

/// Writes the picture of `reports` (one per size) to `svg` and `png`.
pub fn write(reports: &[MeshReport], svg: &Path, png: &Path) -> Result<()> {
    write_pair(&SizesChart(reports), svg, png)
}

struct SizesChart<'a>(&'a [MeshReport]);

/// A named line: its points `(UAVs, value)`.
type Line = (String, Vec<(f64, f64)>);

impl Figure for SizesChart<'_> {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let mode = self.0.first().map_or("", |r| r.time_mode.as_str());
        let root =
            root.titled(&format!("swarm mesh by size ({mode}): what crossed the hosts, and the CPU"), (FAMILY, 22))?;
        let (left, right) = root.split_horizontally(SIZE.0 / 2);
        let at = |f: &dyn Fn(&MeshReport) -> f64| self.0.iter().map(|r| (r.uavs as f64, f(r))).collect::<Vec<_>>();
        let shares = vec![
            ("border shares delivered".to_string(), at(&|r| 100.0 * r.delivered())),
            ("commands late".to_string(), at(&|r| 100.0 * r.late_share())),
        ];
        panel(&left, &shares, "delivery and lateness", "% of border shares / of commands", 105.0)?;
        let cores = self.0.first().map_or(1, |r| r.cpu.cores) as f64;
        let mut cpu: Vec<Line> = ["hub", "recorder", "routers", "agents"]
            .iter()
            .map(|&role| (role.to_string(), at(&|r| r.cpu.cores_of(role))))
            .collect();
        cpu.push((format!("machine (of {cores:.0} cores)"), at(&|r| r.cpu.machine_busy * r.cpu.cores as f64)));
        panel(&right, &cpu, "CPU", "cores kept busy", cores * 1.1)
    }
}

/// A panel of named lines, as `swarm scale` draws them.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    lines: &[Line],
    caption: &str,
    y_label: &str,
    y_top: f64,
) -> DrawResult<DB> {
    let named: Vec<(&str, &[(f64, f64)])> = lines.iter().map(|(name, pts)| (name.as_str(), pts.as_slice())).collect();
    crate::scale::chart::by_uavs(area, &named, caption, y_label, y_top)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_picture_is_written_as_svg_and_png() {
        let dir = std::env::temp_dir().join(format!("mesh-chart-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let (svg, png) = (dir.join("s.svg"), dir.join("s.png"));
        let r = super::super::report::example(100);
        write(&[r, super::super::report::example(1000)], &svg, &png).expect("drawn");
        let text = std::fs::read_to_string(&svg).expect("svg");
        assert!(text.contains("border shares delivered") && text.contains("agents"), "legend drawn");
        assert_eq!(&std::fs::read(&png).expect("png written")[1..4], b"PNG");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
