//! End to end: a real `swarm run` of forest-5 leaves every figure in its run folder, SVG and PNG,
//! and `swarm plot` draws them again from the folder alone.

mod common;

use common::{output_within, run_id, swarm_run, SWARM, TOOL_LIMIT};
use std::path::Path;
use std::process::Command;

/// The figures a run folder holds, by stem.
const FIGURES: [&str; 4] = ["run", "vectors", "localization", "connectivity"];

/// The PNG file signature.
const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

/// Every figure is there: an SVG document naming the run, and a PNG of plausible size.
fn assert_figures(dir: &Path, run: &str) {
    for stem in FIGURES {
        let svg =
            std::fs::read_to_string(dir.join(format!("{stem}.svg"))).unwrap_or_else(|e| panic!("{stem}.svg: {e}"));
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{stem}.svg is an SVG document");
        assert!(svg.contains(&format!("forest-5 ({run})")), "{stem}.svg is titled with the run");
        let png = std::fs::read(dir.join(format!("{stem}.png"))).unwrap_or_else(|e| panic!("{stem}.png: {e}"));
        assert_eq!(png[..8], PNG_SIGNATURE, "{stem}.png is a PNG");
        // IHDR: width and height, big-endian, after the signature, length and chunk type.
        let (w, h) = (
            u32::from_be_bytes(png[16..20].try_into().expect("4 bytes")),
            u32::from_be_bytes(png[20..24].try_into().expect("4 bytes")),
        );
        assert!(w >= 900 && h >= 400, "{stem}.png is {w}x{h}");
    }
}

/// Rows of a CSV file of the run folder (header excluded).
fn rows(dir: &Path, name: &str) -> usize {
    std::fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}")).lines().skip(1).count()
}

#[test]
fn a_run_writes_every_figure_and_swarm_plot_draws_them_again() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("plot");
    let out = swarm_run(&["forest-5", "--out", dir.path().to_str().expect("utf8"), "--run", &run]);
    assert!(out.status.success(), "swarm run failed: {}", String::from_utf8_lossy(&out.stderr));
    assert_figures(dir.path(), &run);
    // What the figures are drawn from: localization and connectivity per tick, the world.
    let ticks = common::summary(dir.path())["ticks"].as_u64().expect("ticks") as usize;
    assert!(rows(dir.path(), "localization.csv") > 4 * ticks, "about a scored state per agent per tick");
    assert!(rows(dir.path(), "connectivity.csv") + 2 >= ticks, "components at every tick");
    let world: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("world.json")).expect("world.json"))
            .expect("json");
    assert!(world["trees"].as_array().expect("trees").len() > 10);
    let run_svg = std::fs::read_to_string(dir.path().join("run.svg")).expect("run.svg");
    assert!(run_svg.matches("<polygon").count() > 10, "the trees are drawn");
    for uav in 1..=5 {
        assert!(run_svg.contains(&format!("UAV {uav}")), "UAV {uav} in the legend");
    }

    for stem in FIGURES {
        for ext in ["svg", "png"] {
            std::fs::remove_file(dir.path().join(format!("{stem}.{ext}"))).expect("remove");
        }
    }
    let plot =
        output_within(Command::new(SWARM).args(["plot", dir.path().to_str().expect("utf8"), "--uav", "3"]), TOOL_LIMIT);
    assert!(plot.status.success(), "swarm plot failed: {}", String::from_utf8_lossy(&plot.stderr));
    assert_eq!(String::from_utf8_lossy(&plot.stdout).lines().count(), 2 * FIGURES.len(), "one path printed per file");
    assert_figures(dir.path(), &run);
    let vectors = std::fs::read_to_string(dir.path().join("vectors.svg")).expect("vectors.svg");
    assert!(vectors.contains("K21 vectors of UAV 3"), "--uav picks the UAV");

    let empty = tempfile::tempdir().expect("tempdir");
    let bad = output_within(Command::new(SWARM).args(["plot", empty.path().to_str().expect("utf8")]), TOOL_LIMIT);
    assert!(
        !bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("not a run folder"),
        "a folder with no run is refused"
    );
}

/// A run with faults, a frozen UAV and a separation invariant: the figures mark what a reader of
/// a paper needs (faults and failures, the contact and separation lines, the swarm's spread),
/// drawn from the real run folder.
#[test]
fn the_figures_of_a_faulty_run_mark_its_faults_limits_and_spread() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = swarm_run(&[
        "forest-5-burst-frozen",
        "--set",
        "end.time_limit_s=40",
        "--no-mcap",
        "--out",
        dir.path().to_str().expect("utf8"),
        "--run",
        &run_id("plotfaults"),
    ]);
    assert!(out.status.success(), "swarm run failed: {}", String::from_utf8_lossy(&out.stderr));
    let svg = |stem: &str| std::fs::read_to_string(dir.path().join(format!("{stem}.svg"))).expect("svg");
    let run = svg("run");
    assert!(run.contains("freeze 1 at 30 s"), "where UAV 1 froze, on the map");
    assert!(run.contains("contact 0.30 m") && run.contains("contact 0.60 m"), "the contact distances");
    assert!(run.contains("separation invariant 0.80 m"), "the separation invariant");
    let loc = svg("localization");
    assert!(loc.contains("median of 5 UAVs") && loc.contains("10th-90th percentile"), "the spread, not 5 thin lines");
    assert!(!loc.contains("\nUAV 1\n"), "no UAV lines unless asked");
    assert!(run.contains("some link impaired") && run.contains("some link cut"), "the shading named");
    let vectors = svg("vectors");
    assert!(vectors.contains("dimensionless"), "the vectors' unit");
    assert!(vectors.contains("freeze at 30 s: not flown after"), "UAV 1's freeze on its vectors");
    assert!(svg("connectivity").contains("some link cut (blocked, held, or from a frozen UAV)"), "what the shading is");
    // `swarm plot --per-uav` adds each UAV's line.
    let o =
        output_within(Command::new(SWARM).args(["plot", dir.path().to_str().expect("utf8"), "--per-uav"]), TOOL_LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(svg("localization").contains("\nUAV 1\n"), "each UAV on request");
    println!("figures of a faulty run: {}", dir.path().display());
}
