//! The `icp` mode's localizer: the shares in and out, and the real ICP behind the neighbour
//! database (seed 000 3.2 and chapter 5).
//!
//! Why a module of its own: the [`Database`] is pure bookkeeping over a [`Matcher`], tested with
//! scripted matchers; this is the thin layer that joins it to the rest of the agent: it turns
//! received [`Share`]s into obstacle sets, our circles into the reference set, the database's
//! entries into the localization's [`Estimate`]s and its counts into the wire's [`IcpCounts`],
//! and it implements [`Matcher`] with the ICP of [`super::alignment`] and [`super::grid`]. It also decides the one
//! thing that depends on the run's time mode: whether the wall clock may cut a step short.

use super::alignment::{fit_near_middle, icp, AgentFromNeighbour, Match};
use super::database::{Database, Matcher, Received};
use super::grid::{initial_icp, initial_icp_ranked, initial_icp_ranked_near, Ranked};
use crate::localization::{ObstacleSet, Share};
use crate::sensing::SensorFrame;
use crate::world_model::{Circle, Estimate};
use nalgebra::Point2;
use std::sync::Arc;
use std::time::Instant;
use swarm_config::IcpParams;
use swarm_types::UavId;
use swarm_wire::{IcpCounts, ObstacleShare};

/// The `icp` localizer (seed 000 3.2, chapter 5): it shares its obstacle set, keeps the newest set
/// from each neighbour, and places the neighbours by matching those sets to its own through the
/// [`Database`] and the real ICP.
#[derive(Debug)]
pub(crate) struct IcpLocalizer {
    id: UavId,
    stale_after_s: f64,
    params: IcpParams,
    /// Whether a wall-clock step budget applies (realtime runs only, see [`Self::estimates`]).
    realtime: bool,
    db: Database,
    /// The newest obstacle set from each neighbour (one per sender, in sender order), handed to
    /// the database by reference every step (it ignores sets older than `stale_after_s`).
    received: Vec<Received>,
}

impl IcpLocalizer {
    /// The localizer of UAV `id`.
    pub(crate) fn new(id: UavId, params: IcpParams, stale_after_s: f64, realtime: bool) -> IcpLocalizer {
        let db = Database::new(params.clone(), stale_after_s);
        IcpLocalizer { id, stale_after_s, params, realtime, db, received: Vec::new() }
    }

    /// Keeps a neighbour's obstacle set if it is newer than the one held (our own echo and poses
    /// are ignored).
    pub(crate) fn receive(&mut self, share: &Share) {
        let Share::Obstacles(o) = share else { return };
        let (from, t_s) = (o.wire.from, o.wire.t_s);
        if from == self.id {
            return;
        }
        // Held by sender, found by bisection: a crowd's agent takes dozens of sets a step, each
        // the decoded set the share arrived with, shared rather than copied.
        match self.received.binary_search_by_key(&from, |r| r.from) {
            Ok(i) if t_s > self.received[i].t_s => {
                let held = &mut self.received[i];
                held.t_s = t_s;
                held.points = Arc::clone(&o.centres_m);
            }
            Ok(_) => {}
            Err(i) => self.received.insert(i, Received { from, t_s, points: Arc::clone(&o.centres_m) }),
        }
    }

    /// The radio links to `senders` came up at sim time `t_s` (the database's crowd rules may
    /// wait for a neighbour just come into range before placing it).
    pub(crate) fn links_came_up(&mut self, senders: &[UavId], t_s: f64) {
        self.db.links_came_up(senders, t_s);
    }

    /// The neighbours placed by matching their sets to our `circles` at the frame's sim time (its
    /// odometry pose for the localization budget's tracks), and the ICP work it took; `started` is
    /// when the step began (wall clock).
    pub(crate) fn estimates(
        &mut self,
        frame: &SensorFrame,
        circles: &[Circle],
        started: Instant,
    ) -> (Vec<Estimate>, IcpCounts) {
        let now = frame.scan.t_s;
        self.db.set_pose(nalgebra::Vector2::new(frame.odom.x, frame.odom.y), frame.odom.yaw);
        let own: Vec<Point2<f64>> = circles.iter().map(|c| c.center).collect();
        let stale = self.stale_after_s;
        self.received.retain(|r| now - r.t_s <= stale + 1e-9);
        // The step-time failsafe (seed 000 6.2) guards a realtime deadline. In lockstep the
        // hub waits for us, so there is none; and a wall-clock decision would make the run
        // depend on machine load instead of repeating exactly.
        let realtime = self.realtime;
        let mut elapsed_ms = || if realtime { started.elapsed().as_secs_f64() * 1e3 } else { 0.0 };
        let c = self.db.step(now, &own, &self.received, &mut IcpMatcher(&self.params), &mut elapsed_ms);
        let estimates = self.db.estimates(now).into_iter().map(Into::into).collect();
        let counts = IcpCounts {
            short: c.short,
            long: c.long,
            initial: c.initial,
            deferred: c.skipped_long,
            entries: self.db.len() as u32,
            suspended: self.db.suspended_len() as u32,
        };
        (estimates, counts)
    }

    /// seed 000 3.2: the obstacle set is what an agent shares, in its body frame.
    pub(crate) fn share(&self, frame: &SensorFrame, circles: &[Circle]) -> Share {
        Share::Obstacles(ObstacleSet::new(ObstacleShare {
            from: self.id,
            tick: frame.scan.tick,
            t_s: frame.scan.t_s,
            centres_cm: ObstacleShare::quantize(circles.iter().map(|c| [c.center.x, c.center.y])),
            hops: swarm_wire::NO_PATH,
            arrival: swarm_wire::NO_PATH,
        }))
    }
}

/// The real ICP behind the neighbour database.
struct IcpMatcher<'a>(&'a IcpParams);

impl Matcher for IcpMatcher<'_> {
    fn short(
        &mut self,
        reference: &[Point2<f64>],
        source: &[Point2<f64>],
        initial: AgentFromNeighbour,
    ) -> Option<Match> {
        icp(reference, source, initial, self.0).ok()
    }
    fn long(&mut self, reference: &[Point2<f64>], source: &[Point2<f64>]) -> Option<Match> {
        initial_icp(reference, source, self.0).ok()
    }
    fn long_ranked(&mut self, reference: &[Point2<f64>], source: &[Point2<f64>]) -> Option<Ranked> {
        initial_icp_ranked(reference, source, self.0).ok()
    }
    fn long_ranked_near(
        &mut self,
        reference: &[Point2<f64>],
        source: &[Point2<f64>],
        heading_rad: f64,
        count: u32,
    ) -> Option<Ranked> {
        initial_icp_ranked_near(reference, source, self.0, heading_rad, count).ok()
    }
    fn fit(&mut self, reference: &[Point2<f64>], source: &[Point2<f64>], t: AgentFromNeighbour) -> Option<f64> {
        fit_near_middle(reference, source, t, self.0).ok()
    }
}
