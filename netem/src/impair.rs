//! The impairment core: what Linux netem would do to each message on one directed link, computed
//! in sim time from a seeded random stream, so an impaired run repeats exactly.
//!
//! # Why
//!
//! The swarm has to be tested over bad radio: late, jittered, lost, bursty, duplicated, reordered
//! and rate-limited messages, and partitions. A real `tc qdisc … netem` needs root, acts on wall
//! time and draws from an unseeded generator, so a run would neither repeat nor stay as lossy at
//! 50× real time as at 1×. This module computes the same decisions purely: sim time (f64 seconds)
//! is handed in, every random draw comes from a ChaCha8 stream owned by one directed link
//! (sender → receiver), and there is no IO and no clock. The semantics follow Linux netem
//! (`net/sched/sch_netem.c`, parsed by iproute2 `tc/q_netem.c`) so a scenario author can read
//! `man tc-netem` and get what it says; partition schemes follow Jepsen's nemesis
//! (`jepsen.nemesis`). Where Toxiproxy overlaps it agrees: its `latency` toxic (latency ± jitter,
//! uniform) is netem's default uniform jitter, its `bandwidth` toxic is [`Impairment::rate_bytes_per_s`],
//! and a `timeout` toxic that never lets data through is [`Impairment::blocked`].
//!
//! # Pieces
//!
//! - [`Impairment`]: the rule for one directed link at one moment, as the scenario writes it
//!   (the data and its validation live in `swarm_config` and are re-exported here, with
//!   [`LossModel`], [`JitterDistribution`], [`Reorder`] and [`Partition`]). Which rule applies to
//!   which link at which sim time is [`crate::Timeline`]'s answer.
//! - [`LinkSim`]: the state of one directed link (its random stream, the burst-loss Markov state,
//!   the rate limiter's queue, the reorder counter). [`LinkSim::decide`] turns a rule, the send
//!   instant and the message size into a [`Decision`]: lost (and why), delivered once, or
//!   delivered twice.
//! - [`Partition`]: who cannot hear whom ([`blocked`]); its answer goes into
//!   [`Impairment::blocked`]. [`Partition::Healed`] is the heal.
//!
//! # What `decide` does, in netem's order (`netem_enqueue`)
//!
//! 1. **Blocked** (partition, isolation): dropped at once with [`LossCause::Blocked`]. No draw, no
//!    state change: the cut is upstream of netem, like Jepsen's iptables drop. **Held**
//!    ([`Impairment::hold`]): stored instead of dropped ([`Decision::Held`]), no draw; the caller
//!    delivers what it stored once the link's rule stops holding. Neither netem nor Jepsen has
//!    this; it is the "store, then flush" of a radio that buffers while out of range.
//! 2. **Identity fast path**: a rule with no impairment ([`Impairment::is_identity`]) delivers at
//!    `now` exactly, with no draw and no allocation.
//! 3. **Duplicate**: one draw if `duplicate > 0` (netem: `q->duplicate >= get_crandom()`).
//! 4. **Loss model**: [`LossModel`] decides (draws described below). netem then keeps
//!    `count = 1 + duplicated − lost` copies; `count == 0` is [`LossCause::LossModel`]. So a message
//!    both duplicated and lost still gets through once, as in netem.
//! 5. **The duplicate** (when `count == 2`): netem clones the packet and re-enqueues the clone at
//!    the root qdisc with `tc_depth + 1` *before* scheduling the original; the clone therefore
//!    takes its own loss decision (advancing the loss model), its own reorder/delay/rate slot, and
//!    is never duplicated again. We do the same, in the same order.
//! 6. **Reorder** (`reorder P gap N`): if the reorder counter is at least `N − 1` and a draw is
//!    below `P`, the message is sent immediately (netem puts it at the head of the queue with
//!    `time_to_send = now`: no delay, no rate slot) and the counter resets to 0. Otherwise it is
//!    delayed normally and the counter increases. With `gap 1` (iproute2's default when only a
//!    probability is given) every message is reordered with probability `P`; with `gap 5` and
//!    `P = 1` exactly every 5th. Reordering needs a delay to be visible; iproute2 refuses it
//!    without one, and so does [`Impairment::validate`].
//! 7. **Delay**: `delay_s + jitter_s · Q(u)` with one uniform draw `u` when `jitter_s > 0`
//!    (netem `tabledist`; no draw when the jitter is 0), clamped at 0 (netem sends a packet whose
//!    time has passed at once). Different jitters reorder messages, as netem's time-sorted
//!    queue (tfifo) does.
//! 8. **Rate**: a message of `b` bytes occupies the link for `b / rate` seconds, after its delay,
//!    and queues behind the last scheduled one: `t = max(now + delay, busy_until) + b / rate`, then
//!    `busy_until = t` (netem: the last packet in the queue is the reference point). So
//!    back-to-back messages are spaced by `b / rate` and the throughput is the rate.
//!
//! # Loss models, exactly
//!
//! Probabilities are compared as `u < p` with `u` uniform in [0, 1) (netem compares u32 draws to
//! thresholds scaled to 2³²): `p = 0` never fires, `p = 1` always does.
//!
//! - [`LossModel::Random`] (`loss random P`): one draw per message when `P > 0`, lost if `u < P`.
//! - [`LossModel::GilbertElliott`] (`loss gemodel p [r [1-h [1-k]]]`, netem `loss_gilb_ell`): two
//!   states, Good and Bad, starting in Good (netem `get_loss_clg` sets `GOOD_STATE`). Per message,
//!   first draw: the transition (Good → Bad with `p`, Bad → Good with `r`); second draw: the loss,
//!   with the loss probability **of the state before the transition** (`1 − k` in Good, `1 − h`
//!   in Bad). That is how the kernel's `switch (clg->state)` reads: the case branch is chosen by the
//!   old state, it may set the new state, and then compares its second draw to the old state's
//!   threshold. So message n sees state Sₙ and Sₙ₊₁ is drawn for the next one. Fields carry the
//!   command-line values: `one_minus_h` is what you type as `1-h` (iproute2 stores
//!   `h = 1 − (1-h)` because the kernel loses in Bad when `rnd > h`), `one_minus_k` is `1-k`
//!   (iproute2 passes it as `k1`, the kernel loses in Good when `rnd < k1`). Defaults as iproute2:
//!   `1-h = 1`, `1-k = 0`; `r` must be given (iproute2 would default it to `1 − p`). Stationary
//!   loss rate: `π_B (1−h) + π_G (1−k)` with `π_B = p / (p + r)`; for `1-h = 1, 1-k = 0` the
//!   losses are exactly the Bad sojourns, whose length is geometric with mean `1 / r`.
//! - [`LossModel::FourState`] (`loss state p13 [p31 [p32 [p23 [p14]]]]`, netem `loss_4state`,
//!   the GI model of Salsano et al. after Salamatian): states 1 = received in a gap period,
//!   2 = received in a burst, 3 = lost in a burst, 4 = isolated loss in a gap; start in 1
//!   (`TX_IN_GAP_PERIOD`). One draw per message moves the chain (1 → 4 with `p14`, 1 → 3 with
//!   `p13`, else stay; 2 → 3 with `p23`, else stay; 3 → 2 with `p32`, 3 → 1 with `p31`, else
//!   stay; 4 → 1 always) and the message is lost **if the new state is 3 or 4** — the opposite
//!   convention to `gemodel`, as in the kernel. Defaults as iproute2: `p32 = 0`, `p23 = 1`,
//!   `p14 = 0`; `p31` must be given (iproute2 would default it to `1 − p13`, the Bernoulli case).
//!   [`expected_loss_rate`] gives the stationary rate.
//!
//! The Markov state persists while the rule changes over sim time (a link that leaves a burst-loss
//! window and re-enters it resumes its chain); [`LinkSim::reset`] restarts it as a
//! `tc qdisc change` that sets a loss model does.
//!
//! # Jitter distributions (netem's tables, analytically)
//!
//! netem turns one uniform draw into a value through an inverse-CDF table of s16 entries scaled by
//! 8192 (`NETEM_DIST_SCALE`), so every table is clipped to about ±4 σ; `tabledist` returns
//! `mu + sigma · t / 8192`. We evaluate the same quantile functions `Q(u)` in closed form
//! ([`jitter_quantile`]; iproute2 `netem/*.c` generate the tables from them) and keep the clip at
//! `[−32768, 32767] / 8192`:
//!
//! - `uniform` (netem's default without `distribution`): `Q(u) = 2u − 1`, so the delay is
//!   uniform in `[delay − jitter, delay + jitter)` and its standard deviation is `jitter / √3`.
//! - `normal`: `Q(u) = Φ⁻¹(u)` (Acklam's rational approximation, relative error < 1.2·10⁻⁹):
//!   `jitter` is the standard deviation.
//! - `pareto`: `Q(u) = (4/3)·((1 − u)^(−1/3) − 1.5)` (shape 3, `pareto.c`), capped at 32767/8192:
//!   minimum `−2/3`, median `−0.320`, mean `−0.033` (0 before the cap), a long right tail.
//! - `paretonormal`: `Q(u) = (Φ⁻¹(u) + 3·pareto(u)) / 4`, both at the same `u`
//!   (`paretonormal.c` sums the two tables entry by entry: 25 % normal, 75 % Pareto).
//!
//! # Not modelled (and why)
//!
//! - Correlation (`delay 100ms 10ms 25%`, `loss 1% 25%`, …): netem's `get_crandom` blends each
//!   uniform draw with the previous one, which shrinks the spread and does not preserve the
//!   configured distribution or rate; bursty loss is modelled properly by the two Markov models.
//! - `corrupt`, `ecn`, `slot`, `limit` (queue length), and `rate`'s packet and cell overheads.
//!
//! # Determinism
//!
//! Each [`LinkSim`] owns a ChaCha8 generator keyed by the run seed and a tag, on the stream of its
//! directed link: key = `run_seed` (8 bytes little-endian) ‖ `b"swarm/netem/link/v1"` padded with
//! zeros to 24 bytes; stream = `(from << 32) | to`. The tag keeps these streams apart from every
//! `seed_from_u64` stream elsewhere in the workspace; the stream id gives each directed link its
//! own non-overlapping sequence, so adding traffic on one link never shifts the draws of another,
//! and `a → b` and `b → a` are independent. Same seed and same messages, same decisions.
//!
//! # Time
//!
//! `now` is the sim time (seconds) at which the message enters the link, normally its send
//! instant; returned instants are sim times. In lockstep mode every delay is therefore sim time,
//! however fast the run goes. The caller applies its own floor (one tick in lockstep, see
//! [`crate::Link::on_receive`]).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
pub use swarm_config::{Impairment, InvalidImpairment, JitterDistribution, LossModel, Partition, Reorder};
use swarm_types::UavId;

/// The lowest value of netem's distribution tables: `i16::MIN / NETEM_DIST_SCALE`.
const DIST_MIN: f64 = -32768.0 / 8192.0;
/// The highest value of netem's distribution tables: `i16::MAX / NETEM_DIST_SCALE`.
const DIST_MAX: f64 = 32767.0 / 8192.0;

/// Tag mixed into the key of every link stream (see the module doc, "Determinism").
const KEY_TAG: &[u8; 19] = b"swarm/netem/link/v1";

/// The standardized value netem's table for `distribution` holds at quantile `u` in [0, 1),
/// before scaling by the jitter and adding the delay (`tabledist`).
#[inline]
pub fn jitter_quantile(distribution: JitterDistribution, u: f64) -> f64 {
    match distribution {
        // tabledist without a table: (rnd % 2σ) + μ − σ.
        JitterDistribution::Uniform => 2.0 * u - 1.0,
        // normal.c: the inverse normal CDF, stored as s16 / 8192.
        JitterDistribution::Normal => inverse_normal_cdf(u).clamp(DIST_MIN, DIST_MAX),
        // pareto.c: 1/pow(v, 1/3) − 1.5, times 4/3, capped at 32767 / 8192.
        JitterDistribution::Pareto => pareto_table(u),
        // paretonormal.c: (normvalue + 3 * parvalue) / 4 at the same table index, clipped.
        JitterDistribution::ParetoNormal => {
            let normal = inverse_normal_cdf(u).clamp(DIST_MIN, DIST_MAX);
            ((normal + 3.0 * pareto_table(u)) / 4.0).clamp(DIST_MIN, DIST_MAX)
        }
    }
}

/// netem's Pareto table at quantile `u` (iproute2 `netem/pareto.c`, shape a = 3).
#[inline]
fn pareto_table(u: f64) -> f64 {
    let v = 1.0 - u; // in (0, 1]: the table runs from dvalue = 1 down
    ((4.0 / 3.0) * (v.powf(-1.0 / 3.0) - 1.5)).min(DIST_MAX)
}

/// Φ⁻¹(p), the standard normal quantile, by P. J. Acklam's rational approximation (relative
/// error below 1.15·10⁻⁹). `p = 0` gives −∞ (callers clip).
fn inverse_normal_cdf(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] =
        [7.784_695_709_041_462e-3, 3.224_671_290_700_398e-1, 2.445_134_137_142_996, 3.754_408_661_907_416];
    const P_LOW: f64 = 0.02425;
    if p <= 0.0 {
        return f64::NEG_INFINITY;
    }
    if p >= 1.0 {
        return f64::INFINITY;
    }
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < P_LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - P_LOW {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// The long-run fraction of messages `model` loses (for a chain started where netem starts it:
/// Good, or state 1). Independent of duplication, which only adds messages.
pub fn expected_loss_rate(model: &LossModel) -> f64 {
    match *model {
        LossModel::None {} => 0.0,
        LossModel::Random { p } => p,
        LossModel::GilbertElliott { p, r, one_minus_h, one_minus_k } => {
            if p + r == 0.0 {
                return one_minus_k; // never leaves Good
            }
            let pi_bad = p / (p + r);
            pi_bad * one_minus_h + (1.0 - pi_bad) * one_minus_k
        }
        LossModel::FourState { p13, p31, p32, p23, p14 } => {
            if p13 == 0.0 {
                // Only states 1 and 4: π₄ = p14 π₁.
                return p14 / (1.0 + p14);
            }
            if p31 == 0.0 {
                // Eventually trapped in {2, 3}: π₂ p23 = π₃ p32.
                return if p32 == 0.0 { 1.0 } else { p23 / (p23 + p32) };
            }
            if p32 > 0.0 && p23 == 0.0 {
                return 0.0; // eventually trapped in state 2
            }
            // Balance: π₄ = p14 π₁, π₃ p31 = p13 π₁, π₂ p23 = p32 π₃.
            let (pi1, pi4, pi3) = (1.0, p14, p13 / p31);
            let pi2 = if p32 == 0.0 { 0.0 } else { pi3 * p32 / p23 };
            (pi3 + pi4) / (pi1 + pi2 + pi3 + pi4)
        }
    }
}

/// Why a message was not delivered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum LossCause {
    /// The link is blocked (partition or isolation).
    Blocked,
    /// The loss model dropped it.
    LossModel,
    /// The radio's distance-dependent loss dropped it ([`LinkSim::radio_loss`]).
    Radio,
}

/// What the link does with one message: 0, 1 or 2 deliveries, at sim times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decision {
    /// Not delivered.
    Lost(LossCause),
    /// Delivered once, at this sim time.
    Deliver(f64),
    /// Duplicated and both copies survived: the original's and the copy's delivery instants.
    Duplicate(f64, f64),
    /// Stored by a holding link, to be delivered when it releases ([`Impairment::hold`]).
    Held,
}

impl Decision {
    /// How many copies are delivered (0, 1 or 2).
    #[inline]
    pub fn copies(&self) -> usize {
        match self {
            Decision::Lost(_) | Decision::Held => 0,
            Decision::Deliver(_) => 1,
            Decision::Duplicate(..) => 2,
        }
    }

    /// The delivery instants, original first.
    #[inline]
    pub fn instants(&self) -> impl Iterator<Item = f64> {
        let (at, n) = match *self {
            Decision::Lost(_) | Decision::Held => ([0.0, 0.0], 0),
            Decision::Deliver(a) => ([a, 0.0], 1),
            Decision::Duplicate(a, b) => ([a, b], 2),
        };
        at.into_iter().take(n)
    }
}

/// What one directed link has done since it was created.
///
/// `delivered = offered − blocked − held − lost + duplicated` always holds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkStats {
    /// Messages handed to [`LinkSim::decide`].
    pub offered: u64,
    /// Messages dropped because the link was blocked.
    pub blocked: u64,
    /// Messages stored by a holding link.
    pub held: u64,
    /// Messages dropped by the radio's distance-dependent loss.
    pub radio_lost: u64,
    /// Copies the loss model dropped (a duplicate's own loss included).
    pub lost: u64,
    /// Messages duplicated.
    pub duplicated: u64,
    /// Copies sent at once by reordering.
    pub reordered: u64,
    /// Copies scheduled for delivery.
    pub delivered: u64,
}

/// The 4-state model's states (netem's `TX_IN_GAP_PERIOD`, …), numbered as in the paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum GiState {
    /// 1: received, in a gap period.
    RxGap,
    /// 2: received, in a burst period.
    RxBurst,
    /// 3: lost, in a burst period.
    LostBurst,
    /// 4: isolated loss, in a gap period.
    LostGap,
}

/// The state of one directed link (sender → receiver): its random stream, the burst-loss Markov
/// states, the rate limiter's queue and the reorder counter.
#[derive(Debug, Clone)]
pub struct LinkSim {
    rng: ChaCha8Rng,
    /// Gilbert–Elliott: in the Bad state (netem starts Good).
    ge_bad: bool,
    /// 4-state model state (netem starts in `TX_IN_GAP_PERIOD`).
    gi: GiState,
    /// Sim time at which the last rate-limited message finishes (netem's last `time_to_send`).
    busy_until: f64,
    /// Messages delayed normally since the last reordered one (netem `q->counter`).
    reorder_counter: u32,
    stats: LinkStats,
}

impl LinkSim {
    /// The link `from → to` of the run seeded `run_seed`, on its own stream (see the module doc,
    /// "Determinism").
    pub fn new(run_seed: u64, from: UavId, to: UavId) -> LinkSim {
        let mut key = [0u8; 32];
        key[..8].copy_from_slice(&run_seed.to_le_bytes());
        key[8..8 + KEY_TAG.len()].copy_from_slice(KEY_TAG);
        let mut rng = ChaCha8Rng::from_seed(key);
        rng.set_stream((u64::from(from.get()) << 32) | u64::from(to.get()));
        LinkSim {
            rng,
            ge_bad: false,
            gi: GiState::RxGap,
            busy_until: f64::NEG_INFINITY,
            reorder_counter: 0,
            stats: LinkStats::default(),
        }
    }

    /// Decides the fate of a message of `bytes` bytes entering the link at sim time `now` under
    /// `rule` (assumed valid, see [`Impairment::validate`]). The identity rule costs a few
    /// comparisons: no draw, no allocation, delivery at `now`.
    #[inline]
    pub fn decide(&mut self, rule: &Impairment, now: f64, bytes: usize) -> Decision {
        self.stats.offered += 1;
        if rule.is_identity() {
            self.stats.delivered += 1;
            return Decision::Deliver(now);
        }
        self.decide_impaired(rule, now, bytes)
    }

    /// The radio's distance-dependent loss (SPEC section 7): one draw from this link's stream
    /// when `p > 0`, true (lost, counted) if it is below `p`. Called before [`LinkSim::decide`]
    /// for a message the radio may lose; a lost message never reaches netem.
    #[inline]
    pub fn radio_loss(&mut self, p: f64) -> bool {
        let lost = p > 0.0 && self.uniform() < p;
        if lost {
            self.stats.radio_lost += 1;
        }
        lost
    }

    /// Counts since creation.
    pub fn stats(&self) -> LinkStats {
        self.stats
    }

    /// Restarts the loss models (Good, state 1) and the reorder counter, as netem does when
    /// `tc qdisc change` sets a loss model; the rate limiter's queue and the stream go on.
    pub fn reset(&mut self) {
        self.ge_bad = false;
        self.gi = GiState::RxGap;
        self.reorder_counter = 0;
    }

    /// `netem_enqueue` for a rule that is not the identity. Out of line, so that the identity
    /// fast path of [`LinkSim::decide`] stays small enough to inline at the call site.
    #[inline(never)]
    fn decide_impaired(&mut self, rule: &Impairment, now: f64, bytes: usize) -> Decision {
        if rule.blocked {
            self.stats.blocked += 1;
            return Decision::Lost(LossCause::Blocked);
        }
        if rule.hold {
            self.stats.held += 1;
            return Decision::Held;
        }
        // Random duplication: netem draws only when the probability is set.
        let duplicated = rule.duplicate > 0.0 && self.uniform() < rule.duplicate;
        let lost = self.loss_event(&rule.loss);
        if lost {
            self.stats.lost += 1;
        }
        if duplicated {
            self.stats.duplicated += 1;
        }
        match (duplicated, lost) {
            (false, true) => Decision::Lost(LossCause::LossModel),
            (true, false) => {
                // netem re-enqueues the clone at the root qdisc (tc_depth + 1, so never duplicated
                // again) before scheduling the original: it takes its own loss decision and slot.
                let copy = if self.loss_event(&rule.loss) {
                    self.stats.lost += 1;
                    None
                } else {
                    Some(self.schedule(rule, now, bytes))
                };
                let original = self.schedule(rule, now, bytes);
                match copy {
                    Some(c) => Decision::Duplicate(original, c),
                    None => Decision::Deliver(original),
                }
            }
            // Neither, or duplicated and lost: count = 1, the original goes on.
            _ => Decision::Deliver(self.schedule(rule, now, bytes)),
        }
    }

    /// The delivery instant of one surviving copy: reorder, else delay then rate.
    fn schedule(&mut self, rule: &Impairment, now: f64, bytes: usize) -> f64 {
        self.stats.delivered += 1;
        if let Some(r) = &rule.reorder {
            // netem: reorder unless gap == 0, or counter < gap − 1, or reorder < rnd.
            if r.gap > 0 && self.reorder_counter >= r.gap - 1 && r.probability > 0.0 && self.uniform() < r.probability {
                // Head of the queue, time_to_send = now: no delay, no rate slot.
                self.reorder_counter = 0;
                self.stats.reordered += 1;
                return now;
            }
        }
        let delay = if rule.jitter_s > 0.0 {
            let u = self.uniform();
            rule.delay_s + rule.jitter_s * jitter_quantile(rule.distribution, u)
        } else {
            rule.delay_s
        };
        let mut at = now + delay.max(0.0);
        if let Some(rate) = rule.rate_bytes_per_s {
            // netem: the last packet in the queue is the reference point; serialization follows.
            at = at.max(self.busy_until) + bytes as f64 / rate;
            self.busy_until = at;
        }
        self.reorder_counter = self.reorder_counter.saturating_add(1);
        at
    }

    /// netem `loss_event`: whether the loss model drops this copy (advancing its Markov chain).
    fn loss_event(&mut self, model: &LossModel) -> bool {
        match *model {
            LossModel::None {} => false,
            LossModel::Random { p } => p > 0.0 && self.uniform() < p,
            LossModel::GilbertElliott { p, r, one_minus_h, one_minus_k } => {
                // loss_gilb_ell: the case is the old state; first draw moves the chain, second
                // draw is compared to the old state's loss probability.
                let was_bad = self.ge_bad;
                let transition = self.uniform();
                if was_bad {
                    if transition < r {
                        self.ge_bad = false;
                    }
                } else if transition < p {
                    self.ge_bad = true;
                }
                let loss = if was_bad { one_minus_h } else { one_minus_k };
                self.uniform() < loss
            }
            LossModel::FourState { p13, p31, p32, p23, p14 } => {
                // loss_4state: one draw moves the chain; lost iff the new state is a loss state.
                let u = self.uniform();
                self.gi = match self.gi {
                    GiState::RxGap if u < p14 => GiState::LostGap,
                    GiState::RxGap if u < p13 + p14 => GiState::LostBurst,
                    GiState::RxGap => GiState::RxGap,
                    GiState::RxBurst if u < p23 => GiState::LostBurst,
                    GiState::RxBurst => GiState::RxBurst,
                    GiState::LostBurst if u < p32 => GiState::RxBurst,
                    GiState::LostBurst if u < p31 + p32 => GiState::RxGap,
                    GiState::LostBurst => GiState::LostBurst,
                    GiState::LostGap => GiState::RxGap,
                };
                matches!(self.gi, GiState::LostBurst | GiState::LostGap)
            }
        }
    }

    /// One uniform draw in [0, 1) from this link's stream.
    #[inline]
    fn uniform(&mut self) -> f64 {
        self.rng.gen::<f64>()
    }
}

/// Whether the message `from → to` is dropped under `partition` (a node always hears itself).
pub fn blocked(partition: &Partition, from: UavId, to: UavId) -> bool {
    if from == to {
        return false;
    }
    match partition {
        Partition::Healed {} => false,
        Partition::Groups { groups } => {
            let listed = |n: UavId| groups.iter().any(|g| g.contains(&n));
            listed(from) && listed(to) && !groups.iter().any(|g| g.contains(&from) && g.contains(&to))
        }
        Partition::Halves { nodes } => {
            let half = nodes.len() / 2;
            match (side(nodes, half, from), side(nodes, half, to)) {
                (Some(a), Some(b)) => a != b,
                _ => false,
            }
        }
        Partition::Isolate { node } => from == *node || to == *node,
        Partition::Bridge { nodes } => {
            let half = nodes.len() / 2;
            let bridge = nodes.get(half).copied();
            if bridge == Some(from) || bridge == Some(to) {
                return false;
            }
            match (side(nodes, half, from), side(nodes, half, to)) {
                (Some(a), Some(b)) => a != b,
                _ => false,
            }
        }
        Partition::MajoritiesRing { ring } => {
            let n = ring.len();
            let (Some(i), Some(j)) = (position(ring, from), position(ring, to)) else {
                return false;
            };
            let m = n / 2 + 1;
            // The receiver j hears offsets −⌊m/2⌋ … m − 1 − ⌊m/2⌋ around itself.
            let back = m / 2;
            let offset = (i + n + back - j) % n; // position of i in j's window, from its start
            offset >= m
        }
        Partition::OneWay { from: senders, to: receivers } => senders.contains(&from) && receivers.contains(&to),
    }
}

/// Whether `node` is in the first half (`Some(false)`), the second (`Some(true)`) or absent.
fn side(nodes: &[UavId], half: usize, node: UavId) -> Option<bool> {
    position(nodes, node).map(|i| i >= half)
}

fn position(nodes: &[UavId], node: UavId) -> Option<usize> {
    nodes.iter().position(|&n| n == node)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    const N: usize = 200_000;

    /// Five binomial standard deviations of a rate `p` over `n` trials (and a floor for p ≈ 0).
    fn tol(p: f64, n: usize) -> f64 {
        5.0 * (p * (1.0 - p) / n as f64).sqrt() + 1e-9
    }

    fn words(l: &LinkSim) -> u128 {
        l.rng.get_word_pos()
    }

    fn lossy(loss: LossModel) -> Impairment {
        Impairment { loss, ..Impairment::IDENTITY }
    }

    /// The loss pattern (true = lost) of `n` messages on a fresh link.
    fn loss_pattern(rule: &Impairment, n: usize, seed: u64) -> Vec<bool> {
        let mut l = LinkSim::new(seed, UavId::new(1), UavId::new(2));
        (0..n).map(|k| l.decide(rule, k as f64 * 0.01, 100).copies() == 0).collect()
    }

    fn mean_std(xs: &[f64]) -> (f64, f64) {
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var.sqrt())
    }

    /// Lengths of the runs of consecutive losses.
    fn bursts(pattern: &[bool]) -> Vec<usize> {
        let mut out = Vec::new();
        let mut run = 0;
        for &lost in pattern {
            if lost {
                run += 1;
            } else if run > 0 {
                out.push(run);
                run = 0;
            }
        }
        out
    }

    #[test]
    fn identity_delivers_at_now_with_no_draw() {
        let mut l = LinkSim::new(7, UavId::new(1), UavId::new(2));
        let before = words(&l);
        for k in 0..1000 {
            let now = 0.1 * k as f64;
            assert_eq!(l.decide(&Impairment::IDENTITY, now, 500), Decision::Deliver(now));
        }
        assert_eq!(words(&l), before, "the identity draws nothing");
        assert!(Impairment::default().is_identity());
        // A fixed delay alone draws nothing either (netem tabledist: sigma == 0 returns mu).
        let fixed = Impairment { delay_s: 0.25, ..Impairment::IDENTITY };
        assert!(!fixed.is_identity());
        assert_eq!(l.decide(&fixed, 1.0, 10), Decision::Deliver(1.25));
        assert_eq!(words(&l), before);
        assert_eq!(l.stats().delivered, 1001);
    }

    #[test]
    fn blocked_drops_everything_without_draws_or_state_change() {
        let mut l = LinkSim::new(7, UavId::new(1), UavId::new(2));
        let ge = LossModel::GilbertElliott { p: 1.0, r: 0.0, one_minus_h: 1.0, one_minus_k: 0.0 };
        let rule = Impairment { blocked: true, loss: ge, ..Impairment::IDENTITY };
        let before = words(&l);
        for k in 0..1000 {
            assert_eq!(l.decide(&rule, k as f64, 10), Decision::Lost(LossCause::Blocked));
        }
        assert_eq!(words(&l), before);
        assert!(!l.ge_bad, "a blocked link does not advance the loss model");
        assert_eq!(l.stats().blocked, 1000);
        assert_eq!(l.decide(&Impairment::BLOCKED, 0.0, 1), Decision::Lost(LossCause::Blocked));
    }

    #[test]
    fn random_loss_rate_matches_p() {
        for p in [0.01, 0.1, 0.3, 0.5] {
            let pattern = loss_pattern(&lossy(LossModel::Random { p }), N, 1);
            let rate = pattern.iter().filter(|&&x| x).count() as f64 / N as f64;
            assert!((rate - p).abs() < tol(p, N), "p {p}: measured {rate}");
            eprintln!("random loss {p}: measured {rate:.4}");
            // Independent: the mean burst length is 1 / (1 − p).
            let b = bursts(&pattern);
            let mean_burst = b.iter().sum::<usize>() as f64 / b.len() as f64;
            assert!((mean_burst - 1.0 / (1.0 - p)).abs() < 0.03 / (1.0 - p), "p {p}: bursts {mean_burst}");
        }
        assert!(loss_pattern(&lossy(LossModel::Random { p: 0.0 }), 1000, 1).iter().all(|&x| !x));
        assert!(loss_pattern(&lossy(LossModel::Random { p: 1.0 }), 1000, 1).iter().all(|&x| x));
    }

    #[test]
    fn gemodel_loss_uses_the_state_before_the_transition() {
        // p = 1: the first message moves Good → Bad but is judged by Good (1-k = 0): delivered.
        // Every later one is judged by Bad (1-h = 1, r = 0): lost.
        let ge = LossModel::GilbertElliott { p: 1.0, r: 0.0, one_minus_h: 1.0, one_minus_k: 0.0 };
        let pattern = loss_pattern(&lossy(ge), 100, 3);
        assert!(!pattern[0], "judged by the state before the transition");
        assert!(pattern[1..].iter().all(|&x| x));
        // And back: Bad → Good with r = 1 only takes effect for the next message.
        let mut l = LinkSim::new(3, UavId::new(1), UavId::new(2));
        l.ge_bad = true;
        let back = LossModel::GilbertElliott { p: 0.0, r: 1.0, one_minus_h: 1.0, one_minus_k: 0.0 };
        assert_eq!(l.decide(&lossy(back), 0.0, 1), Decision::Lost(LossCause::LossModel));
        assert_eq!(l.decide(&lossy(back), 0.0, 1), Decision::Deliver(0.0));
    }

    #[test]
    fn gemodel_simple_gilbert_rate_and_burst_length() {
        // 1-h = 1, 1-k = 0: losses are exactly the Bad sojourns.
        let (p, r) = (0.05, 0.25);
        let ge = LossModel::GilbertElliott { p, r, one_minus_h: 1.0, one_minus_k: 0.0 };
        let n = 400_000;
        let pattern = loss_pattern(&lossy(ge), n, 11);
        let rate = pattern.iter().filter(|&&x| x).count() as f64 / n as f64;
        let expected = p / (p + r);
        assert!((expected_loss_rate(&ge) - expected).abs() < 1e-12);
        // Correlated samples: allow 4× the i.i.d. tolerance (variance inflation (2 − p − r)/(p + r)).
        assert!((rate - expected).abs() < 4.0 * tol(expected, n), "rate {rate} vs {expected}");
        let b = bursts(&pattern);
        let mean_burst = b.iter().sum::<usize>() as f64 / b.len() as f64;
        assert!((mean_burst - 1.0 / r).abs() < 0.05, "mean burst {mean_burst} vs {}", 1.0 / r);
        // Gaps (runs of deliveries) are geometric with mean 1 / p.
        let gaps = bursts(&pattern.iter().map(|x| !x).collect::<Vec<_>>());
        let mean_gap = gaps.iter().sum::<usize>() as f64 / gaps.len() as f64;
        assert!((mean_gap - 1.0 / p).abs() < 0.5, "mean gap {mean_gap} vs {}", 1.0 / p);
        eprintln!("gemodel p={p} r={r} 1-h=1 1-k=0: loss {rate:.4} (expected {expected:.4}), mean burst {mean_burst:.3} (expected {}), mean gap {mean_gap:.2} (expected {})", 1.0 / r, 1.0 / p);
    }

    #[test]
    fn gemodel_full_stationary_loss_rate() {
        let ge = LossModel::GilbertElliott { p: 0.02, r: 0.2, one_minus_h: 0.7, one_minus_k: 0.01 };
        let n = 400_000;
        let pattern = loss_pattern(&lossy(ge), n, 5);
        let rate = pattern.iter().filter(|&&x| x).count() as f64 / n as f64;
        let pi_b = 0.02 / 0.22;
        let expected = pi_b * 0.7 + (1.0 - pi_b) * 0.01;
        assert!((expected_loss_rate(&ge) - expected).abs() < 1e-12);
        assert!((rate - expected).abs() < 4.0 * tol(expected, n), "rate {rate} vs {expected}");
        eprintln!("gemodel p=0.02 r=0.2 1-h=0.7 1-k=0.01: loss {rate:.4} (expected {expected:.4})");
    }

    #[test]
    fn four_state_loss_uses_the_state_after_the_transition() {
        // p13 = 1: the very first message moves 1 → 3 and is lost.
        let gi = LossModel::FourState { p13: 1.0, p31: 0.0, p32: 0.0, p23: 1.0, p14: 0.0 };
        let pattern = loss_pattern(&lossy(gi), 10, 1);
        assert!(pattern.iter().all(|&x| x));
        // Isolated losses (p13 = 0, state 4 always returns to 1): never two in a row.
        let iso = LossModel::FourState { p13: 0.0, p31: 1.0, p32: 0.0, p23: 1.0, p14: 0.2 };
        let pattern = loss_pattern(&lossy(iso), N, 2);
        assert!(bursts(&pattern).iter().all(|&b| b == 1));
        let rate = pattern.iter().filter(|&&x| x).count() as f64 / N as f64;
        let expected = expected_loss_rate(&iso);
        assert!((expected - 0.2 / 1.2).abs() < 1e-12);
        assert!((rate - expected).abs() < tol(expected, N), "rate {rate} vs {expected}");
        eprintln!("4-state isolated p14=0.2: loss {rate:.4} (expected {expected:.4}), longest burst 1");
    }

    #[test]
    fn four_state_stationary_loss_rate() {
        let (p13, p31, p32, p23, p14) = (0.03, 0.4, 0.3, 0.2, 0.01);
        let gi = LossModel::FourState { p13, p31, p32, p23, p14 };
        // Solve π = πP directly, independently of expected_loss_rate's closed form, by power
        // iteration over the transition matrix (rows: from 1, 2, 3, 4).
        let m = [
            [1.0 - p13 - p14, 0.0, p13, p14],
            [0.0, 1.0 - p23, p23, 0.0],
            [p31, p32, 1.0 - p31 - p32, 0.0],
            [1.0, 0.0, 0.0, 0.0],
        ];
        let mut pi = [1.0, 0.0, 0.0, 0.0];
        for _ in 0..20_000 {
            let mut next = [0.0; 4];
            for (i, row) in m.iter().enumerate() {
                for (j, pij) in row.iter().enumerate() {
                    next[j] += pi[i] * pij;
                }
            }
            // Average with the previous step so the period-2 parts die out.
            for j in 0..4 {
                pi[j] = 0.5 * (pi[j] + next[j]);
            }
        }
        let expected = pi[2] + pi[3];
        assert!((expected_loss_rate(&gi) - expected).abs() < 1e-9, "{} vs {expected}", expected_loss_rate(&gi));
        let n = 400_000;
        let pattern = loss_pattern(&lossy(gi), n, 9);
        let rate = pattern.iter().filter(|&&x| x).count() as f64 / n as f64;
        assert!((rate - expected).abs() < 4.0 * tol(expected, n), "rate {rate} vs {expected}");
        eprintln!("4-state p13={p13} p31={p31} p32={p32} p23={p23} p14={p14}: loss {rate:.4} (expected {expected:.4})");
        // iproute2's `loss state P` alone (p31 = 1 − P, p32 = 0) is Bernoulli(P).
        let bern = LossModel::FourState { p13: 0.1, p31: 0.9, p32: 0.0, p23: 1.0, p14: 0.0 };
        assert!((expected_loss_rate(&bern) - 0.1).abs() < 1e-12);
        let pattern = loss_pattern(&lossy(bern), N, 4);
        let rate = pattern.iter().filter(|&&x| x).count() as f64 / N as f64;
        assert!((rate - 0.1).abs() < tol(0.1, N), "bernoulli rate {rate}");
    }

    /// `n` delays (delivery − send) under `rule`.
    fn delays(rule: &Impairment, n: usize) -> Vec<f64> {
        let mut l = LinkSim::new(21, UavId::new(3), UavId::new(4));
        (0..n)
            .map(|k| {
                let now = k as f64 * 0.001;
                let Decision::Deliver(at) = l.decide(rule, now, 100) else { panic!("no loss configured") };
                at - now
            })
            .collect()
    }

    fn jitter(delay_s: f64, jitter_s: f64, distribution: JitterDistribution) -> Impairment {
        Impairment { delay_s, jitter_s, distribution, ..Impairment::IDENTITY }
    }

    #[test]
    fn uniform_jitter_mean_std_and_range() {
        let d = delays(&jitter(0.1, 0.05, JitterDistribution::Uniform), N);
        let (mean, std) = mean_std(&d);
        let expected_std = 0.05 / 3f64.sqrt();
        assert!((mean - 0.1).abs() < 5.0 * expected_std / (N as f64).sqrt(), "mean {mean}");
        assert!((std - expected_std).abs() < 0.01 * expected_std, "std {std} vs {expected_std}");
        assert!(d.iter().all(|&x| (0.05 - 1e-12..0.15).contains(&x)));
        eprintln!(
            "uniform 100 ± 50 ms: mean {:.3} ms (100), std {:.3} ms ({:.3})",
            mean * 1e3,
            std * 1e3,
            expected_std * 1e3
        );
    }

    #[test]
    fn normal_jitter_mean_and_std() {
        // 5 σ above zero, so the clamp at 0 never bites.
        let d = delays(&jitter(0.25, 0.05, JitterDistribution::Normal), N);
        let (mean, std) = mean_std(&d);
        assert!((mean - 0.25).abs() < 5.0 * 0.05 / (N as f64).sqrt(), "mean {mean}");
        assert!((std - 0.05).abs() < 0.01 * 0.05, "std {std}");
        // 68.27 % within one σ.
        let within = d.iter().filter(|&&x| (x - 0.25).abs() < 0.05).count() as f64 / N as f64;
        assert!((within - 0.6827).abs() < tol(0.6827, N), "within 1σ {within}");
        assert!(d.iter().all(|&x| (x - 0.25).abs() <= 4.0 * 0.05 + 1e-12), "clipped at 4σ like netem's table");
        eprintln!("normal 250 ± 50 ms: mean {:.3} ms, std {:.3} ms, within 1σ {:.4}", mean * 1e3, std * 1e3, within);
    }

    #[test]
    fn negative_delays_clamp_to_now() {
        let d = delays(&jitter(0.01, 0.05, JitterDistribution::Uniform), 10_000);
        assert!(d.iter().all(|&x| x >= 0.0));
        let zero = d.iter().filter(|&&x| x == 0.0).count() as f64 / 10_000.0;
        assert!((zero - 0.4).abs() < 0.03, "P(delay < 0) = 0.4 clamps to 0, got {zero}");
    }

    /// Mean and std of a standardized quantile function over a fine midpoint grid (what netem's
    /// table lookup samples).
    fn table_moments(dist: JitterDistribution) -> (f64, f64) {
        let k = 1_000_000;
        let qs: Vec<f64> = (0..k).map(|i| jitter_quantile(dist, (i as f64 + 0.5) / k as f64)).collect();
        mean_std(&qs)
    }

    #[test]
    fn pareto_and_paretonormal_follow_netems_tables() {
        let p = JitterDistribution::Pareto;
        assert!((jitter_quantile(p, 0.0) + 2.0 / 3.0).abs() < 1e-12, "minimum −2/3");
        assert!((jitter_quantile(p, 0.5) - (4.0 / 3.0) * (2f64.cbrt() - 1.5)).abs() < 1e-12, "median");
        assert_eq!(jitter_quantile(p, 1.0 - 1e-12), DIST_MAX, "capped like the s16 table");
        for dist in [JitterDistribution::Pareto, JitterDistribution::ParetoNormal] {
            let (m_exp, s_exp) = table_moments(dist);
            let d = delays(&jitter(1.0, 0.1, dist), N);
            let (mean, std) = mean_std(&d);
            assert!((mean - (1.0 + 0.1 * m_exp)).abs() < 5.0 * 0.1 * s_exp / (N as f64).sqrt(), "{dist:?} mean {mean}");
            assert!((std - 0.1 * s_exp).abs() < 0.03 * 0.1 * s_exp, "{dist:?} std {std} vs {}", 0.1 * s_exp);
            eprintln!(
                "{dist:?} 1000 ± 100 ms: mean {:.2} ms (table {:.2}), std {:.2} ms (table {:.2})",
                mean * 1e3,
                (1.0 + 0.1 * m_exp) * 1e3,
                std * 1e3,
                0.1 * s_exp * 1e3
            );
        }
    }

    #[test]
    fn inverse_normal_cdf_matches_known_quantiles() {
        for (p, x) in [
            (0.5, 0.0),
            (0.975, 1.959_963_984_540_054),
            (0.841_344_746_068_543, 1.0),
            (0.02, -2.053_748_910_631_823),
            (1e-6, -4.753_424_308_822_899),
        ] {
            assert!((inverse_normal_cdf(p) - x).abs() < 1e-7 * x.abs().max(1.0), "Φ⁻¹({p})");
        }
    }

    #[test]
    fn rate_limit_spaces_messages_and_caps_throughput() {
        let rate = 10_000.0;
        let rule = Impairment { rate_bytes_per_s: Some(rate), delay_s: 0.05, ..Impairment::IDENTITY };
        let mut l = LinkSim::new(1, UavId::new(1), UavId::new(2));
        // 1000 messages of 1000 B sent back to back at t = 0: spaced by 0.1 s after the delay.
        let ats: Vec<f64> = (0..1000)
            .map(|_| match l.decide(&rule, 0.0, 1000) {
                Decision::Deliver(at) => at,
                d => panic!("{d:?}"),
            })
            .collect();
        assert!((ats[0] - 0.15).abs() < 1e-12);
        for w in ats.windows(2) {
            assert!((w[1] - w[0] - 0.1).abs() < 1e-9);
        }
        let throughput = 1000.0 * 1000.0 / (ats[999] - 0.05);
        assert!((throughput - rate).abs() < 1e-6 * rate, "throughput {throughput}");
        // Messages slower than the rate do not queue: each takes delay + b / rate.
        let mut l = LinkSim::new(1, UavId::new(1), UavId::new(2));
        for k in 0..100 {
            let now = k as f64;
            assert_eq!(l.decide(&rule, now, 1000), Decision::Deliver(now + 0.05 + 0.1));
        }
        // Saturated with random sizes and arrivals: the throughput is the rate.
        let mut l = LinkSim::new(1, UavId::new(1), UavId::new(2));
        let mut sizes = ChaCha8Rng::seed_from_u64(5);
        let (mut bytes, mut last) = (0.0, 0.0);
        for k in 0..N {
            let b = sizes.gen_range(50..1500);
            bytes += b as f64;
            // Offered at ~2× the rate.
            last = l.decide(&rule, k as f64 * 775.0 / rate / 2.0, b).instants().next().unwrap();
        }
        let throughput = bytes / (last - 0.05);
        assert!((throughput - rate).abs() < 1e-3 * rate, "saturated throughput {throughput}");
        eprintln!("rate {rate} B/s: back-to-back spacing 0.1 s, saturated throughput {throughput:.2} B/s");
    }

    #[test]
    fn duplicate_rate_matches() {
        let d = 0.1;
        let rule = Impairment { duplicate: d, delay_s: 0.02, ..Impairment::IDENTITY };
        let mut l = LinkSim::new(2, UavId::new(5), UavId::new(6));
        let mut dups = 0;
        for k in 0..N {
            let now = k as f64 * 0.01;
            match l.decide(&rule, now, 100) {
                Decision::Duplicate(a, b) => {
                    assert_eq!((a, b), (now + 0.02, now + 0.02));
                    dups += 1;
                }
                Decision::Deliver(a) => assert_eq!(a, now + 0.02),
                Decision::Lost(c) => panic!("{c:?}"),
                Decision::Held => panic!("not holding"),
            }
        }
        let rate = dups as f64 / N as f64;
        assert!((rate - d).abs() < tol(d, N), "duplicate rate {rate}");
        assert_eq!(l.stats().delivered, (N + dups) as u64);
        eprintln!("duplicate {d}: measured {rate:.4}");
    }

    #[test]
    fn duplicates_take_their_own_loss_decision_like_netems_clone() {
        let (d, p) = (0.5, 0.5);
        let rule = Impairment { duplicate: d, loss: LossModel::Random { p }, ..Impairment::IDENTITY };
        let mut l = LinkSim::new(8, UavId::new(1), UavId::new(2));
        let copies: usize = (0..N).map(|k| l.decide(&rule, k as f64, 10).copies()).sum();
        // count = 1 + dup − lost; a surviving clone is lost again with p.
        let expected = (1.0 - d) * (1.0 - p) + d * p + d * (1.0 - p) * (2.0 - p);
        let mean = copies as f64 / N as f64;
        assert!((mean - expected).abs() < 0.01, "copies per message {mean} vs {expected}");
        let s = l.stats();
        assert_eq!(s.delivered, s.offered - s.blocked - s.lost + s.duplicated);
        assert_eq!(s.delivered, copies as u64);
    }

    #[test]
    fn reorder_count_matches_and_reordered_messages_go_first() {
        let delay = 0.1;
        for (p, gap) in [(0.25, 1u32), (0.25, 5), (1.0, 5)] {
            let rule =
                Impairment { delay_s: delay, reorder: Some(Reorder { probability: p, gap }), ..Impairment::IDENTITY };
            assert!(rule.validate().is_ok());
            let mut l = LinkSim::new(4, UavId::new(1), UavId::new(2));
            let mut reordered = 0;
            let mut previous = f64::NEG_INFINITY;
            let mut since_last = 0u32;
            for k in 0..N {
                let now = k as f64 * 0.001;
                let Decision::Deliver(at) = l.decide(&rule, now, 10) else { panic!("no loss") };
                if at == now {
                    reordered += 1;
                    if k > 0 {
                        assert!(at < previous, "a reordered message overtakes the last delayed one");
                    }
                    assert!(since_last + 1 >= gap, "gap respected");
                    since_last = 0;
                } else {
                    assert_eq!(at, now + delay);
                    since_last += 1;
                    previous = at;
                }
            }
            // Each cycle: gap − 1 delayed messages, then a geometric wait with mean 1 / p.
            let expected = p / (1.0 + (gap as f64 - 1.0) * p);
            let rate = reordered as f64 / N as f64;
            assert!((rate - expected).abs() < tol(expected, N), "p {p} gap {gap}: {rate} vs {expected}");
            assert_eq!(l.stats().reordered, reordered);
            if p == 1.0 {
                assert_eq!(reordered as usize, N / gap as usize, "exactly every gap-th message");
            }
            eprintln!("reorder {p} gap {gap}: measured {rate:.4} (expected {expected:.4})");
        }
    }

    fn everything() -> Impairment {
        Impairment {
            delay_s: 0.1,
            jitter_s: 0.05,
            distribution: JitterDistribution::Normal,
            loss: LossModel::GilbertElliott { p: 0.05, r: 0.3, one_minus_h: 0.8, one_minus_k: 0.02 },
            duplicate: 0.05,
            reorder: Some(Reorder { probability: 0.1, gap: 3 }),
            rate_bytes_per_s: Some(1e5),
            blocked: false,
            hold: false,
        }
    }

    #[test]
    fn same_seed_same_decisions_other_link_other_stream() {
        let rule = everything();
        assert!(rule.validate().is_ok());
        let run = |seed, from, to| {
            let mut l = LinkSim::new(seed, from, to);
            (0..10_000).map(|k| l.decide(&rule, k as f64 * 0.01, 200)).collect::<Vec<_>>()
        };
        let a = run(42, UavId::new(1), UavId::new(2));
        assert_eq!(a, run(42, UavId::new(1), UavId::new(2)), "same seed, same link: identical");
        assert_ne!(a, run(42, UavId::new(2), UavId::new(1)), "the reverse link has its own stream");
        assert_ne!(a, run(42, UavId::new(1), UavId::new(3)), "another receiver has its own stream");
        assert_ne!(a, run(43, UavId::new(1), UavId::new(2)), "another run seed differs");
        let s = {
            let mut l = LinkSim::new(42, UavId::new(1), UavId::new(2));
            for k in 0..10_000 {
                l.decide(&rule, k as f64 * 0.01, 200);
            }
            l.stats()
        };
        assert_eq!(s.delivered, s.offered - s.blocked - s.lost + s.duplicated);
        assert!(s.lost > 0 && s.duplicated > 0 && s.reordered > 0);
    }

    #[test]
    fn reset_restarts_the_markov_chains() {
        let ge = lossy(LossModel::GilbertElliott { p: 1.0, r: 0.0, one_minus_h: 1.0, one_minus_k: 0.0 });
        let mut l = LinkSim::new(1, UavId::new(1), UavId::new(2));
        assert_eq!(l.decide(&ge, 0.0, 1).copies(), 1);
        assert_eq!(l.decide(&ge, 0.0, 1).copies(), 0);
        l.reset();
        assert_eq!(l.decide(&ge, 0.0, 1).copies(), 1, "back in Good");
    }

    /// The set of blocked ordered pairs among `nodes`.
    fn cut(p: &Partition, nodes: &[u32]) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for &a in nodes {
            for &b in nodes {
                if blocked(p, UavId::new(a), UavId::new(b)) {
                    out.push((a, b));
                }
            }
        }
        out
    }

    /// Both directions of every pair across `x` and `y`.
    fn across(x: &[u32], y: &[u32]) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for &a in x {
            for &b in y {
                out.push((a, b));
                out.push((b, a));
            }
        }
        out.sort_unstable();
        out
    }

    fn sorted(mut v: Vec<(u32, u32)>) -> Vec<(u32, u32)> {
        v.sort_unstable();
        v
    }

    #[test]
    fn partition_schemes_block_the_right_pairs() {
        let all = [1, 2, 3, 4, 5];
        assert!(cut(&Partition::heal(), &all).is_empty());
        assert!(!blocked(&Partition::heal(), UavId::new(1), UavId::new(2)));

        let groups = Partition::Groups {
            groups: vec![vec![UavId::new(1), UavId::new(2)], vec![UavId::new(3), UavId::new(4), UavId::new(5)]],
        };
        assert_eq!(sorted(cut(&groups, &all)), across(&[1, 2], &[3, 4, 5]));
        // Overlapping groups: 3 is in both, so it is a bridge.
        let overlap = Partition::Groups {
            groups: vec![
                vec![UavId::new(1), UavId::new(2), UavId::new(3)],
                vec![UavId::new(3), UavId::new(4), UavId::new(5)],
            ],
        };
        assert_eq!(sorted(cut(&overlap, &all)), across(&[1, 2], &[4, 5]));
        // A node no group lists is not affected.
        assert!(cut(&groups, &[1, 9]).iter().all(|&(a, b)| a != 9 && b != 9));

        // Jepsen bisect: smaller half first.
        let halves = Partition::Halves { nodes: all.iter().copied().map(UavId::new).collect() };
        assert_eq!(sorted(cut(&halves, &all)), across(&[1, 2], &[3, 4, 5]));

        let iso = Partition::isolate(UavId::new(3));
        assert_eq!(sorted(cut(&iso, &all)), across(&[3], &[1, 2, 4, 5]));
        assert!(
            blocked(&iso, UavId::new(3), UavId::new(1)) && blocked(&iso, UavId::new(1), UavId::new(3)),
            "deaf and mute"
        );

        // Jepsen bridge: halves [1 2] [3 4 5], bridge = 3.
        let bridge = Partition::Bridge { nodes: all.iter().copied().map(UavId::new).collect() };
        assert_eq!(sorted(cut(&bridge, &all)), across(&[1, 2], &[4, 5]));

        let one_way = Partition::OneWay { from: vec![UavId::new(1)], to: vec![UavId::new(2), UavId::new(3)] };
        assert_eq!(sorted(cut(&one_way, &all)), vec![(1, 2), (1, 3)]);
        assert!(!blocked(&one_way, UavId::new(2), UavId::new(1)), "the reverse stays open");
    }

    #[test]
    fn majorities_ring_gives_everyone_a_distinct_majority() {
        for n in 3..=9u32 {
            let ring: Vec<u32> = (0..n).map(|i| 10 + (i * 11) % n).collect(); // a shuffled order
            let p = Partition::MajoritiesRing { ring: ring.iter().copied().map(UavId::new).collect() };
            let majority = n as usize / 2 + 1;
            let mut heard: Vec<Vec<u32>> = Vec::new();
            for &to in &ring {
                let hears: Vec<u32> =
                    ring.iter().copied().filter(|&from| !blocked(&p, UavId::new(from), UavId::new(to))).collect();
                assert_eq!(hears.len(), majority, "n {n}: {to} hears exactly a majority");
                assert!(hears.contains(&to));
                heard.push(hears);
            }
            for i in 0..heard.len() {
                for j in i + 1..heard.len() {
                    assert_ne!(heard[i], heard[j], "n {n}: no two nodes see the same majority");
                }
            }
        }
        // Five nodes (Jepsen's case): each hears its two ring neighbours, symmetric.
        let p = Partition::MajoritiesRing {
            ring: vec![UavId::new(1), UavId::new(2), UavId::new(3), UavId::new(4), UavId::new(5)],
        };
        assert_eq!(
            sorted(cut(&p, &[1, 2, 3, 4, 5])),
            sorted(vec![(1, 3), (3, 1), (1, 4), (4, 1), (2, 4), (4, 2), (2, 5), (5, 2), (3, 5), (5, 3)])
        );
        assert!(!blocked(&p, UavId::new(9), UavId::new(1)), "nodes outside the ring are unaffected");
    }
}
