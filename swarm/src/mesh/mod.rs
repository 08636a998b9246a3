//! `swarm mesh`: a swarm spread over machines, measured on the wire (issue 22, item 4). On one
//! Linux machine (root), it builds a network of machines out of network namespaces ([`net`]): the
//! hub (with the recorder) on one, and each of `--hosts` agent hosts on its own, behind its own
//! `swarm router` connected to the hub, as a site's agents would be. UAVs are placed on hosts by
//! where they start ([`report::strips`]: strips across the way to the goal), so most radio
//! neighbours share a host and only the strips' borders talk across, and numbered host by host
//! ([`report::renumbered`]: the scenario flown lists their starts, in the study folder). It flies the scenario,
//! then reports what each host's link carried as the kernel counted it (`ip -s link`), the
//! shares that reached each host from UAVs of other hosts (its session's own count), and how
//! many UAVs of other hosts were within radio range of the host's UAVs per tick (from the truth
//! track): with subscriptions scoped to radio sets, the shares crossing into a host follow its
//! border, not the swarm's size. Also x real time and late commands.
//!
//! Everything runs with access control: the hub takes fresh credentials, each relay router logs
//! in as its host's user (`uavs<ids>`) and lets in only that user (its agent host), the recorder
//! logs in as `observer`; agents reach the hub only through their site's router. Every address lives in the namespaces this command makes, and
//! they are removed at the end, also on failure.
//!
//! Each host's row also says how many border shares never came (the ticks one sender's received
//! shares skip), so the delivery is a count, not an estimate; and the study says how much CPU
//! each kind of piece used and how busy the machine was ([`cpu`]). `--sizes 100,200,400,1000`
//! flies the scenario at each size (its start disc scaled to keep the density) and adds a table
//! and a plot of delivery, late commands and CPU against the size ([`chart`]).
//!
//! - [`net`]: the namespaces, their links and the kernel's byte counters.
//! - [`cpu`]: the pieces' CPU from `/proc`.
//! - [`report`]: the pure part: hosts by start position, radio neighbours across hosts from the
//!   truth track, the tables.
//! - [`chart`]: the sizes' plot.

pub mod chart;
pub mod cpu;
pub mod net;
pub mod report;

use anyhow::{bail, Context, Result};
use clap::Args;
use net::Net;
use report::{HostRow, MeshReport};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{ExitCode, Stdio};
use std::time::Duration;
use swarm_args::{default_run_id, scenario_value, unix_secs};
use swarm_config::Scenario;
use swarm_node::auth::{host_user, ids_text, Credentials};
use swarm_record::summary::Summary;
use swarm_types::UavId;
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::Child;

/// `swarm mesh`.
#[derive(Args, Debug, Clone)]
pub struct MeshArgs {
    /// Scenario file or built-in name (default: open-1000).
    pub scenario: Option<String>,
    /// Agent hosts, each a machine behind its own router.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=200))]
    pub hosts: u32,
    /// Override the time mode (`lockstep` or `realtime`).
    #[arg(long)]
    pub time_mode: Option<String>,
    /// Cap the sim time [s].
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Study folder (default: runs/mesh-<time>): the run folder, logs, mesh.md and mesh.json.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the report as JSON instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Also record `run.mcap` (off by default: large at 1000 UAVs).
    #[arg(long)]
    pub mcap: bool,
    /// Fly the scenario at each of these sizes (e.g. `100,200,400,1000`), its start disc scaled
    /// to keep the density, one study each under the folder, and add `sizes.md`, `sizes.json`
    /// and `sizes.png` / `sizes.svg`: delivery, late commands and CPU against the size.
    #[arg(long, value_delimiter = ',')]
    pub sizes: Vec<u32>,
}

/// The port every piece listens on, each at its own machine's address.
const PORT: u16 = 7447;

/// A child process in a namespace; it exits when its standard input closes (dropped).
struct Piece {
    child: Child,
    _stdin: Option<tokio::process::ChildStdin>,
}

/// Runs `swarm mesh`.
pub async fn mesh(a: MeshArgs) -> Result<ExitCode> {
    let sc = scenario(&a)?;
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("mesh-{}", unix_secs())));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let out = out.canonicalize()?;
    if a.sizes.is_empty() {
        let report = mesh_one(&sc, a.hosts, &out, a.mcap).await?;
        if a.json {
            swarm_node::process::out(&serde_json::to_string_pretty(&report)?);
        } else {
            print!("{}", report::table(&report));
        }
        eprintln!("study folder: {} (mesh.md, mesh.json, run/, logs)", out.display());
        return Ok(ExitCode::SUCCESS);
    }
    let mut reports = Vec::new();
    for &n in &a.sizes {
        let resized = crate::scale::resized(&sc, n).with_context(|| format!("--sizes {n} of {}", sc.name))?;
        let report = mesh_one(&resized, a.hosts, &out.join(format!("n{n}")), a.mcap).await?;
        eprint!("{}", report::size_line(&report));
        reports.push(report);
    }
    let table = report::sizes_table(&sc.name, &reports);
    std::fs::write(out.join("sizes.md"), &table)?;
    std::fs::write(out.join("sizes.json"), serde_json::to_string_pretty(&reports)?)?;
    chart::write(&reports, &out.join("sizes.svg"), &out.join("sizes.png"))?;
    if a.json {
        swarm_node::process::out(&serde_json::to_string_pretty(&reports)?);
    } else {
        print!("{table}");
    }
    eprintln!("study folder: {} (sizes.md, sizes.json, sizes.png, a study per size)", out.display());
    Ok(ExitCode::SUCCESS)
}

/// Flies `sc` over `hosts` agent hosts, its study in `out`, and reports it (also written to
/// `out`'s `mesh.md` and `mesh.json`).
async fn mesh_one(sc: &Scenario, hosts: u32, out: &Path, mcap: bool) -> Result<MeshReport> {
    let starts = physics_hub::start_positions(sc);
    let by_position = report::strips(&starts, sc.swarm.goal, hosts as usize);
    let (sc, groups) = report::renumbered(sc, &starts, &by_position).map_err(anyhow::Error::msg)?;
    let hosts: Vec<String> = (1..=groups.len()).map(|h| format!("h{h}")).collect();
    let machines: Vec<String> = std::iter::once("hub".to_string()).chain(hosts.iter().cloned()).collect();
    let net = Net::build(&format!("mesh{}", std::process::id()), &machines)?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    eprintln!(
        "mesh: {} UAVs of {} on {} agent hosts ({}), hub and recorder on their own machine",
        sc.count(),
        sc.name,
        hosts.len(),
        sizes(&groups)
    );
    // Ctrl-C or SIGTERM at any moment still drops the network (its namespaces) and the pieces.
    let mut term =
        tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()).context("cannot watch SIGTERM")?;
    let flown = tokio::select! {
        f = fly(&net, &sc, out, &hosts, &groups, mcap) => f?,
        _ = tokio::signal::ctrl_c() => bail!("interrupted; the network and its pieces are removed"),
        _ = term.recv() => bail!("terminated; the network and its pieces are removed"),
    };
    drop(net);
    let report = build_report(&sc, out, &hosts, &groups, &flown)?;
    std::fs::write(out.join("mesh.md"), report::table(&report))?;
    std::fs::write(out.join("mesh.json"), serde_json::to_string_pretty(&report)?)?;
    Ok(report)
}

/// The scenario with the command line's overrides.
fn scenario(a: &MeshArgs) -> Result<Scenario> {
    let (mut sc, _) = Scenario::from_arg(a.scenario.as_deref().unwrap_or("open-1000"))?;
    if let Some(m) = &a.time_mode {
        sc.time.mode = scenario_value("--time-mode", m)?;
    }
    if let Some(t) = a.time_limit {
        anyhow::ensure!(t.is_finite() && t > 0.0, "--time-limit {t}: a positive number of seconds");
        sc.end.time_limit_s = t;
    }
    Ok(sc)
}

fn sizes(groups: &[Vec<UavId>]) -> String {
    groups.iter().map(|g| g.len().to_string()).collect::<Vec<_>>().join(" + ")
}

/// What the flight left besides its run folder: each machine's link bytes over the flight, and
/// the CPU its pieces used.
struct Flown {
    /// (received, sent) per machine, hub first.
    link_bytes: Vec<(u64, u64)>,
    cpu: cpu::CpuUse,
}

/// Starts the pieces in their namespaces, flies the run to its end, and reads the link counters.
async fn fly(
    net: &Net,
    sc: &Scenario,
    out: &Path,
    hosts: &[String],
    groups: &[Vec<UavId>],
    mcap: bool,
) -> Result<Flown> {
    let exe = std::env::current_exe().context("cannot find this executable")?;
    let scenario_file = out.join("scenario.toml");
    std::fs::write(&scenario_file, toml::to_string(sc)?)?;
    let mut users: Vec<String> = groups.iter().map(|g| host_user(g)).collect();
    users.push("observer".into());
    let creds = Credentials::create(&out.join("credentials"), &users)?;
    let run = default_run_id("mesh");
    let keys = swarm_wire::Keys::new(&run)?;
    let hub_ep = format!("tcp/{}:{PORT}", net.addr("hub"));
    let start =
        |machine: &str, args: Vec<String>, log: &str| spawn(net, machine, &exe, args, &out.join(log), Stdio::piped());

    let dict = creds.dictionary().to_string_lossy().into_owned();
    let mut hub = start(
        "hub",
        strings(&[
            "hub",
            &scenario_file.to_string_lossy(),
            "--run",
            &run,
            "--listen",
            &hub_ep,
            "--users",
            &dict,
            "--exit-with-stdin",
        ]),
        "hub.log",
    )?;
    wait_line(&mut hub, swarm_node::pieces::LISTENING_PREFIX, "the hub").await?;
    let observer = creds.client_args("observer");
    let mut rec_args =
        strings(&["record", "--run", &run, "--out", &out.join("run").to_string_lossy(), "--connect", &hub_ep]);
    rec_args.extend(observer.iter().cloned());
    if !mcap {
        rec_args.push("--no-mcap".into());
    }
    // Its stdout (the printed summary, a line per UAV) to a file: a pipe nobody reads would fill
    // and stall it.
    let printed = std::fs::File::create(out.join("summary.txt")).context("cannot create summary.txt")?;
    let mut rec = spawn(net, "hub", &exe, rec_args, &out.join("recorder.log"), Stdio::from(printed))?;
    let mut up =
        strings(&["tap", &keys.alive_recorder(), "--alive", "--count", "1", "--duration", "60", "--connect", &hub_ep]);
    up.extend(observer.iter().cloned());
    let seen =
        spawn(net, "hub", &exe, up, &out.join("tap-recorder.log"), Stdio::piped())?.child.wait_with_output().await?;
    anyhow::ensure!(
        String::from_utf8_lossy(&seen.stdout).contains("\"alive\":true"),
        "the recorder never came up (see {})",
        out.join("recorder.log").display()
    );

    let mut pieces = Vec::new();
    let mut pids = vec![("hub".to_string(), pid(&hub)?), ("recorder".to_string(), pid(&rec)?)];
    for (host, ids) in hosts.iter().zip(groups) {
        let ep = format!("tcp/{}:{PORT}", net.addr(host));
        let user = host_user(ids);
        let relay_users = creds.dictionary_of(&user)?.to_string_lossy().into_owned();
        let mut r_args =
            strings(&["router", "--listen", &ep, "--connect", &hub_ep, "--users", &relay_users, "--exit-with-stdin"]);
        r_args.extend(creds.client_args(&user));
        let mut router = start(host, r_args, &format!("router-{host}.log"))?;
        wait_line(&mut router, swarm_node::router::ROUTER_LISTENING_PREFIX, &format!("the router of {host}")).await?;
        pids.push(("routers".to_string(), pid(&router)?));
        pieces.push(router);
    }
    let before = counters(net)?;
    for (host, ids) in hosts.iter().zip(groups) {
        let ep = format!("tcp/{}:{PORT}", net.addr(host));
        let mut a_args =
            strings(&["agent", "--run", &run, "--ids", &ids_text(ids), "--connect", &ep, "--exit-with-stdin"]);
        a_args.extend(creds.client_args(&host_user(ids)));
        let agents = spawn(net, host, &exe, a_args, &out.join(format!("agents-{host}.log")), Stdio::null())?;
        pids.push(("agents".to_string(), pid(&agents)?));
        pieces.push(agents);
    }
    let watch = cpu::Watch::start(pids);
    let mut clock = strings(&["tap", &keys.clock(), "--connect", &hub_ep]);
    clock.extend(observer.iter().cloned());
    let progress = spawn(net, "hub", &exe, clock, &out.join("tap-clock.log"), Stdio::piped())?;
    follow(sc, &mut rec, &mut hub, progress).await?;
    let cpu = watch.stop().await;
    let after = counters(net)?;
    drop(pieces);
    drop(hub);
    let delta = |b: &(u64, u64), a: &(u64, u64)| Some((a.0.checked_sub(b.0)?, a.1.checked_sub(b.1)?));
    let link_bytes = before.iter().zip(&after).map(|(b, a)| delta(b, a)).collect::<Option<Vec<_>>>();
    Ok(Flown { link_bytes: link_bytes.context("a link's byte counters went back during the flight")?, cpu })
}

/// A running piece's pid (`ip netns exec` execs the program, so it is the piece's own).
fn pid(p: &Piece) -> Result<u32> {
    p.child.id().context("a piece exited as it started (see its log in the study folder)")
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|s| s.to_string()).collect()
}

/// Starts `exe ARGS` in `machine`'s namespace, its stdout to `stdout` (piped only when read),
/// stderr to `log`; it dies with us.
fn spawn(net: &Net, machine: &str, exe: &Path, args: Vec<String>, log: &Path, stdout: Stdio) -> Result<Piece> {
    let log_file = std::fs::File::create(log).with_context(|| format!("cannot create {}", log.display()))?;
    let mut c = net.command(machine, exe);
    c.args(args).stdin(Stdio::piped()).stdout(stdout).stderr(Stdio::from(log_file)).kill_on_drop(true);
    let mut child = c.spawn().context("cannot start `ip netns exec`")?;
    let stdin = child.stdin.take();
    Ok(Piece { child, _stdin: stdin })
}

/// Waits (at most 60 s) for `p` to print a line starting with `prefix`.
async fn wait_line(p: &mut Piece, prefix: &str, what: &str) -> Result<()> {
    let stdout = p.child.stdout.take().context("piped stdout")?;
    let mut lines = BufReader::new(stdout).lines();
    let found = tokio::time::timeout(Duration::from_secs(60), async {
        while let Ok(Some(line)) = lines.next_line().await {
            if line.starts_with(prefix) {
                return true;
            }
        }
        false
    })
    .await;
    match found {
        Ok(true) => Ok(()),
        _ => bail!("{what} did not come up within 60 s (see its log in the study folder)"),
    }
}

/// Each machine's (received, sent) link bytes now, in the network's order (hub first).
fn counters(net: &Net) -> Result<Vec<(u64, u64)>> {
    net.machines().iter().map(|m| net.link_bytes(m)).collect()
}

/// Shows progress from the clock tap until the recorder ends with the run (the hub ends first, a
/// moment after its last step, while the recorder still writes the run folder and its figures:
/// a minute or more at 1000 UAVs); fails if the recorder or the hub fails.
async fn follow(sc: &Scenario, rec: &mut Piece, hub: &mut Piece, mut clock: Piece) -> Result<()> {
    let bar = swarm_record::recorder::progress_bar(sc, false);
    let stdout = clock.child.stdout.take().context("piped stdout")?;
    let mut lines = BufReader::new(stdout).lines();
    let ticks = async {
        while let Ok(Some(line)) = lines.next_line().await {
            if let Some(t) =
                serde_json::from_str::<serde_json::Value>(&line).ok().and_then(|v| v["msg"]["Clock"]["tick"].as_u64())
            {
                bar.set_position(t);
            }
        }
        std::future::pending::<()>().await
    };
    let recorded = async {
        match rec.child.wait().await? {
            s if s.success() => Ok(()),
            s => Err(anyhow::anyhow!("the recorder failed ({s}); see recorder.log in the study folder")),
        }
    };
    tokio::pin!(recorded);
    let result = tokio::select! {
        r = &mut recorded => r,
        s = hub.child.wait() => match s? {
            s if s.success() => {
                bar.set_message("run over: the recorder writes the run folder and its figures");
                recorded.await
            }
            s => Err(anyhow::anyhow!("the hub failed ({s}); see hub.log in the study folder")),
        },
        _ = ticks => Ok(()),
    };
    bar.finish_and_clear();
    result
}

/// The report from the run folder and the link counters.
fn build_report(
    sc: &Scenario,
    out: &Path,
    hosts: &[String],
    groups: &[Vec<UavId>],
    flown: &Flown,
) -> Result<MeshReport> {
    let run = out.join("run");
    let summary: Summary = serde_json::from_str(
        &std::fs::read_to_string(run.join("summary.json")).context("the run left no summary.json")?,
    )?;
    let csv = std::fs::read_to_string(run.join("trajectories.csv")).context("the run left no trajectories.csv")?;
    let ticks = report::positions_by_tick(&csv).map_err(anyhow::Error::msg)?;
    let host_of: HashMap<UavId, usize> =
        groups.iter().enumerate().flat_map(|(h, ids)| ids.iter().map(move |&id| (id, h))).collect();
    let heard = report::outside_heard_per_tick(&ticks, &host_of, groups.len(), sc.radio.range_m);
    let heard_wide =
        report::outside_heard_per_tick(&ticks, &host_of, groups.len(), sc.radio.range_m + sc.radio.hysteresis_m);
    let n = summary.ticks.max(1) as f64;
    let kb = |b: u64| b as f64 / 1000.0 / n;
    let rows = hosts
        .iter()
        .zip(groups)
        .enumerate()
        .map(|(h, (host, ids))| {
            let session = summary.traffic.per_session.iter().find(|s| s.uavs.first().is_some_and(|u| ids.contains(u)));
            let (rx, tx) = flown.link_bytes.get(h + 1).copied().unwrap_or_default();
            HostRow {
                host: host.clone(),
                uavs: ids.len(),
                link_rx_kb_per_tick: kb(rx),
                link_tx_kb_per_tick: kb(tx),
                remote_shares_per_tick: session.map_or(0.0, |s| s.remote_shares_per_tick),
                remote_share_kb_per_tick: session.map_or(0.0, |s| s.remote_share_bytes_per_tick / 1000.0),
                remote_share_gaps_per_tick: session.map_or(0.0, |s| s.remote_share_gaps as f64 / s.ticks.max(1) as f64),
                outside_heard_per_tick: heard[h],
                outside_heard_wide_per_tick: heard_wide[h],
                outside_uavs: sc.count() - ids.len(),
            }
        })
        .collect();
    let (hub_rx, hub_tx) = flown.link_bytes.first().copied().unwrap_or_default();
    Ok(MeshReport {
        scenario: sc.name.clone(),
        time_mode: summary.time_mode.clone(),
        uavs: sc.count(),
        ticks: summary.ticks,
        x_real_time: summary.sim_speed,
        late_commands: summary.timing.late_commands,
        commands: summary.timing.commands,
        collisions: summary.collisions,
        reached_goal: summary.reached_goal,
        hosts: rows,
        hub_rx_kb_per_tick: kb(hub_rx),
        hub_tx_kb_per_tick: kb(hub_tx),
        cpu: flown.cpu.clone(),
    })
}
