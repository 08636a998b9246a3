//! The scenario's description of a network impairment and of a partition: the data of a
//! `[[netem]]` rule, after Linux netem (`man tc-netem`) and Jepsen's partition schemes.
//!
//! Why here: a scenario is pure data, and these are part of it (`rule = { ... }`,
//! `partition = { scheme = ... }`, also the JSON of `netem/rules` on the wire). What they *do* to a
//! message (the draws, the delay distributions, which links a partition cuts) is the model in the
//! `netem` crate, which depends on this one; here they are only read and validated, so the schema
//! and the model cannot drift apart and this crate stays free of behaviour.

use serde::{Deserialize, Serialize};
use swarm_types::UavId;

/// The rule for one directed link at one moment. The default is the identity (no impairment).
///
/// Field names carry units; probabilities are in [0, 1]. The exact semantics of each field and
/// the order in which they apply are the `netem` crate's (module `netem::impair`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Impairment {
    /// Mean added delay (s) (netem `delay TIME`).
    #[serde(default)]
    pub delay_s: f64,
    /// Jitter (s) (netem `delay TIME JITTER`): the half-width for `uniform`, the standard deviation
    /// for `normal`, the scale of the standardized table otherwise.
    #[serde(default)]
    pub jitter_s: f64,
    /// Shape of the jitter (netem `distribution`); `uniform` by default, as in netem.
    #[serde(default)]
    pub distribution: JitterDistribution,
    /// Loss model (netem `loss random | gemodel | state`).
    #[serde(default)]
    pub loss: LossModel,
    /// Probability that a message is duplicated (netem `duplicate P`).
    #[serde(default)]
    pub duplicate: f64,
    /// Reordering (netem `reorder P [gap N]`); needs `delay_s > 0`.
    #[serde(default)]
    pub reorder: Option<Reorder>,
    /// Link rate (bytes/s) (netem `rate`): a message of b bytes occupies the link for b / rate
    /// seconds and queues behind the previous one. `None` is unlimited.
    #[serde(default)]
    pub rate_bytes_per_s: Option<f64>,
    /// Drop everything (partition, isolation). A partition sets it on the links it cuts.
    #[serde(default)]
    pub blocked: bool,
    /// Hold everything instead of dropping it: every message is stored, and the stored messages
    /// are delivered at once when the rule for the link stops holding (release). The caller owns
    /// the store; `blocked` wins when both are set.
    #[serde(default)]
    pub hold: bool,
}

impl Default for Impairment {
    fn default() -> Self {
        Impairment::IDENTITY
    }
}

impl Impairment {
    /// No impairment: every message is delivered at the instant it enters the link.
    pub const IDENTITY: Impairment = Impairment {
        delay_s: 0.0,
        jitter_s: 0.0,
        distribution: JitterDistribution::Uniform,
        loss: LossModel::None {},
        duplicate: 0.0,
        reorder: None,
        rate_bytes_per_s: None,
        blocked: false,
        hold: false,
    };

    /// Everything is dropped (a partition or an isolated UAV).
    pub const BLOCKED: Impairment = Impairment { blocked: true, ..Impairment::IDENTITY };

    /// Everything is stored until the link stops holding (a partition in `hold` mode).
    pub const HOLD: Impairment = Impairment { hold: true, ..Impairment::IDENTITY };

    /// Whether this rule changes nothing (the model's free fast path: no draw, no delay).
    #[inline]
    pub fn is_identity(&self) -> bool {
        !self.blocked
            && !self.hold
            && self.delay_s == 0.0
            && self.jitter_s == 0.0
            && self.duplicate == 0.0
            && matches!(self.loss, LossModel::None {})
            && self.reorder.is_none()
            && self.rate_bytes_per_s.is_none()
    }

    /// Checks ranges as iproute2 would: times finite and ≥ 0, probabilities in [0, 1], outgoing
    /// probabilities of a Markov state summing to ≤ 1, reorder gap ≥ 1 and only with a delay,
    /// rate finite and > 0. The error names the dotted path of the bad field.
    pub fn validate(&self) -> Result<(), InvalidImpairment> {
        non_negative("delay_s", self.delay_s)?;
        non_negative("jitter_s", self.jitter_s)?;
        probability("duplicate", self.duplicate)?;
        match self.loss {
            LossModel::None {} => {}
            LossModel::Random { p } => probability("loss.p", p)?,
            LossModel::GilbertElliott { p, r, one_minus_h, one_minus_k } => {
                probability("loss.p", p)?;
                probability("loss.r", r)?;
                probability("loss.one_minus_h", one_minus_h)?;
                probability("loss.one_minus_k", one_minus_k)?;
            }
            LossModel::FourState { p13, p31, p32, p23, p14 } => {
                probability("loss.p13", p13)?;
                probability("loss.p31", p31)?;
                probability("loss.p32", p32)?;
                probability("loss.p23", p23)?;
                probability("loss.p14", p14)?;
                if p13 + p14 > 1.0 {
                    return Err(InvalidImpairment::new("loss.p14", "p13 + p14 must be <= 1"));
                }
                if p31 + p32 > 1.0 {
                    return Err(InvalidImpairment::new("loss.p32", "p31 + p32 must be <= 1"));
                }
            }
        }
        if let Some(r) = &self.reorder {
            probability("reorder.probability", r.probability)?;
            if r.gap == 0 {
                return Err(InvalidImpairment::new("reorder.gap", "must be >= 1"));
            }
            if self.delay_s <= 0.0 {
                // iproute2: "reordering not possible without specifying some delay".
                return Err(InvalidImpairment::new("reorder", "needs delay_s > 0 (as netem)"));
            }
        }
        if let Some(rate) = self.rate_bytes_per_s {
            if !(rate.is_finite() && rate > 0.0) {
                return Err(InvalidImpairment::new("rate_bytes_per_s", "must be a finite number > 0"));
            }
        }
        Ok(())
    }
}

fn non_negative(field: &str, v: f64) -> Result<(), InvalidImpairment> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(InvalidImpairment::new(field, "must be a finite number >= 0"))
    }
}

fn probability(field: &str, v: f64) -> Result<(), InvalidImpairment> {
    if (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(InvalidImpairment::new(field, "must be a probability in [0, 1]"))
    }
}

/// A rule field out of range: its dotted path and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct InvalidImpairment {
    /// Dotted path of the field, e.g. `loss.p13`.
    pub field: String,
    /// What is wrong with it.
    pub reason: String,
}

impl InvalidImpairment {
    fn new(field: &str, reason: &str) -> Self {
        InvalidImpairment { field: field.into(), reason: reason.into() }
    }
}

/// Shape of the delay jitter: netem's `distribution` tables (evaluated analytically by the model).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JitterDistribution {
    /// Uniform in `[delay − jitter, delay + jitter)` (netem's default).
    #[default]
    Uniform,
    /// Normal with standard deviation `jitter`, clipped at about ±4 σ like netem's table.
    Normal,
    /// netem's Pareto table (shape 3, shifted and scaled, capped at about 4 σ).
    Pareto,
    /// netem's `paretonormal`: 25 % normal + 75 % Pareto, summed quantile by quantile.
    ParetoNormal,
}

/// How messages are lost (netem `loss`). The exact draws are described in `netem::impair`.
///
/// Variants without parameters are empty struct variants (`None {}`), not unit variants: serde
/// ignores extra keys in a unit variant's table of an internally tagged enum, so
/// `loss = { model = "none", p = 0.3 }` would pass silently; a struct variant refuses it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum LossModel {
    /// No loss.
    None {},
    /// Independent loss with probability `p` (netem `loss random P`).
    Random {
        /// Loss probability of each message.
        p: f64,
    },
    /// Gilbert–Elliott burst loss, netem `loss gemodel p r 1-h 1-k` (`model = "gemodel"` also
    /// accepted); the loss of a message is decided by the state *before* the transition drawn
    /// with it.
    #[serde(alias = "gemodel")]
    GilbertElliott {
        /// P(Good → Bad) per message.
        p: f64,
        /// P(Bad → Good) per message.
        r: f64,
        /// Loss probability in the Bad state (netem's `1-h`); 1 by default, as iproute2.
        #[serde(default = "one")]
        one_minus_h: f64,
        /// Loss probability in the Good state (netem's `1-k`); 0 by default, as iproute2.
        #[serde(default)]
        one_minus_k: f64,
    },
    /// The 4-state Markov model, netem `loss state p13 p31 p32 p23 p14` (`model = "state"` also
    /// accepted); a message is lost when the state *after* its transition is a loss state (3 or 4).
    #[serde(alias = "state")]
    FourState {
        /// P(1 → 3): from a gap (good reception) into a burst loss.
        p13: f64,
        /// P(3 → 1): from a burst loss back to a gap.
        p31: f64,
        /// P(3 → 2): from a burst loss to good reception within the burst; 0 by default.
        #[serde(default)]
        p32: f64,
        /// P(2 → 3): from good reception within a burst back to a burst loss; 1 by default.
        #[serde(default = "one")]
        p23: f64,
        /// P(1 → 4): an isolated loss within a gap; 0 by default.
        #[serde(default)]
        p14: f64,
    },
}

impl Default for LossModel {
    fn default() -> Self {
        LossModel::None {}
    }
}

fn one() -> f64 {
    1.0
}

/// netem `reorder P [gap N]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Reorder {
    /// Probability that an eligible message is sent at once, ahead of the delayed ones.
    pub probability: f64,
    /// A message is eligible after `gap − 1` messages delayed normally since the last reordered
    /// one; 1 by default (iproute2 sets `gap 1` when only a probability is given).
    #[serde(default = "one_u32")]
    pub gap: u32,
}

fn one_u32() -> u32 {
    1
}

/// Who cannot hear whom: Jepsen's partition schemes (`jepsen.nemesis`) over UAV ids. A node
/// always hears itself; a node a scheme does not list is not affected by it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "scheme", rename_all = "snake_case", deny_unknown_fields)]
pub enum Partition {
    /// No partition: everyone hears everyone (Jepsen's heal). An empty struct variant, not a unit
    /// one, so that extra keys in its table are refused (see [`LossModel`]).
    Healed {},
    /// Explicit groups: two listed nodes hear each other iff some group holds both (Jepsen's
    /// `complete-grudge`; overlapping groups make bridges).
    Groups {
        /// The components.
        groups: Vec<Vec<UavId>>,
    },
    /// Two halves, the first ⌊n/2⌋ nodes against the rest (Jepsen `bisect`: smaller half first).
    Halves {
        /// The nodes, in the order that decides the cut.
        nodes: Vec<UavId>,
    },
    /// One UAV deaf and mute: it hears nobody and nobody hears it (Jepsen
    /// `partition-random-node`, with the node given).
    Isolate {
        /// The isolated UAV.
        node: UavId,
    },
    /// Two halves as [`Partition::Halves`], except the first node of the second half, the bridge,
    /// which hears and is heard by everyone (Jepsen `bridge`).
    Bridge {
        /// The nodes, in the order that decides the cut and the bridge.
        nodes: Vec<UavId>,
    },
    /// Every node hears a majority, no two the same: with m = ⌊n/2⌋ + 1, the node at ring
    /// position j hears positions j − ⌊m/2⌋ … j − ⌊m/2⌋ + m − 1 (mod n). This is Jepsen's
    /// `majorities-ring-perfect` with the ring order given instead of shuffled (Jepsen switches to
    /// a stochastic construction above 5 nodes). For even m the window is lopsided, so some pairs
    /// hear each other one way only, as in Jepsen.
    MajoritiesRing {
        /// The nodes in ring order.
        ring: Vec<UavId>,
    },
    /// One-way: messages from any `from` node to any `to` node are dropped; the reverse is open.
    OneWay {
        /// Senders that cannot be heard by `to`.
        from: Vec<UavId>,
        /// Receivers that cannot hear `from`.
        to: Vec<UavId>,
    },
}

impl Partition {
    /// No partition.
    pub fn heal() -> Partition {
        Partition::Healed {}
    }

    /// `node` deaf and mute.
    pub fn isolate(node: UavId) -> Partition {
        Partition::Isolate { node }
    }

    /// Every node the scheme names.
    pub fn nodes(&self) -> Vec<UavId> {
        match self {
            Partition::Healed {} => Vec::new(),
            Partition::Groups { groups } => groups.iter().flatten().copied().collect(),
            Partition::Halves { nodes } | Partition::Bridge { nodes } => nodes.clone(),
            Partition::Isolate { node } => vec![*node],
            Partition::MajoritiesRing { ring } => ring.clone(),
            Partition::OneWay { from, to } => from.iter().chain(to).copied().collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    fn lossy(loss: LossModel) -> Impairment {
        Impairment { loss, ..Impairment::IDENTITY }
    }

    #[test]
    fn validate_names_the_bad_field() {
        let bad = |rule: Impairment| rule.validate().unwrap_err().field;
        assert_eq!(bad(Impairment { delay_s: -1.0, ..Impairment::IDENTITY }), "delay_s");
        assert_eq!(bad(Impairment { jitter_s: f64::NAN, ..Impairment::IDENTITY }), "jitter_s");
        assert_eq!(bad(Impairment { duplicate: 1.5, ..Impairment::IDENTITY }), "duplicate");
        assert_eq!(
            bad(lossy(LossModel::GilbertElliott { p: 0.1, r: 2.0, one_minus_h: 1.0, one_minus_k: 0.0 })),
            "loss.r"
        );
        assert_eq!(bad(lossy(LossModel::FourState { p13: 0.6, p31: 0.5, p32: 0.0, p23: 1.0, p14: 0.6 })), "loss.p14");
        assert_eq!(
            bad(Impairment { reorder: Some(Reorder { probability: 0.1, gap: 1 }), ..Impairment::IDENTITY }),
            "reorder"
        );
        assert_eq!(
            bad(Impairment {
                delay_s: 0.1,
                reorder: Some(Reorder { probability: 0.1, gap: 0 }),
                ..Impairment::IDENTITY
            }),
            "reorder.gap"
        );
        assert_eq!(bad(Impairment { rate_bytes_per_s: Some(0.0), ..Impairment::IDENTITY }), "rate_bytes_per_s");
        let reordered =
            Impairment { delay_s: 0.1, reorder: Some(Reorder { probability: 0.1, gap: 3 }), ..Impairment::IDENTITY };
        assert!(reordered.validate().is_ok());
        assert!(Impairment::IDENTITY.validate().is_ok());
    }

    #[test]
    fn a_variant_without_parameters_refuses_extra_keys() {
        #[derive(Debug, Deserialize)]
        struct T {
            p: Partition,
            l: LossModel,
        }
        let ok: T = toml::from_str("p = { scheme = \"healed\" }\nl = { model = \"none\" }").unwrap();
        assert_eq!((ok.p, ok.l), (Partition::Healed {}, LossModel::None {}));
        let err = toml::from_str::<T>("p = { scheme = \"healed\", x = 1 }\nl = { model = \"none\" }").unwrap_err();
        assert!(err.to_string().contains('x'), "{err}");
        assert!(toml::from_str::<T>("p = { scheme = \"healed\" }\nl = { model = \"none\", p = 0.3 }").is_err());
        // What `netem/rules` carries is unchanged: the tag alone.
        assert_eq!(serde_json::to_string(&Partition::Healed {}).unwrap(), r#"{"scheme":"healed"}"#);
        assert_eq!(serde_json::to_string(&LossModel::None {}).unwrap(), r#"{"model":"none"}"#);
    }
}
