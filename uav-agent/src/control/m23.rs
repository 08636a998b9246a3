//! The formation layer of M23 (seed 004 chapter 3, section 3.4): leader-follower topologies on
//! top of a costmap planner, and the local tracker that flies the planner's path.
//!
//! Why this module exists: in seed 004 every UAV flies to a goal with a global planner (A*) and a
//! local planner (DWA); the formation layer only decides *which goal*. The leader flies to the
//! swarm goal but waits for far followers (Fig. 38–39); each follower derives its goal from the
//! leader or its predecessors by the topology (Fig. 41–42e), checks it against the costmap and,
//! if occupied, searches for a cheap cell nearby (Fig. 40, 42b, 42d). The code is pure: poses,
//! costs (through the planner's [`CostQuery`], so this module does not depend on the costmap's
//! implementation)
//! and the sim time come in as arguments.
//!
//! Entry points: [`formation_target`] (GET_FORMATION_GOAL; the tests read its goal alone with
//! `formation_goal`), [`validate_goal`]
//! and [`nearest_low_cost`] (Fig. 42b/d), [`follower_goal`] (one pass of the Fig. 40 loop),
//! [`LeaderWait`] (Fig. 38), [`track`] (the local tracker).
//!
//! Choices where seed 004 is silent or its code contradicts its text (each documented at its
//! function):
//! - LF adds the offset in the world frame (seed Fig. 42d line 353, no rotation); rotating it by
//!   the leader's heading is an option (`lf_frame = "leader_heading"`).
//! - PF and TNPF pull the reference back along the line towards the follower's own position, not
//!   along the reference's heading or velocity (Fig. 42e lines 448–450 and 454–456).
//! - Formation order: the leader first, then ascending id. The PF reference is the known UAV
//!   immediately before this one in that order: `uav(N−1)` of Fig. 42a line 623 when it is known;
//!   when it is not (failed, out of radio range), the next one up the chain, so a lost UAV does
//!   not freeze every follower behind it. TNPF takes its two nearest among the known predecessors
//!   (Fig. 42f). With no known reference there is no formation goal and the old goal is kept.
//! - Goal validation accepts cost < COSTMAP_THRES (Fig. 40, Fig. 42b line 267); an unknown or
//!   off-map cell (`None`, and ROS NO_INFORMATION 255) counts as free, where seed Fig. 42c
//!   returns infinity off the map. The search is centred, as in Fig. 42d lines 374–375, on the
//!   midpoint between the occupied goal and the reference UAV, and returns the Euclidean-nearest
//!   acceptable cell within SEARCHING_RADIUS (seed Fig. 42b scans square rings two cells apart
//!   and returns the first hit in scan order, which is biased to one corner).
//! - Leader wait: the timer runs per "far" episode. After MAX_TIME the leader goes and does not
//!   wait again until every follower has been within MAX_DISTANCE once (the pseudo code and text
//!   of Fig. 38; the Fig. 39 code would re-enter waiting one loop later, which defeats the
//!   timeout the text asks for). No follower poses (`None`) keeps the state, as Fig. 39 line 788.
//! - Tracker: seed 004 used ROS DWA. [`track`] is a reduced dynamic-window tracker for a
//!   holonomic multirotor: a pure-pursuit carrot at the lookahead distance along the path gives
//!   the desired velocity (slowing to stop at the path's end), the candidates are the velocities
//!   reachable in one step under the acceleration limit (the dynamic window, seed eq. 8) and
//!   inside the speed limit, and a candidate is admissible only if the straight segment it flies
//!   in this step plus its braking distance crosses no inscribed or lethal cell (cost 253 or
//!   254). The admissible candidate closest to the desired velocity wins (the goal term of eq.
//!   10; the obstacle term is the admissibility test). Kept because it keeps DWA's properties —
//!   limits respected by construction, never commanding a velocity that cannot stop before an
//!   obstacle — with no trajectory scoring weights to tune.
//! - Non-finite inputs: UAVs with a non-finite position are ignored; a non-finite own position
//!   gives no PF or TNPF goal (LF does not need it) and a zero tracker command.

use nalgebra::{Point2, Rotation2, Vector2};
use swarm_config::{LfFrame, M23Params, Topology};
use swarm_types::UavId;

// ROS costmap_2d values, as the costmap writes them (NO_INFORMATION counts as free here).
#[cfg(test)]
use crate::planning::LETHAL_OBSTACLE as LETHAL;
use crate::planning::{CostQuery, INSCRIBED_INFLATED_OBSTACLE as INSCRIBED, NO_INFORMATION};

/// Lengths below this are treated as zero.
const EPS: f64 = 1e-9;
/// The goal search looks at most this many rings of cells, whatever the radius/resolution.
const MAX_SEARCH_RINGS: i64 = 1000;
/// Angles sampled on each ring of the tracker's dynamic window.
const WINDOW_ANGLES: usize = 16;
/// Rings (fractions of the window radius) sampled in the tracker's dynamic window.
const WINDOW_RINGS: [f64; 3] = [1.0, 2.0 / 3.0, 1.0 / 3.0];

/// A UAV as the formation layer sees it: id and pose in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UavState {
    /// UAV id (1-based).
    pub id: UavId,
    /// Position [m], world frame.
    pub position: Point2<f64>,
    /// Heading [rad], world frame.
    pub heading: f64,
}

/// A formation goal and the point it was derived from (the leader, the predecessor, or the
/// centre of two predecessors); the validation search is centred between the two (Fig. 42d).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FormationTarget {
    /// The desired goal [m], world frame.
    pub goal: Point2<f64>,
    /// The reference point [m], world frame (`leader_pos` of Fig. 42d).
    pub reference: Point2<f64>,
}

fn finite_point(p: &Point2<f64>) -> bool {
    p.x.is_finite() && p.y.is_finite()
}

/// Position in the formation order: the leader id 0 (which is no UAV: ids start at 1, so it
/// comes first), every other UAV its id.
fn rank(id: UavId, leader_id: UavId) -> UavId {
    if id == leader_id {
        UavId::default()
    } else {
        id
    }
}

/// Whether `a` comes before `b` in the formation order (leader first, then ascending id; seed
/// 004 Fig. 42f line 498 keeps the neighbours whose name sorts before this UAV's).
pub fn precedes(a: UavId, b: UavId, leader_id: UavId) -> bool {
    rank(a, leader_id) < rank(b, leader_id)
}

/// 0-based index of follower `id` among the followers (ascending id, leader skipped), the index
/// into the LF offsets; `None` for the leader and for id 0.
pub fn follower_index(id: UavId, leader_id: UavId) -> Option<usize> {
    if id == leader_id {
        return None;
    }
    let skipped = usize::from(id > leader_id);
    Some(id.try_index()? - skipped)
}

/// The reference pulled back towards the follower by `distance` (seed 004 Fig. 42e lines
/// 448–450 and 454–456): θ = atan2(r_y − m_y, r_x − m_x), goal = r − distance·(cos θ, sin θ).
/// A follower exactly at the reference gets θ = atan2(0, 0) = 0, as numpy does.
fn pull_back(reference: Point2<f64>, me: Point2<f64>, distance: f64) -> Point2<f64> {
    // seed 004 Fig. 42e line 448 / 454: θ = atan2(ref_y − my_y, ref_x − my_x).
    let theta = (reference.y - me.y).atan2(reference.x - me.x);
    // seed 004 Fig. 42e lines 449–450 / 455–456 and Fig. 42d lines 353–354: goal = ref + target.
    reference - distance * Vector2::new(theta.cos(), theta.sin())
}

/// LF goal (seed 004 Fig. 41a, Fig. 42a lines 619–621, Fig. 42d lines 353–354): leader position
/// plus this follower's offset, in world axes or rotated by the leader's heading (`lf_frame`).
fn lf_target(me: &UavState, leader: &UavState, p: &M23Params) -> Option<FormationTarget> {
    let index = follower_index(me.id, p.leader_id)?;
    let [ox, oy] = p.lf_offset_m(index);
    let offset = Vector2::new(ox, oy);
    let offset_in_world = match p.lf_frame {
        LfFrame::World => offset,
        LfFrame::LeaderHeading if leader.heading.is_finite() => Rotation2::new(leader.heading) * offset,
        LfFrame::LeaderHeading => return None,
    };
    // seed 004 Fig. 42d lines 353–354: x = leader_x + offset_x, y = leader_y + offset_y.
    let goal = leader.position + offset_in_world;
    finite_point(&goal).then_some(FormationTarget { goal, reference: leader.position })
}

/// PF goal (seed 004 Fig. 41b, Fig. 42a lines 622–624, Fig. 42e lines 453–457): the known UAV
/// immediately before this one in the formation order, pulled back by `pf_distance_m`.
fn pf_target(me: &UavState, known: &[UavState], p: &M23Params) -> Option<FormationTarget> {
    let predecessor =
        known.iter().filter(|u| precedes(u.id, me.id, p.leader_id)).max_by_key(|u| rank(u.id, p.leader_id))?;
    let goal = pull_back(predecessor.position, me.position, p.pf_distance_m);
    Some(FormationTarget { goal, reference: predecessor.position })
}

/// TNPF goal (seed 004 Fig. 41c, Fig. 42e lines 437–451, Fig. 42f): the two known predecessors
/// nearest to this UAV, their centre pulled back by `tnpf_distance_m`; with one predecessor, PF
/// on it with the same distance (Fig. 42e lines 438–440). Equal distances: the earlier in order.
fn tnpf_target(me: &UavState, known: &[UavState], p: &M23Params) -> Option<FormationTarget> {
    let mut predecessors: Vec<&UavState> = known.iter().filter(|u| precedes(u.id, me.id, p.leader_id)).collect();
    // seed 004 Fig. 42f lines 501–512: the nearest and the second nearest by distance2d.
    predecessors.sort_by(|a, b| {
        let da = (a.position - me.position).norm_squared();
        let db = (b.position - me.position).norm_squared();
        da.total_cmp(&db).then(rank(a.id, p.leader_id).cmp(&rank(b.id, p.leader_id)))
    });
    let reference = match predecessors.as_slice() {
        [] => return None,
        [only] => only.position,
        // seed 004 Fig. 42e lines 446–447: the centre of the two leaders.
        [first, second, ..] => Point2::from((first.position.coords + second.position.coords) / 2.0),
    };
    let goal = pull_back(reference, me.position, p.tnpf_distance_m);
    Some(FormationTarget { goal, reference })
}

/// GET_FORMATION_GOAL of seed 004 Fig. 40 with its reference point (Fig. 41, 42a lines 619–627).
///
/// `leader` is the leader's pose if known; `neighbours` are the other UAVs this one currently
/// knows (the leader may be among them; a valid `leader` argument wins). `None` for topology
/// `none`, for the leader itself, and when the reference UAV is unknown — the follower then keeps
/// its old goal.
/// UAVs with a non-finite position are ignored; a non-finite own position gives `None` for PF and
/// TNPF (LF does not use it).
pub fn formation_target(
    topology: Topology,
    me: &UavState,
    leader: Option<&UavState>,
    neighbours: &[UavState],
    p: &M23Params,
) -> Option<FormationTarget> {
    if me.id == p.leader_id {
        return None;
    }
    let valid_leader = |l: &&UavState| l.id == p.leader_id && finite_point(&l.position);
    let leader = leader.filter(valid_leader).or_else(|| neighbours.iter().find(valid_leader));
    let known: Vec<UavState> = leader
        .copied()
        .into_iter()
        .chain(neighbours.iter().copied().filter(|n| n.id != p.leader_id && n.id != me.id))
        .filter(|u| finite_point(&u.position))
        .collect();
    let target = match topology {
        Topology::None => None,
        Topology::Lf => lf_target(me, leader?, p),
        Topology::Pf | Topology::Tnpf if !finite_point(&me.position) => None,
        Topology::Pf => pf_target(me, &known, p),
        Topology::Tnpf => tnpf_target(me, &known, p),
    };
    target.filter(|t| finite_point(&t.goal))
}

/// The formation goal alone: [`formation_target`] without its reference point (what the tests
/// check; the pilot takes the whole target).
#[cfg(test)]
pub fn formation_goal(
    topology: Topology,
    me: &UavState,
    leader: Option<&UavState>,
    neighbours: &[UavState],
    p: &M23Params,
) -> Option<Point2<f64>> {
    formation_target(topology, me, leader, neighbours, p).map(|t| t.goal)
}

/// Whether a cost is acceptable for a goal: below `max_cost` (seed 004 Fig. 40 "IF cost <
/// COSTMAP_THRES", Fig. 42b line 267); unknown counts as free.
fn low_cost(cost: Option<u8>, max_cost: u8) -> bool {
    match cost {
        None | Some(NO_INFORMATION) => true,
        Some(c) => c < max_cost,
    }
}

/// GET_NEAREST_POSSIBLE_GOAL (seed 004 Fig. 42b): the point nearest to `centre` (Euclidean, on
/// the grid of `costs.resolution()` steps around `centre`, at most `radius_m` away, `centre`
/// itself included) whose cost is below `max_cost`; `None` if there is none.
///
/// Cells are visited in square rings of growing size like the seed; the search stops once no
/// later ring can hold a nearer cell. Equal distances: smallest x offset, then smallest y offset.
/// At most 1000 rings are searched. A non-finite centre or a resolution that is not a positive
/// number gives `None`.
pub fn nearest_low_cost(
    centre: Point2<f64>,
    costs: &impl CostQuery,
    max_cost: u8,
    radius_m: f64,
) -> Option<Point2<f64>> {
    let res = costs.resolution();
    if !(finite_point(&centre) && res.is_finite() && res > 0.0 && radius_m >= 0.0) {
        return None;
    }
    let radius_cells = radius_m / res;
    let rings = (radius_cells.floor() as i64).min(MAX_SEARCH_RINGS);
    let radius_sq = radius_cells * radius_cells + EPS;
    let mut best: Option<(i64, i64, i64)> = None;
    for k in 0..=rings {
        if best.is_some_and(|(d2, _, _)| d2 <= k * k) {
            break; // ring k is at least k cells away: nothing nearer is left.
        }
        for (i, j) in ring(k) {
            let d2 = i * i + j * j;
            if d2 as f64 > radius_sq || best.is_some_and(|b| (d2, i, j) >= b) {
                continue;
            }
            let point = centre + Vector2::new(i as f64, j as f64) * res;
            if low_cost(costs.cost_at(point), max_cost) {
                best = Some((d2, i, j));
            }
        }
    }
    best.map(|(_, i, j)| centre + Vector2::new(i as f64, j as f64) * res)
}

/// The cell offsets (i, j) with max(|i|, |j|) = k: the border of the (2k+1)² square.
fn ring(k: i64) -> Vec<(i64, i64)> {
    if k == 0 {
        return vec![(0, 0)];
    }
    let edges = (-k..=k).flat_map(|i| [(i, -k), (i, k)]);
    let sides = (-k + 1..k).flat_map(|j| [(-k, j), (k, j)]);
    edges.chain(sides).collect()
}

/// Goal validation of seed 004 Fig. 40 and Fig. 42d: the formation goal if its cost is below
/// COSTMAP_THRES; else the nearest cheap point within SEARCHING_RADIUS of the midpoint between
/// the goal and the reference (Fig. 42d lines 374–376); `None` when there is none, and the caller
/// keeps its previous goal (Fig. 40 "no updated goal").
pub fn validate_goal(target: &FormationTarget, costs: &impl CostQuery, p: &M23Params) -> Option<Point2<f64>> {
    if !finite_point(&target.goal) {
        return None;
    }
    // seed 004 Fig. 40 / Fig. 42d line 358: IF cost < COSTMAP_THRES THEN go to the goal.
    if low_cost(costs.cost_at(target.goal), p.costmap_thres) {
        return Some(target.goal);
    }
    // seed 004 Fig. 42d lines 374–375: search around ((x + leader_x)/2, (y + leader_y)/2).
    let centre = Point2::from((target.goal.coords + target.reference.coords) / 2.0);
    nearest_low_cost(centre, costs, p.costmap_thres, p.searching_radius_m)
}

/// What a follower knows for one pass of the Fig. 40 loop.
#[derive(Debug, Clone, Copy)]
pub struct FollowerInput<'a> {
    /// This UAV.
    pub me: UavState,
    /// The leader, if known.
    pub leader: Option<&'a UavState>,
    /// The other UAVs currently known.
    pub neighbours: &'a [UavState],
    /// The leader's static goal [m], world frame.
    pub leader_goal: Point2<f64>,
    /// This UAV's own static goal [m], world frame (`M23Params::goal_of`).
    pub own_goal: Point2<f64>,
    /// The goal this UAV flies to now, if any.
    pub previous_goal: Option<Point2<f64>>,
}

/// One pass of the follower loop (seed 004 Fig. 40, Fig. 42a): the goal to fly to.
///
/// Topology `none` and the leader itself: the own static goal. Once the leader is within
/// `leader_arrived_m` of its goal (Fig. 42a line 601): the own static goal. Otherwise the
/// formation goal, validated against the costmap ([`validate_goal`]); when there is none (no
/// reference known, or nothing cheap within the radius) the previous goal is kept, which is
/// `None` only if there never was one.
pub fn follower_goal(
    topology: Topology,
    input: &FollowerInput,
    costs: &impl CostQuery,
    p: &M23Params,
) -> Option<Point2<f64>> {
    if topology == Topology::None || input.me.id == p.leader_id {
        return Some(input.own_goal);
    }
    let leader_arrived = input
        .leader
        .filter(|l| l.id == p.leader_id)
        .is_some_and(|l| (l.position - input.leader_goal).norm() < p.leader_arrived_m);
    if leader_arrived {
        return Some(input.own_goal);
    }
    formation_target(topology, &input.me, input.leader, input.neighbours, p)
        .and_then(|t| validate_goal(&t, costs, p))
        .or(input.previous_goal)
}

/// Whether any follower is farther than `max_distance_m` from the leader ("is there far
/// followers" of seed 004 Fig. 39 line 789: distance > MAX_DISTANCE). Non-finite positions are
/// ignored.
pub fn any_follower_far(leader: Point2<f64>, followers: &[Point2<f64>], max_distance_m: f64) -> bool {
    followers.iter().filter(|f| finite_point(f)).any(|f| (f - leader).norm() > max_distance_m)
}

/// The leader's state in the wait rule of seed 004 Fig. 38.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LeaderState {
    /// State 0: going to the goal.
    Going,
    /// State 1: waiting (holding) since this sim time [s].
    Waiting {
        /// Sim time the wait began [s].
        since_secs: f64,
    },
    /// Waited MAX_TIME for a follower that is still far: going, and not waiting again until all
    /// followers have been near.
    TimedOut,
}

/// The leader's wait rule (seed 004 Fig. 38–39), a state machine driven by sim time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeaderWait {
    /// The current state.
    pub state: LeaderState,
}

impl Default for LeaderWait {
    fn default() -> Self {
        LeaderWait { state: LeaderState::Going }
    }
}

impl LeaderWait {
    /// Whether the leader holds (state 1 of Fig. 38: "waiting (do nothing)").
    pub fn holding(&self) -> bool {
        matches!(self.state, LeaderState::Waiting { .. })
    }

    /// Advances the rule to sim time `t_s` and returns whether the leader holds.
    ///
    /// `far`: whether a follower is farther than MAX_DISTANCE ([`any_follower_far`]), or `None`
    /// when the follower poses are not all available (Fig. 39 line 788: the state is kept). The
    /// transitions are Going → Waiting when far (Fig. 39 lines 790–793); Waiting → Going when no
    /// longer far (lines 794–796); Waiting → TimedOut when it has lasted more than MAX_TIME
    /// (lines 798–801, also without poses); TimedOut → Going when no longer far. A non-finite
    /// time changes nothing.
    pub fn step(&mut self, t_s: f64, far: Option<bool>, p: &M23Params) -> bool {
        if !t_s.is_finite() {
            return self.holding();
        }
        self.state = match (self.state, far) {
            (LeaderState::Going, Some(true)) => LeaderState::Waiting { since_secs: t_s },
            (LeaderState::Waiting { .. } | LeaderState::TimedOut, Some(false)) => LeaderState::Going,
            (state, _) => state,
        };
        if let LeaderState::Waiting { since_secs } = self.state {
            // seed 004 Fig. 39 line 799: now − start_waiting > MAX_TIME → go.
            if t_s - since_secs > p.max_time_s {
                self.state = LeaderState::TimedOut;
            }
        }
        self.holding()
    }
}

/// How the tracker's command relates to the path-following velocity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Safety {
    /// The command is the path-following velocity (limited in speed and acceleration).
    Clear,
    /// That velocity could not stop before an inscribed/lethal cell; the closest admissible
    /// velocity of the dynamic window was taken instead.
    Adjusted,
    /// No velocity of the window is admissible (the UAV is already too close and too fast, e.g.
    /// a cell just became lethal): zero is commanded, even beyond the acceleration limit.
    Stopped,
}

/// The tracker's output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerOutput {
    /// Commanded velocity [m/s], world frame.
    pub velocity: Vector2<f64>,
    /// The lookahead point on the path [m], world frame (`None` for an empty path).
    pub carrot: Option<Point2<f64>>,
    /// Whether the obstacle check changed the command.
    pub safety: Safety,
}

/// The point `lookahead_m` along `path` after the projection of `position`, and the distance
/// left to the path's end measured from `position` through the projection.
fn carrot_on(path: &[Point2<f64>], position: Point2<f64>, lookahead_m: f64) -> Option<(Point2<f64>, f64)> {
    let (&last, _) = path.split_last()?;
    let nearest = |(i, w): (usize, &[Point2<f64>])| {
        let (a, b) = (w[0], w[1]);
        let ab = b - a;
        let t =
            if ab.norm_squared() > EPS { ((position - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0) } else { 0.0 };
        let q = a + t * ab;
        (i, q, (position - q).norm())
    };
    let Some((seg, proj, off_path)) = path.windows(2).enumerate().map(nearest).min_by(|a, b| a.2.total_cmp(&b.2))
    else {
        return Some((last, (last - position).norm()));
    };
    let mut carrot = None;
    let mut walked = 0.0;
    let mut from = proj;
    for &to in &path[seg + 1..] {
        let len = (to - from).norm();
        if carrot.is_none() && walked + len >= lookahead_m {
            carrot = Some(from + (to - from) * ((lookahead_m - walked) / len.max(EPS)));
        }
        walked += len;
        from = to;
    }
    Some((carrot.unwrap_or(last), off_path + walked))
}

/// The path-following velocity: towards the carrot at min(max speed, √(2·a·d_left)), so the UAV
/// can brake to rest at the path's end; zero within `goal_tolerance_m` of the end.
fn desired_velocity(path: &[Point2<f64>], position: Point2<f64>, p: &M23Params) -> (Vector2<f64>, Option<Point2<f64>>) {
    let Some((carrot, left)) = carrot_on(path, position, p.lookahead_m) else {
        return (Vector2::zeros(), None);
    };
    let to_end = path.last().map_or(0.0, |end| (end - position).norm());
    let to_carrot = carrot - position;
    if to_end <= p.goal_tolerance_m || to_carrot.norm() <= EPS {
        return (Vector2::zeros(), Some(carrot));
    }
    // v² = 2·a·d: the speed from which the acceleration limit still stops within d.
    let speed = p.max_speed_mps.min((2.0 * p.max_accel_mps2 * left).sqrt());
    (to_carrot / to_carrot.norm() * speed, Some(carrot))
}

/// `v` clipped to length `max`.
fn clip(v: Vector2<f64>, max: f64) -> Vector2<f64> {
    let n = v.norm();
    if n > max {
        v * (max / n)
    } else {
        v
    }
}

/// Whether a cost blocks the tracker: inscribed or lethal (seed 004 Fig. 33 lethal_cost 253).
/// Standing on such a cell, only cells costlier than the own one block, so the UAV can back out
/// instead of freezing. NO_INFORMATION and unknown count as free (cost 0).
fn blocks(cost: Option<u8>, own: Option<u8>) -> bool {
    let norm = |c: Option<u8>| c.filter(|&c| c != NO_INFORMATION).unwrap_or(0);
    let (cost, own) = (norm(cost), norm(own));
    if own >= INSCRIBED {
        cost > own
    } else {
        cost >= INSCRIBED
    }
}

/// Admissible velocity (the dynamic window's obstacle condition): the straight segment flown in
/// this step plus the braking distance |v|²/(2a) crosses no blocking cell, sampled every half
/// cell. Standing still is always admissible.
fn admissible(c: Vector2<f64>, position: Point2<f64>, dt_s: f64, costs: &impl CostQuery, p: &M23Params) -> bool {
    let speed = c.norm();
    if speed <= EPS {
        return true;
    }
    let reach = speed * dt_s + speed * speed / (2.0 * p.max_accel_mps2);
    let res = costs.resolution();
    let step = if res.is_finite() && res > 0.0 { res / 2.0 } else { reach };
    let samples = ((reach / step).ceil() as usize).clamp(1, 100_000);
    let dir = c / speed;
    let own = costs.cost_at(position);
    // Every half cell along the ray, plus the end of this step and the end of the braking.
    let along = (1..samples).map(|k| k as f64 * step).chain([speed * dt_s, reach]);
    along.filter(|s| *s > 0.0).all(|s| !blocks(costs.cost_at(position + dir * s), own))
}

/// The local tracker (replaces seed 004's DWA, see the module doc): a velocity command [m/s],
/// world frame, following `path` from `position` at current velocity `velocity`, for a control
/// step of `dt_s`.
///
/// The candidates are the velocities v + Δ with |Δ| ≤ max_accel·dt (the dynamic window, seed 004
/// eq. 8, here a disk around the current velocity) projected into |v| ≤ max_speed: the
/// path-following velocity limited this way first, then 16 directions on three rings of the
/// window, the full brake and the current velocity. The first admissible candidate closest to the
/// desired velocity is commanded. When |velocity| ≤ max_speed the result is within both limits
/// (the projection onto the speed disk is non-expansive); otherwise the speed limit wins. The
/// own heading is not needed: the multirotor is holonomic, as seed 004's DWA (max_vel_y, Fig. 34).
pub fn track(
    path: &[Point2<f64>],
    position: Point2<f64>,
    velocity: Vector2<f64>,
    dt_s: f64,
    costs: &impl CostQuery,
    p: &M23Params,
) -> TrackerOutput {
    let stop = TrackerOutput { velocity: Vector2::zeros(), carrot: None, safety: Safety::Stopped };
    if !finite_point(&position) {
        return stop;
    }
    let v = if velocity.x.is_finite() && velocity.y.is_finite() { velocity } else { Vector2::zeros() };
    let dt = if dt_s.is_finite() && dt_s > 0.0 { dt_s } else { 0.0 };
    let finite_path: Vec<Point2<f64>> = path.iter().copied().filter(finite_point).collect();
    let (desired, carrot) = desired_velocity(&finite_path, position, p);
    let window = p.max_accel_mps2 * dt;
    let limit = |c: Vector2<f64>| clip(c, p.max_speed_mps);
    // seed 004 eq. 8: the velocities reachable in one step, inside the speed limit.
    let ideal = limit(v + clip(desired - v, window));
    let samples = WINDOW_RINGS.iter().flat_map(|&r| {
        (0..WINDOW_ANGLES).map(move |k| {
            let a = k as f64 * std::f64::consts::TAU / WINDOW_ANGLES as f64;
            Vector2::new(a.cos(), a.sin()) * (r * window)
        })
    });
    let others = samples.chain([-clip(v, window), Vector2::zeros()]).map(|d| limit(v + d));
    if admissible(ideal, position, dt, costs, p) {
        return TrackerOutput { velocity: ideal, carrot, safety: Safety::Clear };
    }
    let best = others
        .filter(|c| admissible(*c, position, dt, costs, p))
        .min_by(|a, b| (a - desired).norm_squared().total_cmp(&(b - desired).norm_squared()));
    match best {
        Some(c) => TrackerOutput { velocity: c, carrot, safety: Safety::Adjusted },
        None => TrackerOutput { carrot, ..stop },
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::FRAC_PI_2;

    /// A small costmap: `w × h` cells of `res` metres, origin at (0, 0), `None` outside.
    struct Grid {
        res: f64,
        w: i64,
        h: i64,
        cells: Vec<u8>,
    }

    impl Grid {
        fn new(res: f64, w: i64, h: i64, fill: u8) -> Self {
            Grid { res, w, h, cells: vec![fill; (w * h) as usize] }
        }
        fn set(&mut self, cx: i64, cy: i64, cost: u8) {
            self.cells[(cy * self.w + cx) as usize] = cost;
        }
        fn fill_rect(&mut self, xs: std::ops::RangeInclusive<i64>, ys: std::ops::RangeInclusive<i64>, cost: u8) {
            for cx in xs {
                for cy in ys.clone() {
                    self.set(cx, cy, cost);
                }
            }
        }
    }

    impl CostQuery for Grid {
        fn cost_at(&self, p: Point2<f64>) -> Option<u8> {
            let (cx, cy) = ((p.x / self.res).floor() as i64, (p.y / self.res).floor() as i64);
            let inside = (0..self.w).contains(&cx) && (0..self.h).contains(&cy);
            inside.then(|| self.cells[(cy * self.w + cx) as usize])
        }
        fn resolution(&self) -> f64 {
            self.res
        }
    }

    /// No map at all: every cell unknown, i.e. free.
    struct Free;
    impl CostQuery for Free {
        fn cost_at(&self, _: Point2<f64>) -> Option<u8> {
            None
        }
        fn resolution(&self) -> f64 {
            0.05
        }
    }

    fn uav(id: UavId, x: f64, y: f64) -> UavState {
        UavState { id, position: Point2::new(x, y), heading: 0.0 }
    }

    fn pt(x: f64, y: f64) -> Point2<f64> {
        Point2::new(x, y)
    }

    #[track_caller]
    fn close(a: Point2<f64>, b: Point2<f64>) {
        assert!((a - b).norm() < 1e-9, "{a:?} != {b:?}");
    }

    fn params() -> M23Params {
        M23Params::default()
    }

    // ---- formation goals -------------------------------------------------------------------

    #[test]
    fn lf_adds_the_table_7_offset_in_world_axes() {
        let p = params();
        let leader = UavState { id: UavId::new(1), position: pt(10.0, 5.0), heading: 0.7 };
        let goal = |id| formation_goal(Topology::Lf, &uav(id, 0.0, 0.0), Some(&leader), &[], &p).unwrap();
        // Offsets (−2, 0), (0, −2), (−2, −2); heading 0.7 ignored in the world frame.
        close(goal(UavId::new(2)), pt(8.0, 5.0));
        close(goal(UavId::new(3)), pt(10.0, 3.0));
        close(goal(UavId::new(4)), pt(8.0, 3.0));
        // Follower index 3 → generated slot 4 = (0, −4): (10, 1).
        close(goal(UavId::new(5)), pt(10.0, 1.0));
        let t = formation_target(Topology::Lf, &uav(UavId::new(3), 0.0, 0.0), Some(&leader), &[], &p).unwrap();
        close(t.reference, pt(10.0, 5.0));
    }

    #[test]
    fn lf_in_the_leader_frame_rotates_the_offset() {
        let p = M23Params { lf_frame: LfFrame::LeaderHeading, ..params() };
        let leader = UavState { id: UavId::new(1), position: pt(10.0, 5.0), heading: FRAC_PI_2 };
        // R(90°)·(−2, 0) = (0, −2) → (10, 3).
        let g = formation_goal(Topology::Lf, &uav(UavId::new(2), 0.0, 0.0), Some(&leader), &[], &p).unwrap();
        close(g, pt(10.0, 3.0));
        let blind = UavState { heading: f64::NAN, ..leader };
        assert_eq!(formation_goal(Topology::Lf, &uav(UavId::new(2), 0.0, 0.0), Some(&blind), &[], &p), None);
    }

    #[test]
    fn follower_order_skips_the_leader() {
        assert_eq!(follower_index(UavId::new(1), UavId::new(3)), Some(0));
        assert_eq!(follower_index(UavId::new(2), UavId::new(3)), Some(1));
        assert_eq!(follower_index(UavId::new(4), UavId::new(3)), Some(2));
        assert_eq!(follower_index(UavId::new(3), UavId::new(3)), None);
        assert_eq!(follower_index(UavId::new(0), UavId::new(3)), None);
        assert!(
            precedes(UavId::new(3), UavId::new(1), UavId::new(3))
                && precedes(UavId::new(1), UavId::new(2), UavId::new(3))
                && !precedes(UavId::new(4), UavId::new(2), UavId::new(3))
                && !precedes(UavId::new(2), UavId::new(2), UavId::new(3))
        );
    }

    #[test]
    fn no_goal_without_reference_or_for_the_leader() {
        let p = params();
        let leader = uav(UavId::new(1), 10.0, 5.0);
        let me = uav(UavId::new(3), 0.0, 0.0);
        assert_eq!(formation_goal(Topology::Lf, &me, None, &[], &p), None);
        assert_eq!(formation_goal(Topology::Pf, &me, None, &[uav(UavId::new(4), 1.0, 1.0)], &p), None);
        assert_eq!(formation_goal(Topology::Tnpf, &me, None, &[uav(UavId::new(5), 1.0, 1.0)], &p), None);
        assert_eq!(formation_goal(Topology::None, &me, Some(&leader), &[], &p), None);
        assert_eq!(formation_goal(Topology::Lf, &leader, Some(&leader), &[], &p), None);
        // A leader with a non-finite position is unknown.
        let lost = uav(UavId::new(1), f64::NAN, 0.0);
        assert_eq!(formation_goal(Topology::Lf, &me, Some(&lost), &[], &p), None);
    }

    #[test]
    fn pf_pulls_the_predecessor_back_towards_me() {
        let p = params();
        let me = uav(UavId::new(3), 0.0, 0.0);
        let leader = uav(UavId::new(1), 6.0, 8.0);
        let known = [uav(UavId::new(2), 3.0, 4.0), uav(UavId::new(4), 1.0, 1.0)];
        // Predecessor uav2 at (3, 4), |·| = 5: goal = (3, 4) − 2·(0.6, 0.8) = (1.8, 2.4).
        let t = formation_target(Topology::Pf, &me, Some(&leader), &known, &p).unwrap();
        close(t.goal, pt(1.8, 2.4));
        close(t.reference, pt(3.0, 4.0));
        // uav2 unknown: the next one up, the leader at (6, 8), |·| = 10:
        // (6, 8) − 2·(0.6, 0.8) = (4.8, 6.4). The successor uav4 is never used.
        let g = formation_goal(Topology::Pf, &me, Some(&leader), &known[1..], &p).unwrap();
        close(g, pt(4.8, 6.4));
    }

    #[test]
    fn pf_with_a_leader_that_is_not_uav_1() {
        let p = M23Params { leader_id: UavId::new(3), ..params() };
        // Order 3, 1, 2, 4: uav1 follows the leader uav3 at (0, 5); me at the origin:
        // (0, 5) − 2·(0, 1) = (0, 3).
        let known = [uav(UavId::new(3), 0.0, 5.0), uav(UavId::new(2), 9.0, 9.0)];
        let g = formation_goal(Topology::Pf, &uav(UavId::new(1), 0.0, 0.0), None, &known, &p).unwrap();
        close(g, pt(0.0, 3.0));
    }

    #[test]
    fn pf_at_the_reference_pulls_back_along_minus_x() {
        // atan2(0, 0) = 0: (4, 4) − 2·(1, 0) = (2, 4).
        let g = formation_goal(
            Topology::Pf,
            &uav(UavId::new(2), 4.0, 4.0),
            Some(&uav(UavId::new(1), 4.0, 4.0)),
            &[],
            &params(),
        );
        close(g.unwrap(), pt(2.0, 4.0));
    }

    #[test]
    fn tnpf_pulls_the_centre_of_the_two_nearest_predecessors_back() {
        let p = params();
        let me = uav(UavId::new(4), 0.0, 0.0);
        let leader = uav(UavId::new(1), 6.0, 0.0);
        // Predecessors: uav2 at distance 4, uav1 at 6, uav3 at 14.1; uav5 (distance 1) follows me.
        let known = [uav(UavId::new(2), 0.0, 4.0), uav(UavId::new(3), 10.0, 10.0), uav(UavId::new(5), 1.0, 0.0)];
        let t = formation_target(Topology::Tnpf, &me, Some(&leader), &known, &p).unwrap();
        // Centre (3, 2), |·| = √13: goal = (3 − 2·3/√13, 2 − 2·2/√13) = (1.33591…, 0.89061…).
        let s = 13f64.sqrt();
        close(t.goal, pt(3.0 - 6.0 / s, 2.0 - 4.0 / s));
        close(t.reference, pt(3.0, 2.0));
    }

    #[test]
    fn tnpf_with_one_predecessor_is_pf() {
        let p = M23Params { tnpf_distance_m: 1.0, ..params() };
        // Only the leader precedes uav2: (0, 3) − 1·(0, 1) = (0, 2).
        let g = formation_goal(
            Topology::Tnpf,
            &uav(UavId::new(2), 0.0, 0.0),
            Some(&uav(UavId::new(1), 0.0, 3.0)),
            &[uav(UavId::new(3), 0.0, 1.0)],
            &p,
        );
        close(g.unwrap(), pt(0.0, 2.0));
    }

    #[test]
    fn non_finite_uavs_are_ignored() {
        let p = params();
        let known = [uav(UavId::new(2), f64::NAN, 0.0), uav(UavId::new(1), 0.0, 5.0)];
        // uav2 ignored: PF on the leader, (0, 5) − 2·(0, 1) = (0, 3).
        close(formation_goal(Topology::Pf, &uav(UavId::new(3), 0.0, 0.0), None, &known, &p).unwrap(), pt(0.0, 3.0));
        assert_eq!(formation_goal(Topology::Pf, &uav(UavId::new(3), f64::NAN, 0.0), None, &known, &p), None);
    }

    proptest! {
        #[test]
        fn pf_goal_lies_on_the_segment_at_the_follow_distance(
            px in -50.0..50.0f64, py in -50.0..50.0f64, mx in -50.0..50.0f64, my in -50.0..50.0f64,
        ) {
            let p = params();
            let (me, leader) = (uav(UavId::new(2), mx, my), uav(UavId::new(1), px, py));
            let g = formation_goal(Topology::Pf, &me, Some(&leader), &[], &p).unwrap();
            let reference = pt(px, py);
            prop_assert!(((g - reference).norm() - p.pf_distance_m).abs() < 1e-9);
            let away = pt(mx, my) - reference;
            if away.norm() > 1e-6 {
                // The goal is on my side of the predecessor (beyond me when I am within 2 m).
                prop_assert!((g - reference).dot(&away) > 0.0);
            }
        }
    }

    // ---- goal validation -------------------------------------------------------------------

    /// 10 m × 10 m at 0.5 m, free, with a lethal block over cells x 5..=11, y 8..=12.
    fn blocked_grid() -> Grid {
        let mut g = Grid::new(0.5, 20, 20, 0);
        g.fill_rect(5..=11, 8..=12, LETHAL);
        g
    }

    #[test]
    fn a_free_goal_is_kept() {
        let t = FormationTarget { goal: pt(1.25, 1.25), reference: pt(3.0, 3.0) };
        assert_eq!(validate_goal(&t, &blocked_grid(), &params()), Some(pt(1.25, 1.25)));
    }

    #[test]
    fn a_goal_on_a_lethal_cell_moves_to_the_nearest_free_cell() {
        // Goal (5.25, 5.25) is cell (10, 10), lethal. Centre = midpoint with the reference
        // (1.25, 5.25) = (3.25, 5.25), cell (6, 10), lethal; ring 1 → cells x 5..7, lethal;
        // ring 2: (−2, 0) → (2.25, 5.25), cell (4, 10), free, d² = 4; (2, 0) and (0, ±2) lethal.
        let t = FormationTarget { goal: pt(5.25, 5.25), reference: pt(1.25, 5.25) };
        let g = validate_goal(&t, &blocked_grid(), &params()).unwrap();
        close(g, pt(2.25, 5.25));
    }

    #[test]
    fn no_free_cell_within_the_radius_keeps_the_previous_goal() {
        // Radius 0.75 m = 1.5 cells: rings 0 and 1 only, all lethal.
        let p = M23Params { searching_radius_m: 0.75, ..params() };
        let t = FormationTarget { goal: pt(5.25, 5.25), reference: pt(1.25, 5.25) };
        assert_eq!(validate_goal(&t, &blocked_grid(), &p), None);
        // Through the follower loop: uav2 in LF with the leader at (7.25, 5.25), offset (−2, 0).
        let leader = uav(UavId::new(1), 7.25, 5.25);
        let mut grid = blocked_grid();
        grid.fill_rect(12..=13, 8..=12, LETHAL);
        let previous = Some(pt(0.5, 0.5));
        let input = FollowerInput {
            me: uav(UavId::new(2), 0.0, 0.0),
            leader: Some(&leader),
            neighbours: &[],
            leader_goal: pt(40.0, 0.0),
            own_goal: pt(41.0, 0.0),
            previous_goal: previous,
        };
        // Goal (5.25, 5.25) lethal; centre (6.25, 5.25) = cell (12, 10), lethal, ring 1 = cells
        // x 11..13, lethal: nothing within 0.75 m, the previous goal stays.
        assert_eq!(follower_goal(Topology::Lf, &input, &grid, &p), previous);
    }

    #[test]
    fn the_search_returns_the_euclidean_nearest_not_the_first_ring_hit() {
        // All lethal but two cells around the centre cell (10, 10): offset (3, 3) in ring 3
        // (d² = 18) and offset (4, 0) in ring 4 (d² = 16). The nearer one is (4, 0).
        let mut g = Grid::new(0.5, 20, 20, LETHAL);
        g.set(13, 13, 0);
        g.set(14, 10, 0);
        let found = nearest_low_cost(pt(5.25, 5.25), &g, 50, 3.0).unwrap();
        close(found, pt(7.25, 5.25));
        // Radius 2 m = 4 cells: (4, 0) is on the disk's edge, (3, 3) at 4.24 cells outside it.
        assert_eq!(nearest_low_cost(pt(5.25, 5.25), &g, 50, 2.0), Some(pt(7.25, 5.25)));
        assert_eq!(nearest_low_cost(pt(5.25, 5.25), &g, 50, 1.9), None);
    }

    #[test]
    fn the_threshold_is_strict_and_unknown_is_free() {
        let p = params();
        let mut g = Grid::new(0.5, 20, 20, 0);
        let t = FormationTarget { goal: pt(5.25, 5.25), reference: pt(1.25, 5.25) };
        g.set(10, 10, 49);
        assert_eq!(validate_goal(&t, &g, &p), Some(t.goal));
        // Cost 50 is not < 50: searched from the midpoint (3.25, 5.25), which is free.
        g.set(10, 10, 50);
        assert_eq!(validate_goal(&t, &g, &p), Some(pt(3.25, 5.25)));
        let outside = FormationTarget { goal: pt(-3.0, -3.0), reference: pt(0.0, 0.0) };
        assert_eq!(validate_goal(&outside, &g, &p), Some(pt(-3.0, -3.0)));
    }

    #[test]
    fn followers_go_to_their_own_goal_once_the_leader_arrived() {
        let p = params();
        let mut leader = uav(UavId::new(1), 29.0, 0.0);
        fn input(leader: &UavState) -> FollowerInput<'_> {
            FollowerInput {
                me: uav(UavId::new(3), 20.0, 0.0),
                leader: Some(leader),
                neighbours: &[],
                leader_goal: pt(30.0, 0.0),
                own_goal: pt(28.0, -2.0),
                previous_goal: None,
            }
        }
        // |(29, 0) − (30, 0)| = 1 < 2: own goal.
        assert_eq!(follower_goal(Topology::Lf, &input(&leader), &Free, &p), Some(pt(28.0, -2.0)));
        // 3 ≥ 2: the LF goal (27, 0) + (0, −2) = (27, −2).
        leader.position = pt(27.0, 0.0);
        assert_eq!(follower_goal(Topology::Lf, &input(&leader), &Free, &p), Some(pt(27.0, -2.0)));
        assert_eq!(follower_goal(Topology::None, &input(&leader), &Free, &p), Some(pt(28.0, -2.0)));
    }

    // ---- leader wait -----------------------------------------------------------------------

    #[test]
    fn far_means_strictly_beyond_max_distance() {
        let leader = pt(0.0, 0.0);
        assert!(!any_follower_far(leader, &[pt(3.0, 4.0), pt(6.0, 0.0), pt(f64::NAN, 0.0)], 6.0));
        assert!(any_follower_far(leader, &[pt(3.0, 4.0), pt(6.1, 0.0)], 6.0));
    }

    #[test]
    fn leader_waits_then_resumes_after_max_time() {
        let p = params(); // MAX_TIME 10 s
        let mut w = LeaderWait::default();
        assert!(!w.step(0.0, Some(false), &p));
        assert!(w.step(1.0, Some(true), &p)); // waiting since 1
        assert!(w.step(5.0, Some(true), &p));
        assert!(w.step(11.0, Some(true), &p)); // 11 − 1 = 10, not > 10
        assert!(!w.step(11.5, Some(true), &p)); // 10.5 > 10: go
        assert_eq!(w.state, LeaderState::TimedOut);
        assert!(!w.step(30.0, Some(true), &p)); // still far: does not wait again
        assert!(!w.step(31.0, Some(false), &p)); // caught up: timer reset
        assert!(w.step(32.0, Some(true), &p)); // a new episode waits again
        assert_eq!(w.state, LeaderState::Waiting { since_secs: 32.0 });
    }

    #[test]
    fn leader_resumes_when_followers_catch_up_and_keeps_state_without_poses() {
        let p = params();
        let mut w = LeaderWait::default();
        assert!(w.step(1.0, Some(true), &p));
        assert!(!w.step(3.0, Some(false), &p));
        assert!(!w.step(4.0, None, &p)); // no poses: keeps going
        assert!(w.step(5.0, Some(true), &p));
        assert!(w.step(9.0, None, &p)); // no poses: keeps waiting…
        assert!(!w.step(15.5, None, &p)); // …but the timeout still applies: 10.5 > 10
        assert!(!w.step(f64::NAN, Some(true), &p));
    }

    // ---- tracker ---------------------------------------------------------------------------

    fn straight_path() -> Vec<Point2<f64>> {
        vec![pt(0.0, 0.0), pt(10.0, 0.0)]
    }

    #[test]
    fn tracker_accelerates_from_rest_within_the_limit() {
        // Desired (1.5, 0) towards the carrot 1.5 m ahead; a·dt = 1·0.1: command (0.1, 0).
        let out = track(&straight_path(), pt(0.0, 0.0), Vector2::zeros(), 0.1, &Free, &params());
        assert!((out.velocity - Vector2::new(0.1, 0.0)).norm() < 1e-12);
        close(out.carrot.unwrap(), pt(1.5, 0.0));
        assert_eq!(out.safety, Safety::Clear);
    }

    #[test]
    fn tracker_brakes_towards_the_end_of_the_path() {
        let p = params();
        // 1 m left: speed = min(1.5, √(2·1·1)) = √2; Δ = √2 − 1.5 = −0.0858, within 0.1.
        let out = track(&straight_path(), pt(9.0, 0.0), Vector2::new(1.5, 0.0), 0.1, &Free, &p);
        assert!((out.velocity - Vector2::new(2f64.sqrt(), 0.0)).norm() < 1e-12);
        // 0.4 m left ≤ tolerance 0.5: desired 0, from 0.5 m/s the command is 0.4 m/s.
        let out = track(&straight_path(), pt(9.6, 0.0), Vector2::new(0.5, 0.0), 0.1, &Free, &p);
        assert!((out.velocity - Vector2::new(0.4, 0.0)).norm() < 1e-12);
        // Off the path at (5, 1): projection (5, 0), carrot (6.5, 0): direction (1.5, −1)/1.8028.
        let out = track(&straight_path(), pt(5.0, 1.0), Vector2::zeros(), 1.0, &Free, &p);
        let d: Vector2<f64> = Vector2::new(1.5, -1.0);
        assert!((out.velocity - d / d.norm()).norm() < 1e-12);
    }

    /// 12 m × 8 m at 0.1 m, free, with a lethal wall over x ∈ [5.0, 5.3) at every y.
    fn wall_grid() -> Grid {
        let mut g = Grid::new(0.1, 120, 80, 0);
        g.fill_rect(50..=52, 0..=79, LETHAL);
        g
    }

    #[test]
    fn tracker_never_enters_a_lethal_cell() {
        let p = params();
        let g = wall_grid();
        let path = vec![pt(1.0, 4.0), pt(9.0, 4.0)]; // straight through the wall
        let (mut pos, mut v, dt) = (pt(1.0, 4.0), Vector2::zeros(), 0.1);
        let mut closest = f64::INFINITY;
        for _ in 0..300 {
            let out = track(&path, pos, v, dt, &g, &p);
            assert!(out.velocity.norm() <= p.max_speed_mps + 1e-9);
            assert!((out.velocity - v).norm() <= p.max_accel_mps2 * dt + 1e-9, "{out:?} from {v:?}");
            let next = pos + out.velocity * dt;
            for k in 0..=100 {
                let q = pos + (next - pos) * (k as f64 / 100.0);
                assert_ne!(g.cost_at(q), Some(LETHAL), "stepped onto the wall at {q:?}");
            }
            (pos, v) = (next, out.velocity);
            closest = closest.min(5.0 - pos.x);
        }
        // It flew up to the wall (within a few cm) and stopped there.
        assert!(closest < 0.1 && pos.x < 5.0, "closest {closest}, at {pos:?}");
        assert!(v.norm() < 0.2, "{v:?}");
    }

    #[test]
    fn tracker_stops_when_no_velocity_of_the_window_can_stop_in_time() {
        // 1.5 m/s, wall 0.2 m ahead: every window velocity has |v| ≥ 1.4 and a reach of at
        // least 0.14 + 1.4²/2 = 1.12 m along ≈ +x.
        let out =
            track(&[pt(4.8, 4.0), pt(9.0, 4.0)], pt(4.8, 4.0), Vector2::new(1.5, 0.0), 0.1, &wall_grid(), &params());
        assert_eq!(out.safety, Safety::Stopped);
        assert_eq!(out.velocity, Vector2::zeros());
    }

    #[test]
    fn tracker_backs_out_of_an_inscribed_band() {
        // Standing in an inscribed band (x ∈ [4, 5)) in front of the wall: moving back to the
        // free side is allowed, the path leads there.
        let mut g = wall_grid();
        g.fill_rect(40..=49, 0..=79, INSCRIBED);
        let out = track(&[pt(4.5, 4.0), pt(1.0, 4.0)], pt(4.5, 4.0), Vector2::zeros(), 0.1, &g, &params());
        assert_eq!(out.safety, Safety::Clear);
        assert!((out.velocity - Vector2::new(-0.1, 0.0)).norm() < 1e-12);
        // Towards the wall it may move inside the band but not into the wall: from x = 4.99 the
        // path velocity (0.1, 0) reaches 0.1·0.1 + 0.1²/2 = 0.015 m, to x = 5.005, lethal.
        let out = track(&[pt(4.99, 4.0), pt(9.0, 4.0)], pt(4.99, 4.0), Vector2::zeros(), 0.1, &g, &params());
        assert_eq!(out.safety, Safety::Adjusted);
        let reach = out.velocity.norm() * 0.1 + out.velocity.norm_squared() / 2.0;
        assert!(4.99 + reach * out.velocity.x / out.velocity.norm().max(1e-12) < 5.0, "{out:?}");
        let out = track(&[pt(4.9, 4.0), pt(9.0, 4.0)], pt(4.9, 4.0), Vector2::zeros(), 0.1, &g, &params());
        assert_eq!(out.safety, Safety::Clear);
    }

    #[test]
    fn tracker_with_non_finite_inputs() {
        let p = params();
        let out = track(&straight_path(), pt(f64::NAN, 0.0), Vector2::zeros(), 0.1, &Free, &p);
        assert_eq!((out.velocity, out.safety), (Vector2::zeros(), Safety::Stopped));
        // A NaN velocity is taken as rest; a NaN dt as a zero window: the command stays at rest.
        let out = track(&straight_path(), pt(0.0, 0.0), Vector2::new(f64::NAN, 0.0), f64::NAN, &Free, &p);
        assert_eq!(out.velocity, Vector2::zeros());
        let out = track(&[], pt(0.0, 0.0), Vector2::new(1.0, 0.0), 0.1, &Free, &p);
        assert!((out.velocity - Vector2::new(0.9, 0.0)).norm() < 1e-12);
        assert_eq!(out.carrot, None);
    }

    fn random_grid(cells: &[bool]) -> Grid {
        let mut g = Grid::new(0.25, 40, 40, 0);
        for (k, &lethal) in cells.iter().enumerate() {
            if lethal {
                g.set(k as i64 % 40, k as i64 / 40, LETHAL);
            }
        }
        g
    }

    proptest! {
        #[test]
        fn tracker_respects_speed_and_acceleration_limits(
            speed in 0.0..1.5f64, angle in -3.2..3.2f64, dt in 0.01..0.5f64,
            x in 0.0..10.0f64, y in 0.0..10.0f64,
            path in proptest::collection::vec((0.0..10.0f64, 0.0..10.0f64), 0..6),
            cells in proptest::collection::vec(proptest::bool::weighted(0.1), 1600),
            max_speed in 0.5..5.0f64, max_accel in 0.5..3.0f64,
        ) {
            let p = M23Params { max_speed_mps: max_speed, max_accel_mps2: max_accel, ..params() };
            let v = Vector2::new(angle.cos(), angle.sin()) * speed.min(max_speed);
            let path: Vec<Point2<f64>> = path.into_iter().map(|(a, b)| pt(a, b)).collect();
            let pos = pt(x, y);
            // Free map: both limits always hold.
            let out = track(&path, pos, v, dt, &Free, &p);
            prop_assert!(out.velocity.norm() <= max_speed + 1e-9);
            prop_assert!((out.velocity - v).norm() <= max_accel * dt + 1e-9);
            // Random lethal cells: both limits hold unless the tracker had to stop, and the step
            // never ends on a lethal cell when it did not start on one.
            let g = random_grid(&cells);
            let out = track(&path, pos, v, dt, &g, &p);
            prop_assert!(out.velocity.norm() <= max_speed + 1e-9);
            if out.safety != Safety::Stopped {
                prop_assert!((out.velocity - v).norm() <= max_accel * dt + 1e-9);
                if g.cost_at(pos) != Some(LETHAL) {
                    prop_assert_ne!(g.cost_at(pos + out.velocity * dt), Some(LETHAL));
                }
            }
        }
    }
}
