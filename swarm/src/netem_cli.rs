//! `swarm netem`: change the network faults of a running swarm. Each command becomes one or more
//! `[[netem]]` rules (the scenario's schema), sent to the hub on `swarm/{run}/netem/add`; the hub
//! starts them at its next tick and republishes every rule in force on `swarm/{run}/netem/rules`
//! (`swarm tap 'swarm/{run}/netem/**'` shows them). Semantics are those of the scenario rules:
//! the latest rule for a link applies, `heal` clears every link.

use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Subcommand};
use std::process::ExitCode;
use swarm_config::{NetemRule, UavSet};
use swarm_wire::session::{self, Role};
use swarm_wire::{Keys, Msg};
use netem::impair::{Impairment, JitterDistribution, LossModel};

/// `swarm netem`.
#[derive(Args, Debug, Clone)]
pub struct NetemArgs {
    /// Run id.
    #[arg(long)]
    pub run: String,
    /// What to do.
    #[command(subcommand)]
    pub op: NetemOp,
    /// Endpoints.
    #[command(flatten)]
    pub zenoh: crate::cli::ZenohArgs,
}

/// Which links a rule is for.
#[derive(Args, Debug, Clone, Default)]
pub struct LinkSel {
    /// Messages to and from this UAV (both directions).
    #[arg(long, conflicts_with_all = ["from", "to"])]
    pub uav: Option<u32>,
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
    /// i.i.d. loss of PERCENT % of messages, e.g. `netem loss 30 --uav 7`.
    Loss {
        /// Percent lost.
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
    /// Split the swarm into groups that cannot hear each other, e.g. `netem partition 1,2,3/4,5,6,7`.
    Partition {
        /// Groups separated by `/`.
        groups: String,
    },
    /// Make one UAV deaf and mute.
    Isolate {
        /// The UAV.
        uav: u32,
    },
    /// Remove every fault: all links pass everything.
    Heal,
}

fn ids(s: &str) -> Result<Vec<u32>> {
    s.split(',').map(|x| x.trim().parse::<u32>().with_context(|| format!("`{x}` is not a UAV id"))).collect()
}

fn set(s: &Option<String>) -> Result<UavSet> {
    Ok(match s {
        Some(s) => UavSet::Ids(ids(s)?),
        None => UavSet::default(),
    })
}

fn rule(from: UavSet, to: UavSet, rule: Impairment) -> NetemRule {
    NetemRule { at_s: 0.0, from, to, rule }
}

/// The rules one command stands for (`at_s` 0: the hub starts them at its next tick).
pub fn rules_of(op: &NetemOp) -> Result<Vec<NetemRule>> {
    let on_links = |links: &LinkSel, imp: Impairment| -> Result<Vec<NetemRule>> {
        Ok(match links.uav {
            Some(u) => vec![
                rule(UavSet::Ids(vec![u]), UavSet::default(), imp.clone()),
                rule(UavSet::default(), UavSet::Ids(vec![u]), imp),
            ],
            None => vec![rule(set(&links.from)?, set(&links.to)?, imp)],
        })
    };
    match op {
        NetemOp::Loss { percent, links } => {
            if !(0.0..=100.0).contains(percent) {
                bail!("loss: percent must be in [0, 100], got {percent}");
            }
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
        NetemOp::Partition { groups } => {
            let groups: Vec<Vec<u32>> = groups.split('/').map(ids).collect::<Result<_>>()?;
            if groups.len() < 2 {
                bail!("partition: give at least two groups, e.g. 1,2,3/4,5");
            }
            let mut out = Vec::new();
            for (i, a) in groups.iter().enumerate() {
                for (j, b) in groups.iter().enumerate() {
                    if i != j {
                        out.push(rule(UavSet::Ids(a.clone()), UavSet::Ids(b.clone()), Impairment::BLOCKED));
                    }
                }
            }
            Ok(out)
        }
        NetemOp::Isolate { uav } => on_links(&LinkSel { uav: Some(*uav), ..LinkSel::default() }, Impairment::BLOCKED),
        NetemOp::Heal => Ok(vec![rule(UavSet::default(), UavSet::default(), Impairment::IDENTITY)]),
    }
}

/// Runs `swarm netem`.
pub async fn netem(a: NetemArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "netem needs --connect <hub endpoint>");
    let keys = Keys::new(&a.run)?;
    let rules = rules_of(&a.op)?;
    let json = serde_json::to_string(&rules)?;
    let s = session::open(Role::Client, &[], &a.zenoh.connect, &a.zenoh.cfg).await?;
    s.put(keys.netem_add(), Msg::NetemRules(json.clone()).encode()?)
        .encoding(session::encoding())
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .await
        .map_err(|e| anyhow!("zenoh: {e}"))?;
    let _ = s.close().await;
    println!("{json}");
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_become_rules() {
        let r = rules_of(&NetemOp::Loss { percent: 30.0, links: LinkSel { uav: Some(7), ..LinkSel::default() } }).expect("ok");
        assert_eq!(r.len(), 2, "to and from UAV 7");
        assert_eq!(r[0].from, UavSet::Ids(vec![7]));
        assert_eq!(r[1].to, UavSet::Ids(vec![7]));
        assert_eq!(r[0].rule.loss, LossModel::Random { p: 0.3 });
        let p = rules_of(&NetemOp::Partition { groups: "1,2/3/4".into() }).expect("ok");
        assert_eq!(p.len(), 6, "every ordered pair of groups");
        assert!(p.iter().all(|r| r.rule.blocked));
        assert!(rules_of(&NetemOp::Heal).expect("ok")[0].rule.is_identity());
        assert!(rules_of(&NetemOp::Partition { groups: "1,2".into() }).is_err());
        assert!(rules_of(&NetemOp::Loss { percent: 130.0, links: LinkSel::default() }).is_err());
        assert!(rules_of(&NetemOp::Partition { groups: "1,x/2".into() }).is_err());
    }
}
