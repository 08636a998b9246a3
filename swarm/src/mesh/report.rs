//! What `swarm mesh` computes from what a run left, with no IO: which host flies which UAV, how
//! many UAVs of the other hosts each host's UAVs could hear per tick (from the truth track), and
//! the table that puts those beside the bytes the kernel counted on each host's link.

use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt::Write as _;
use swarm_types::UavId;

/// Splits the UAVs (ids 1..=n, `starts[id - 1]`) into `hosts` groups by where they start: sorted
/// by the coordinate across the way from their centroid to `goal`, cut into strips of nearly
/// equal size, so a UAV's radio neighbours are mostly on its own host and only the strips'
/// borders talk across hosts. Each group's ids ascend.
pub fn strips(starts: &[[f64; 2]], goal: [f64; 2], hosts: usize) -> Vec<Vec<UavId>> {
    let n = starts.len();
    let hosts = hosts.clamp(1, n.max(1));
    let c = starts.iter().fold([0.0, 0.0], |a, p| [a[0] + p[0] / n as f64, a[1] + p[1] / n as f64]);
    let (dx, dy) = (goal[0] - c[0], goal[1] - c[1]);
    let len = dx.hypot(dy);
    let (ux, uy) = if len > 1e-9 { (dx / len, dy / len) } else { (1.0, 0.0) };
    let across = |p: &[f64; 2]| ux * (p[1] - c[1]) - uy * (p[0] - c[0]);
    let mut order: Vec<UavId> = UavId::all(n).collect();
    order.sort_by(|&a, &b| across(&starts[a.index()]).total_cmp(&across(&starts[b.index()])).then(a.cmp(&b)));
    (0..hosts)
        .map(|h| {
            let mut ids = order[h * n / hosts..(h + 1) * n / hosts].to_vec();
            ids.sort_unstable();
            ids
        })
        .collect()
}

/// `sc` with its UAVs numbered host by host: `groups` (old ids, by host) become consecutive id
/// ranges in their order, the start positions listed explicitly in the new order (`starts`, by
/// old id), and the informed and failed UAVs renumbered with them. A host then logs in as
/// `uavs1-250`, as a site would, instead of a list of scattered ids. Scenarios whose timelines
/// name UAVs (`[[netem]]`, `[[failures]]`, `[[mission]]`) are refused: they would need the same
/// renumbering of every set they name.
pub fn renumbered(
    sc: &swarm_config::Scenario,
    starts: &[[f64; 2]],
    groups: &[Vec<UavId>],
) -> Result<(swarm_config::Scenario, Vec<Vec<UavId>>), String> {
    if !sc.netem.is_empty() || !sc.failures.is_empty() || !sc.mission.is_empty() {
        return Err(format!(
            "{}: swarm mesh numbers UAVs host by host, and this scenario's [[netem]], [[failures]] or [[mission]] name UAVs by id; fly one without them",
            sc.name
        ));
    }
    let order: Vec<UavId> = groups.iter().flatten().copied().collect();
    let new_of: HashMap<UavId, UavId> = order.iter().enumerate().map(|(i, &old)| (old, UavId::from_index(i))).collect();
    let map = |ids: &[UavId]| -> Vec<UavId> {
        let mut v: Vec<UavId> = ids.iter().filter_map(|i| new_of.get(i).copied()).collect();
        v.sort_unstable();
        v
    };
    let mut out = sc.clone();
    out.swarm.start_positions = Some(order.iter().map(|&old| starts[old.index()]).collect());
    out.swarm.start_area = None;
    if let swarm_config::Informed::Ids(ids) = &sc.swarm.informed {
        out.swarm.informed = swarm_config::Informed::Ids(map(ids));
    }
    out.swarm.failed = map(&sc.swarm.failed);
    let mut next = 1;
    let ranges = groups
        .iter()
        .map(|g| {
            let r: Vec<UavId> = (next..next + g.len() as u32).map(UavId::new).collect();
            next += g.len() as u32;
            r
        })
        .collect();
    Ok((out, ranges))
}

/// One tick of the truth track: each live UAV's position.
pub type Positions = Vec<(UavId, [f64; 2])>;

/// The live UAVs' positions per tick of a `trajectories.csv` (`tick,t_s,id,x_m,y_m,...,alive,...`).
pub fn positions_by_tick(csv: &str) -> Result<BTreeMap<u64, Positions>, String> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().ok_or("trajectories.csv is empty")?.split(',').collect();
    let col =
        |name: &str| header.iter().position(|h| *h == name).ok_or(format!("trajectories.csv has no `{name}` column"));
    let (tick, id, x, y, alive) = (col("tick")?, col("id")?, col("x_m")?, col("y_m")?, col("alive")?);
    let mut out: BTreeMap<u64, Positions> = BTreeMap::new();
    for (n, line) in lines.enumerate() {
        let c: Vec<&str> = line.split(',').collect();
        let bad = || format!("trajectories.csv line {}: {line:?}", n + 2);
        let get = |i: usize| c.get(i).copied().ok_or_else(bad);
        if get(alive)? != "1" {
            continue;
        }
        let t: u64 = get(tick)?.parse().map_err(|_| bad())?;
        let p = [get(x)?.parse().map_err(|_| bad())?, get(y)?.parse().map_err(|_| bad())?];
        out.entry(t).or_default().push((get(id)?.parse().map_err(|_| bad())?, p));
    }
    Ok(out)
}

/// Per host, the mean over ticks of how many UAVs of other hosts are within `range` of at least
/// one of its UAVs: the senders whose shares must cross into the host (each once per tick, to its
/// one session). `host_of` maps a UAV to its host's index.
pub fn outside_heard_per_tick(
    ticks: &BTreeMap<u64, Positions>,
    host_of: &HashMap<UavId, usize>,
    hosts: usize,
    range: f64,
) -> Vec<f64> {
    let mut sums = vec![0u64; hosts];
    for positions in ticks.values() {
        // A uniform grid of `range` cells: a UAV's neighbours are in its cell and the 8 around.
        let cell = |p: [f64; 2]| ((p[0] / range).floor() as i64, (p[1] / range).floor() as i64);
        let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (i, &(_, p)) in positions.iter().enumerate() {
            grid.entry(cell(p)).or_default().push(i);
        }
        let mut heard: Vec<BTreeSet<UavId>> = vec![BTreeSet::new(); hosts];
        for &(id, p) in positions {
            let Some(&h) = host_of.get(&id) else { continue };
            let (cx, cy) = cell(p);
            for (gx, gy) in (cx - 1..=cx + 1).flat_map(|gx| (cy - 1..=cy + 1).map(move |gy| (gx, gy))) {
                for &j in grid.get(&(gx, gy)).map_or(&[][..], Vec::as_slice) {
                    let (other, q) = positions[j];
                    if host_of.get(&other).is_some_and(|&g| g != h) && (p[0] - q[0]).hypot(p[1] - q[1]) <= range {
                        heard[h].insert(other);
                    }
                }
            }
        }
        for (s, h) in sums.iter_mut().zip(&heard) {
            *s += h.len() as u64;
        }
    }
    let n = ticks.len().max(1) as f64;
    sums.into_iter().map(|s| s as f64 / n).collect()
}

/// What one host of the mesh saw.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HostRow {
    /// Host name (its namespace's suffix).
    pub host: String,
    /// The UAVs it flew.
    pub uavs: usize,
    /// Bytes into its link, as the kernel counted them (`ip -s link`), per tick.
    pub link_rx_kb_per_tick: f64,
    /// Bytes out of its link per tick.
    pub link_tx_kb_per_tick: f64,
    /// Shares from UAVs of other hosts that reached its agent host per tick (its session's count).
    pub remote_shares_per_tick: f64,
    /// Their payload bytes per tick.
    pub remote_share_kb_per_tick: f64,
    /// Shares of those senders that never came between two that did (lost, or never sent), per
    /// tick.
    pub remote_share_gaps_per_tick: f64,
    /// UAVs of other hosts within radio range of one of its UAVs, per tick (truth): what the
    /// remote shares should follow.
    pub outside_heard_per_tick: f64,
    /// The same within range plus the radio's hysteresis (a UAV leaves a radio set only beyond
    /// it): the remote shares lie between the two.
    pub outside_heard_wide_per_tick: f64,
    /// UAVs of other hosts: what every host would receive per tick if each heard every share.
    pub outside_uavs: usize,
}

/// The whole study's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeshReport {
    /// Scenario name.
    pub scenario: String,
    /// `lockstep` or `realtime`.
    pub time_mode: String,
    /// UAVs.
    pub uavs: usize,
    /// Ticks flown.
    pub ticks: u64,
    /// Sim seconds per wall second.
    pub x_real_time: f64,
    /// Commands that arrived after their tick closed, and all commands.
    pub late_commands: u64,
    /// See `late_commands`.
    pub commands: u64,
    /// Collisions.
    pub collisions: usize,
    /// Whether the goal rule was met.
    pub reached_goal: bool,
    /// One row per agent host.
    pub hosts: Vec<HostRow>,
    /// Bytes the hub's link carried, in and out, per tick.
    pub hub_rx_kb_per_tick: f64,
    /// See `hub_rx_kb_per_tick`.
    pub hub_tx_kb_per_tick: f64,
    /// The CPU its pieces used, and how busy the machine was.
    pub cpu: super::cpu::CpuUse,
}

impl MeshReport {
    /// Of the border shares each host's subscriptions should have brought, the share that came:
    /// received / (received + gaps), over all hosts (1 when none was due).
    pub fn delivered(&self) -> f64 {
        let (got, missed) = self.border_shares();
        if got + missed > 0.0 {
            got / (got + missed)
        } else {
            1.0
        }
    }

    /// Border shares per tick over all hosts: (received, never came).
    pub fn border_shares(&self) -> (f64, f64) {
        let sum = |f: fn(&HostRow) -> f64| self.hosts.iter().map(f).sum();
        (sum(|h| h.remote_shares_per_tick), sum(|h| h.remote_share_gaps_per_tick))
    }

    /// Late commands as a share of all commands.
    pub fn late_share(&self) -> f64 {
        if self.commands > 0 {
            self.late_commands as f64 / self.commands as f64
        } else {
            0.0
        }
    }
}

/// The report as a Markdown table with its headline.
pub fn table(r: &MeshReport) -> String {
    let mut t = String::new();
    let late = 100.0 * r.late_share();
    let _ = writeln!(
        t,
        "# swarm mesh: {} ({} UAVs, {}) over {} agent hosts\n\n{:.2}x real time, {} ticks, late commands {} of {} ({late:.2} %), collisions {}, goal {}; hub link {:.1} kB in / {:.1} kB out per tick\n",
        r.scenario,
        r.uavs,
        r.time_mode,
        r.hosts.len(),
        r.x_real_time,
        r.ticks,
        r.late_commands,
        r.commands,
        r.collisions,
        if r.reached_goal { "reached" } else { "not reached" },
        r.hub_rx_kb_per_tick,
        r.hub_tx_kb_per_tick
    );
    let _ = writeln!(t, "Border shares delivered: {:.2} %. {}\n", 100.0 * r.delivered(), cpu_line(&r.cpu));
    let _ = writeln!(t, "| host | UAVs | link in kB/tick | link out kB/tick | shares in from other hosts /tick | their kB/tick | of them never came /tick | other hosts' UAVs in radio range /tick (+ hysteresis) | other hosts' UAVs |");
    let _ = writeln!(t, "|---|---|---|---|---|---|---|---|---|");
    for h in &r.hosts {
        let _ = writeln!(
            t,
            "| {} | {} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} | {:.1} ({:.1}) | {} |",
            h.host,
            h.uavs,
            h.link_rx_kb_per_tick,
            h.link_tx_kb_per_tick,
            h.remote_shares_per_tick,
            h.remote_share_kb_per_tick,
            h.remote_share_gaps_per_tick,
            h.outside_heard_per_tick,
            h.outside_heard_wide_per_tick,
            h.outside_uavs
        );
    }
    t
}

/// The CPU of a flight in a sentence.
fn cpu_line(c: &super::cpu::CpuUse) -> String {
    let roles: Vec<String> = c.by_role.iter().map(|r| format!("{} {:.2}", r.role, r.cores)).collect();
    format!(
        "CPU over {:.0} s: the machine's {} cores {:.0} % busy; cores kept busy by {}",
        c.wall_s,
        c.cores,
        100.0 * c.machine_busy,
        roles.join(", ")
    )
}

/// One size's result in a line, as the sizes study goes.
pub fn size_line(r: &MeshReport) -> String {
    format!(
        "{} UAVs: {:.2}x real time, delivered {:.2} %, late commands {:.2} %, machine {:.0} % busy\n",
        r.uavs,
        r.x_real_time,
        100.0 * r.delivered(),
        100.0 * r.late_share(),
        100.0 * r.cpu.machine_busy
    )
}

/// The sizes study of scenario `name` as a Markdown table: a row per size.
pub fn sizes_table(name: &str, rs: &[MeshReport]) -> String {
    let mut t = String::new();
    let first = rs.first();
    let _ = writeln!(
        t,
        "# swarm mesh by size: {name} over {} agent hosts, {}\n",
        first.map_or(0, |r| r.hosts.len()),
        first.map_or("", |r| r.time_mode.as_str())
    );
    let _ = writeln!(t, "| UAVs | x real time | border shares in /tick | never came /tick | delivered | late commands | machine busy | hub cores | recorder cores | routers cores | agent hosts cores | collisions |");
    let _ = writeln!(t, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rs {
        let (got, missed) = r.border_shares();
        let _ = writeln!(
            t,
            "| {} | {:.2} | {:.1} | {:.2} | {:.2} % | {} of {} ({:.2} %) | {:.0} % of {} | {:.2} | {:.2} | {:.2} | {:.2} | {} |",
            r.uavs,
            r.x_real_time,
            got,
            missed,
            100.0 * r.delivered(),
            r.late_commands,
            r.commands,
            100.0 * r.late_share(),
            100.0 * r.cpu.machine_busy,
            r.cpu.cores,
            r.cpu.cores_of("hub"),
            r.cpu.cores_of("recorder"),
            r.cpu.cores_of("routers"),
            r.cpu.cores_of("agents"),
            r.collisions
        );
    }
    t
}

/// A report with no hosts, for the tests of the tables and the chart.
#[cfg(test)]
pub(crate) fn example(uavs: usize) -> MeshReport {
    MeshReport {
        scenario: "s".into(),
        time_mode: "realtime".into(),
        uavs,
        ticks: 1,
        x_real_time: 1.0,
        late_commands: 0,
        commands: 0,
        collisions: 0,
        reached_goal: false,
        hosts: vec![],
        hub_rx_kb_per_tick: 0.0,
        hub_tx_kb_per_tick: 0.0,
        cpu: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ids `v`, typed.
    fn ids(v: &[u32]) -> Vec<UavId> {
        v.iter().copied().map(UavId::new).collect()
    }

    #[test]
    fn strips_cut_across_the_way_to_the_goal() {
        // Six UAVs in two columns flying along +x: strips by y.
        let starts = [[0.0, 0.0], [0.0, 5.0], [0.0, 10.0], [2.0, 0.0], [2.0, 5.0], [2.0, 10.0]];
        assert_eq!(strips(&starts, [100.0, 5.0], 3), vec![ids(&[1, 4]), ids(&[2, 5]), ids(&[3, 6])]);
        // Flying along +y: strips by x.
        assert_eq!(strips(&starts, [1.0, 100.0], 2), vec![ids(&[4, 5, 6]), ids(&[1, 2, 3])]);
        let all: usize = strips(&starts, [100.0, 5.0], 4).iter().map(Vec::len).sum();
        assert_eq!(all, 6, "every UAV on exactly one host");
    }

    #[test]
    fn renumbering_gives_each_host_a_range_and_keeps_where_each_uav_starts() {
        let mut sc = swarm_config::builtin("open-field-5").expect("builtin");
        sc.swarm.informed = swarm_config::Informed::Ids(ids(&[2, 5]));
        sc.swarm.failed = ids(&[4]);
        let starts = physics_hub::start_positions(&sc);
        let groups = vec![ids(&[2, 4]), ids(&[1, 3, 5])];
        let (out, ranges) = renumbered(&sc, &starts, &groups).expect("renumbered");
        assert_eq!(ranges, vec![ids(&[1, 2]), ids(&[3, 4, 5])]);
        let listed = out.swarm.start_positions.clone().expect("listed");
        assert_eq!(
            listed,
            vec![starts[1], starts[3], starts[0], starts[2], starts[4]],
            "old 2, 4, 1, 3, 5 are new 1 to 5"
        );
        assert!(
            matches!(&out.swarm.informed, swarm_config::Informed::Ids(ids) if ids == &self::ids(&[1, 5])),
            "old 2 and 5"
        );
        assert_eq!(out.swarm.failed, ids(&[2]), "old 4");
        sc.failures.push(serde_json::from_str(r#"{"at_s": 1.0, "uav": 3, "kind": "kill"}"#).expect("a failure"));
        assert!(renumbered(&sc, &starts, &groups).is_err(), "timelines that name UAVs are refused");
    }

    #[test]
    fn a_host_hears_the_other_hosts_uavs_within_range_once_each() {
        let csv = "tick,t_s,id,x_m,y_m,alive\n1,0.1,1,0.0,0.0,1\n1,0.1,2,5.0,0.0,1\n1,0.1,3,8.0,0.0,1\n1,0.1,4,30.0,0.0,1\n2,0.2,1,0.0,0.0,1\n2,0.2,2,5.0,0.0,1\n2,0.2,3,8.0,0.0,0\n2,0.2,4,30.0,0.0,1\n";
        let ticks = positions_by_tick(csv).expect("parses");
        assert_eq!(ticks.len(), 2);
        assert_eq!(ticks[&2].len(), 3, "a dead UAV is heard by no one");
        let host_of: HashMap<UavId, usize> = [(1, 0), (2, 1), (3, 1), (4, 1)].map(|(id, h)| (UavId::new(id), h)).into();
        let heard = outside_heard_per_tick(&ticks, &host_of, 2, 10.0);
        // Host 0 (UAV 1) hears 2 and 3 at tick 1, 2 at tick 2; host 1 hears UAV 1 at both.
        assert_eq!(heard, vec![1.5, 1.0]);
        assert!(positions_by_tick("tick,id\n").is_err(), "columns missing");
        assert!(positions_by_tick("tick,t_s,id,x_m,y_m,alive\n1,0,x,0,0,1\n").is_err(), "a bad number names its line");
    }

    #[test]
    fn the_table_has_a_row_per_host() {
        let host = |h: &str| HostRow {
            host: h.into(),
            uavs: 250,
            link_rx_kb_per_tick: 812.5,
            link_tx_kb_per_tick: 60.0,
            remote_shares_per_tick: 20.0,
            remote_share_kb_per_tick: 1.25,
            remote_share_gaps_per_tick: 0.5,
            outside_heard_per_tick: 21.0,
            outside_heard_wide_per_tick: 22.5,
            outside_uavs: 750,
        };
        let r = MeshReport {
            scenario: "open-1000".into(),
            time_mode: "lockstep".into(),
            uavs: 1000,
            ticks: 600,
            x_real_time: 1.5,
            late_commands: 0,
            commands: 600_000,
            collisions: 0,
            reached_goal: false,
            hosts: vec![host("h1"), host("h2")],
            hub_rx_kb_per_tick: 200.0,
            hub_tx_kb_per_tick: 1700.0,
            cpu: super::super::cpu::CpuUse {
                wall_s: 40.0,
                cores: 2,
                machine_busy: 0.5,
                by_role: vec![super::super::cpu::RoleCpu {
                    role: "hub".into(),
                    processes: 1,
                    cpu_s: 10.0,
                    cores: 0.25,
                }],
            },
        };
        let t = table(&r);
        assert!(t.contains("| h1 | 250 | 812.5 | 60.0 | 20.0 | 1.25 | 0.50 | 21.0 (22.5) | 750 |"), "{t}");
        assert!(t.contains("1.50x real time"), "{t}");
        assert!(t.contains("delivered: 97.56 %"), "20 of 20.5: {t}");
        assert!(t.contains("2 cores 50 % busy; cores kept busy by hub 0.25"), "{t}");
        let mut small = r.clone();
        small.uavs = 100;
        small.late_commands = 600;
        let st = sizes_table("open-1000", &[small, r]);
        assert!(st.starts_with("# swarm mesh by size: open-1000 over 2 agent hosts, lockstep"), "{st}");
        let rows: Vec<&str> = st.lines().filter(|l| l.starts_with("| 1")).collect();
        assert_eq!(rows.len(), 2, "{st}");
        assert_eq!(rows[0], "| 100 | 1.50 | 40.0 | 1.00 | 97.56 % | 600 of 600000 (0.10 %) | 50 % of 2 | 0.25 | 0.00 | 0.00 | 0.00 | 0 |");
        assert!(size_line(&example(1000)).starts_with("1000 UAVs"));
    }

    #[test]
    fn nothing_due_is_all_delivered() {
        let r = example(5);
        assert_eq!((r.delivered(), r.late_share()), (1.0, 0.0));
    }
}
