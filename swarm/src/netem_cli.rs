//! `swarm netem`: change the network faults of a running swarm. Each command becomes a timeline
//! (`[[netem]]` rules and `[[failures]]`, the scenario's schema), sent to the hub on
//! `swarm/{run}/netem/add`; the hub counts its times from its next tick and republishes the whole
//! timeline in force on `swarm/{run}/netem/rules` (`swarm tap 'swarm/{run}/netem/**'` shows it).
//! Semantics are those of the scenario: the latest rule for a link applies, a partition event
//! replaces the partition in force, `heal` clears every link and the partition. `apply FILE`
//! sends a whole experiment file, its times counted from now.

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use netem::impair::{Impairment, JitterDistribution, LossModel, Partition};
use std::process::ExitCode;
use swarm_config::{Failure, FailureKind, NetemRule, Timeline, UavSet};
use swarm_types::UavId;
use swarm_wire::plumbing;
use swarm_wire::{Keys, Msg, NetemAck};

/// `swarm netem`.
#[derive(Args, Debug, Clone)]
pub struct NetemArgs {
    /// Run id.
    #[arg(long)]
    pub run: String,
    /// What to do.
    #[command(subcommand)]
    pub op: NetemOp,
    /// How long to wait for the hub to say it applied the change [s].
    #[arg(long, default_value_t = 10.0)]
    pub wait: f64,
    /// Endpoints.
    #[command(flatten)]
    pub zenoh: swarm_args::ZenohArgs,
}

/// Which links a rule is for.
#[derive(Args, Debug, Clone, Default)]
pub struct LinkSel {
    /// Messages to and from this UAV (both directions).
    #[arg(long, conflicts_with_all = ["from", "to"])]
    pub uav: Option<UavId>,
    /// Senders, e.g. `1,2,3` (default: all).
    #[arg(long)]
    pub from: Option<String>,
    /// Receivers, e.g. `4,5` (default: all).
    #[arg(long)]
    pub to: Option<String>,
}

/// A change to the faults in force.
#[derive(Subcommand, Debug, Clone)]
pub enum NetemOp {
    /// i.i.d. loss of PERCENT % of messages, e.g. `netem loss 30% --uav 7`.
    Loss {
        /// Percent lost (`30` or `30%`).
        #[arg(value_parser = percent)]
        percent: f64,
        /// Links.
        #[command(flatten)]
        links: LinkSel,
    },
    /// Delay every message by MS milliseconds, with normal jitter of `--jitter` ms.
    Delay {
        /// Mean delay [ms].
        ms: f64,
        /// Standard deviation [ms].
        #[arg(long, default_value_t = 0.0)]
        jitter: f64,
        /// Links.
        #[command(flatten)]
        links: LinkSel,
    },
    /// Split the swarm into groups that cannot hear each other, e.g. `netem partition 1,2,3/4,5,6,7`,
    /// or by a Jepsen scheme over the listed nodes, e.g. `netem partition --scheme bridge 1,2,3,4,5`.
    Partition {
        /// Groups separated by `/` (no scheme), or the nodes in the order the scheme reads them.
        groups: String,
        /// A Jepsen scheme instead of explicit groups.
        #[arg(long, value_enum)]
        scheme: Option<Scheme>,
        /// Store the cut links' messages and deliver them at the heal, instead of dropping them.
        #[arg(long)]
        hold: bool,
    },
    /// Freeze a UAV: it hovers where it is and stops talking (an obstacle to the others).
    Freeze {
        /// The UAV.
        uav: UavId,
    },
    /// Send a whole experiment file (`[[netem]]` and `[[failures]]` tables, only `freeze`
    /// failures), its `at_s` counted from the hub's next tick.
    Apply {
        /// The TOML file.
        file: std::path::PathBuf,
    },
    /// Make one UAV deaf and mute.
    Isolate {
        /// The UAV.
        uav: UavId,
    },
    /// Remove every fault: all links pass everything.
    Heal,
}

/// Jepsen's partition schemes (see `netem::impair::Partition`).
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheme {
    /// The first ⌊n/2⌋ nodes against the rest.
    Halves,
    /// Halves, with the first node of the second half hearing everyone.
    Bridge,
    /// Every node hears a majority, no two the same.
    MajoritiesRing,
}

fn percent(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.trim().trim_end_matches('%').parse().map_err(|_| format!("`{s}` is not a percentage"))?;
    if (0.0..=100.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("percent must be in [0, 100], got {v}"))
    }
}

fn ids(s: &str) -> Result<Vec<UavId>> {
    s.split(',').map(|x| x.trim().parse::<UavId>().with_context(|| format!("`{x}` is not a UAV id"))).collect()
}

fn set(s: &Option<String>) -> Result<UavSet> {
    Ok(match s {
        Some(s) => UavSet::Ids(ids(s)?),
        None => UavSet::default(),
    })
}

fn rule(from: UavSet, to: UavSet, rule: Impairment) -> NetemRule {
    NetemRule::link(0.0, from, to, rule)
}

fn rules(netem: Vec<NetemRule>) -> Timeline {
    Timeline { netem, failures: Vec::new() }
}

/// The timeline one command stands for (`at_s` 0: the hub starts it at its next tick).
pub fn timeline_of(op: &NetemOp) -> Result<Timeline> {
    let on_links = |links: &LinkSel, imp: Impairment| -> Result<Timeline> {
        Ok(rules(match links.uav {
            Some(u) => vec![
                rule(UavSet::Ids(vec![u]), UavSet::default(), imp.clone()),
                rule(UavSet::default(), UavSet::Ids(vec![u]), imp),
            ],
            None => vec![rule(set(&links.from)?, set(&links.to)?, imp)],
        }))
    };
    match op {
        NetemOp::Loss { percent, links } => {
            on_links(links, Impairment { loss: LossModel::Random { p: percent / 100.0 }, ..Impairment::IDENTITY })
        }
        NetemOp::Delay { ms, jitter, links } => on_links(
            links,
            Impairment {
                delay_s: ms / 1e3,
                jitter_s: jitter / 1e3,
                distribution: JitterDistribution::Normal,
                ..Impairment::IDENTITY
            },
        ),
        NetemOp::Partition { groups, scheme, hold } => {
            Ok(rules(vec![NetemRule::partition(0.0, partition(groups, *scheme)?, *hold)]))
        }
        NetemOp::Isolate { uav } => Ok(rules(vec![NetemRule::partition(0.0, Partition::isolate(*uav), false)])),
        NetemOp::Heal => Ok(rules(vec![
            rule(UavSet::default(), UavSet::default(), Impairment::IDENTITY),
            NetemRule::partition(0.0, Partition::heal(), false),
        ])),
        NetemOp::Freeze { uav } => Ok(Timeline {
            netem: Vec::new(),
            failures: vec![Failure { at_s: 0.0, uav: *uav, kind: FailureKind::Freeze }],
        }),
        NetemOp::Apply { file } => {
            let t = Timeline::from_file(file)?;
            if let Some(f) = t.failures.iter().find(|f| f.kind != FailureKind::Freeze) {
                bail!(
                    "{}: only `freeze` failures can be applied to a running swarm (UAV {} has {:?})",
                    file.display(),
                    f.uav,
                    f.kind
                );
            }
            Ok(t)
        }
    }
}

fn partition(groups: &str, scheme: Option<Scheme>) -> Result<Partition> {
    let Some(scheme) = scheme else {
        let groups: Vec<Vec<UavId>> = groups.split('/').map(ids).collect::<Result<_>>()?;
        if groups.len() < 2 {
            bail!("partition: give at least two groups, e.g. 1,2,3/4,5");
        }
        return Ok(Partition::Groups { groups });
    };
    let nodes = ids(groups)?;
    if nodes.len() < 2 {
        bail!("partition --scheme: list at least two nodes, e.g. 1,2,3,4,5");
    }
    Ok(match scheme {
        Scheme::Halves => Partition::Halves { nodes },
        Scheme::Bridge => Partition::Bridge { nodes },
        Scheme::MajoritiesRing => Partition::MajoritiesRing { ring: nodes },
    })
}

/// Runs `swarm netem`.
pub async fn netem(a: NetemArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "netem needs --connect <hub endpoint>");
    let keys = Keys::new(&a.run)?;
    let timeline = timeline_of(&a.op)?;
    let json = serde_json::to_string(&timeline)?;
    let s = a.zenoh.open_tool_session().await?;
    // Listen for the hub's answer before asking, so it cannot be missed.
    let (tx, mut acks) = tokio::sync::mpsc::unbounded_channel();
    let _sub = plumbing::subscribe(&s, keys.netem_ack(), tx, |x| {
        serde_json::from_slice::<NetemAck>(&plumbing::payload(x)).ok()
    })
    .await?;
    plumbing::put_once(
        &s,
        &keys.netem_add(),
        Msg::NetemRules(json.clone()).encode()?,
        zenoh::qos::CongestionControl::Block,
    )
    .await?;
    let deadline = tokio::time::Instant::now() + std::time::Duration::from_secs_f64(a.wait.max(0.0));
    let answer = loop {
        match tokio::time::timeout_at(deadline, acks.recv()).await {
            Ok(Some(ack)) if ack.timeline == json => break Some(ack),
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => break None,
        }
    };
    let _ = s.close().await;
    match answer {
        Some(ack) if ack.accepted => {
            swarm_node::process::out(&applied(&timeline, ack.from_s));
            Ok(ExitCode::SUCCESS)
        }
        Some(ack) => bail!("the hub refused the change: {}", ack.reason),
        None => bail!(
            "no answer from the hub of run {} within {} s: the change was not applied. Is the run still flying, and are you an operator? \
             (only an operator may change the faults: --user operator --password-file <run folder>/credentials/operator.password)",
            a.run,
            a.wait
        ),
    }
}

/// What the hub took, in words: each rule and failure at the sim time it acts.
fn applied(t: &swarm_config::Timeline, from_s: Option<f64>) -> String {
    let base = from_s.unwrap_or(0.0);
    let when = match from_s {
        Some(s) => format!("applied from sim t = {s:.1} s"),
        None => "applied (the hub did not say when)".to_string(),
    };
    let mut lines = vec![format!("{when}: {} rule(s), {} failure(s)", t.netem.len(), t.failures.len())];
    for r in &t.netem {
        let what = match &r.partition {
            Some(p) => format!("partition {}", serde_json::to_string(p).unwrap_or_default()),
            None => serde_json::to_string(&r.rule).unwrap_or_default(),
        };
        lines.push(format!("  at sim t = {:.1} s: {what}", base + r.at_s));
    }
    for f in &t.failures {
        lines.push(format!("  at sim t = {:.1} s: UAV {} {}", base + f.at_s, f.uav, f.kind.name()));
    }
    lines.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_become_timelines() {
        let loss = |p| NetemOp::Loss { percent: p, links: LinkSel { uav: Some(UavId::new(7)), ..LinkSel::default() } };
        let r = timeline_of(&loss(30.0)).expect("ok").netem;
        assert_eq!(r.len(), 2, "to and from UAV 7");
        assert_eq!(r[0].from, UavSet::Ids(vec![UavId::new(7)]));
        assert_eq!(r[1].to, UavSet::Ids(vec![UavId::new(7)]));
        assert_eq!(r[0].rule.loss, LossModel::Random { p: 0.3 });
        assert_eq!(percent("30%"), Ok(30.0));
        assert!(percent("130").is_err() && percent("x%").is_err());
        let op = |groups: &str, scheme, hold| NetemOp::Partition { groups: groups.into(), scheme, hold };
        let p = timeline_of(&op("1,2/3/4", None, false)).expect("ok").netem;
        assert_eq!(p.len(), 1);
        let part = p[0].partition.as_ref().expect("a partition event");
        let blocked = |from, to| netem::impair::blocked(part, from, to);
        assert!(
            blocked(UavId::new(1), UavId::new(3))
                && blocked(UavId::new(4), UavId::new(2))
                && !blocked(UavId::new(1), UavId::new(2))
        );
        assert!(!p[0].rule.hold);
        let held = timeline_of(&op("1,2,3,4,5", Some(Scheme::Bridge), true)).expect("ok").netem;
        assert_eq!(
            held[0].partition,
            Some(Partition::Bridge {
                nodes: vec![UavId::new(1), UavId::new(2), UavId::new(3), UavId::new(4), UavId::new(5)]
            })
        );
        assert!(held[0].rule.hold);
        let heal = timeline_of(&NetemOp::Heal).expect("ok").netem;
        assert!(heal[0].rule.is_identity() && heal[1].partition == Some(Partition::Healed {}));
        let f = timeline_of(&NetemOp::Freeze { uav: UavId::new(3) }).expect("ok").failures;
        assert_eq!(f, vec![Failure { at_s: 0.0, uav: UavId::new(3), kind: FailureKind::Freeze }]);
        assert!(timeline_of(&op("1,2", None, false)).is_err());
        assert!(timeline_of(&op("1,x/2", None, false)).is_err());
        assert!(timeline_of(&op("1", Some(Scheme::Halves), false)).is_err());
    }

    #[test]
    fn apply_reads_an_experiment_file_and_refuses_kills() {
        let dir = std::env::temp_dir().join(format!("swarm-netem-apply-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let ok = dir.join("ok.toml");
        std::fs::write(&ok, "[[netem]]\nat_s = 2.0\nrule = { loss = { model = \"random\", p = 0.1 } }\n[[failures]]\nat_s = 1.0\nuav = 2\nkind = \"freeze\"\n").expect("write");
        let t = timeline_of(&NetemOp::Apply { file: ok }).expect("ok");
        assert_eq!((t.netem.len(), t.failures.len()), (1, 1));
        let kill = dir.join("kill.toml");
        std::fs::write(&kill, "[[failures]]\nat_s = 1.0\nuav = 2\nkind = \"kill\"\n").expect("write");
        assert!(timeline_of(&NetemOp::Apply { file: kill }).is_err());
        let bad = dir.join("bad.toml");
        std::fs::write(&bad, "[[netem]]\nat_s = 1.0\nrule = { los = 1 }\n").expect("write");
        let e = timeline_of(&NetemOp::Apply { file: bad.clone() }).expect_err("typo").to_string();
        assert!(e.contains("bad.toml") && e.contains("netem[0].rule"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
