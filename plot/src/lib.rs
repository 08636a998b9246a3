//! The figures of a run and of the studies, in a crate of their own so only the command that
//! draws links plotters and its font (the `swarm-node` binary does not).
//!
//! `swarm plot RUN`: the figures of a run folder, each as SVG and as PNG (to drop into a paper or
//! a chat), drawn with plotters and the embedded DejaVu Sans (no system font). The recorder
//! writes them at the end of every run; `swarm plot` draws them again from the folder alone
//! (another UAV's vectors, a folder copied from elsewhere).
//!
//! - `data`: the run folder read back (the CSV files, `world.json`, `summary.json`,
//!   `scenario.toml`).
//! - `style`: what every figure shares: font, colours, `Figure` (one drawing, SVG and PNG).
//! - `map`: `run.svg`, the map with the paths and the distances over time (seed 000 Figs.
//!   6.5-6.6).
//! - `vectors`: `vectors.svg`, one UAV's K21 vector magnitudes (seed 000 Figs. 6.3-6.4).
//! - `localization`: `localization.svg`, localization error and neighbour count over time.
//! - `connectivity`: `connectivity.svg`, components over time on the shaded netem timeline.
//! - `lines`: [`line_chart`], the studies' curves (`swarm sweep-error`).

mod connectivity;
mod data;
mod lines;
mod localization;
mod map;
mod style;
mod vectors;

pub use lines::{line_chart, Series};
/// The plotting library itself, so charts drawn elsewhere (`swarm scale`, `swarm sweep-seeds`)
/// use the same pinned version through [`Figure`].
pub use plotters;
pub use style::{color, tick, write_pair, DrawResult, Figure, FAMILY};

use anyhow::Result;
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use swarm_types::UavId;

/// The figures of a run folder, by file stem, in the order they are written.
pub const FIGURES: [&str; 4] = ["run", "vectors", "localization", "connectivity"];

/// `swarm plot`.
#[derive(Args, Debug, Clone)]
pub struct PlotArgs {
    /// Run folder (what `swarm run` wrote: `runs/<run id>` or its `--out`).
    pub run: PathBuf,
    /// The UAV whose K21 vectors are drawn (default: the lowest id that reported).
    #[arg(long)]
    pub uav: Option<UavId>,
    /// Also draw each UAV's own line in localization.png (the swarm's median and spread are
    /// always there).
    #[arg(long)]
    pub per_uav: bool,
}

/// Runs `swarm plot`: writes the figures into the run folder and prints their paths.
pub fn plot(a: PlotArgs) -> Result<ExitCode> {
    let started = std::time::Instant::now();
    let files = write_all_with(&a.run, a.uav, a.per_uav)?;
    for f in &files {
        println!("{}", f.display());
    }
    tracing::info!(figures = files.len(), seconds = started.elapsed().as_secs_f64(), "plotted");
    Ok(ExitCode::SUCCESS)
}

/// Reads the run folder `dir` and writes every figure of [`FIGURES`] into it, SVG and PNG;
/// returns the paths written. `uav` picks the vectors' UAV.
pub fn write_all(dir: &Path, uav: Option<UavId>) -> Result<Vec<PathBuf>> {
    write_all_with(dir, uav, false)
}

/// [`write_all`], with each UAV's own line in localization.png when `per_uav`.
pub fn write_all_with(dir: &Path, uav: Option<UavId>, per_uav: bool) -> Result<Vec<PathBuf>> {
    let run = data::Run::read(dir)?;
    let uav = uav.or_else(|| run.states.keys().next().copied()).unwrap_or(UavId::new(1));
    let mut out = Vec::new();
    out.extend(style::write(&map::RunFigure(&run), dir, FIGURES[0])?);
    out.extend(style::write(&vectors::VectorsFigure { run: &run, uav }, dir, FIGURES[1])?);
    out.extend(style::write(&localization::LocalizationFigure { run: &run, per_uav }, dir, FIGURES[2])?);
    out.extend(style::write(&connectivity::ConnectivityFigure(&run), dir, FIGURES[3])?);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Decodes a PNG and returns its size.
    fn png_size(path: &Path) -> (u32, u32) {
        let decoder = png::Decoder::new(std::fs::File::open(path).expect("png exists"));
        let mut reader = decoder.read_info().expect("a PNG header");
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).expect("a whole PNG frame");
        assert!(buf.iter().any(|&b| b != 255), "{}: not blank", path.display());
        (info.width, info.height)
    }

    #[test]
    fn every_figure_of_a_small_run_folder_is_written_as_svg_and_png() {
        let dir = std::env::temp_dir().join(format!("plot-all-{}", std::process::id()));
        data::synthetic_run_folder(&dir);
        let files = write_all(&dir, None).expect("plots");
        assert_eq!(files.len(), 2 * FIGURES.len());
        for stem in FIGURES {
            let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg"))).expect("svg written");
            assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{stem}: an SVG document");
            assert!(svg.contains("synthetic &lt;2&gt; (r1)"), "{stem}: the title, escaped");
            let (w, h) = png_size(&dir.join(format!("{stem}.png")));
            assert!(w >= 900 && h >= 400, "{stem}: {w}x{h}");
        }
        let read = |stem: &str| std::fs::read_to_string(dir.join(format!("{stem}.svg"))).expect("svg");
        let run = read("run");
        assert_eq!(run.matches(r##"fill="#5B4636""##).count(), 2, "one disc per tree");
        assert!(run.contains("UAV 2") && run.contains("distance to the nearest other UAV"));
        assert!(!run.contains("NaN") && !run.contains("inf"), "non-finite samples skipped");
        let vectors = read("vectors");
        assert!(
            vectors.contains("K21 vectors of UAV 1")
                && vectors.contains("avoidance |v_o|")
                && vectors.contains("output |v| [m/s]")
        );
        let loc = read("localization");
        assert!(loc.contains("median of 2 UAVs") && loc.contains("neighbours each agent"));
        let conn = read("connectivity");
        assert!(conn.contains("some link cut") && conn.contains("kill 2") && conn.contains("components"));
        assert!(!conn.contains("some link impaired"), "a partition cuts, it does not impair");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
