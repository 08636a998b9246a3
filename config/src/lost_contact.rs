//! LostContactParams: what an agent does once it has had no neighbour estimate for a while.
//!
//! The seeds are silent on it (seed 000 6.2 only reports a separated UAV that rejoins), and a
//! flocking controller left alone keeps flying: K21's navigation pushes along the body x axis
//! with nothing to turn it, so a UAV cut off from its swarm flies on in a straight line for ever.
//! The agent's choice, in its own odometry frame and never from ground truth:
//!
//! 1. flock as usual while it has a neighbour estimate within `contact_radius_m` (one its
//!    controller flocks with), and remember where the swarm was last estimated (the centroid of
//!    its neighbour estimates, odometry frame);
//! 2. after `after_s` with none, if it still has estimates farther away (the swarm is heard but
//!    out of the controller's reach), fly towards them at K21's speed `kf`; with no estimate at
//!    all, fly back to where the swarm was last estimated at `speed_mps` (slower than the flock,
//!    so the swarm can catch up); either way avoiding the trees and walls its LIDAR sees (seed
//!    000's avoidance, 4.10–4.13);
//! 3. within `hold_radius_m` of where the swarm was last estimated, hover and wait;
//! 4. as soon as it has an estimate within reach again, flock again.
//!
//! An informed UAV (one that has a goal) keeps flying to its goal, where the swarm is going,
//! unless `informed_return` is set. A UAV that never had an estimate flocks as before (there is
//! nowhere to go back to).
//!
//! The same for a group (seed 000 is silent here too): a group cut off from every informed UAV
//! (by a partition, or because the informed failed) is never "alone", yet nobody steers it and
//! it flies on. Every share carries its sender's hop count to the nearest informed UAV (0 for
//! an informed UAV, one more than the smallest count heard for the others, so no id is
//! revealed; counts of `max_hops` or more mean "no path"). An uninformed UAV that has had no path
//! for `regroup_after_s` flies back, still flocking, to where it last had one, hovers within
//! `hold_radius_m` of it, and flocks again as soon as a path is back.
//!
//! Holding can last for ever: the swarm it waits for may have gone on to the goal, beyond radio
//! range, and nobody comes back (a UAV lost beside a frozen one, a half cut off for 60 s while
//! the other half arrived: issue 46). So, with `search_after_s` above 0, a UAV (or group) that
//! has held for that long searches: it flies on from where it holds, `search_distance_m` along
//! the way it travelled while it last had a path to an informed UAV (its own odometry velocity,
//! smoothed), alone at `speed_mps`, in a group still flocking at K21's speed, then holds there.
//! The way the swarm was going is where the swarm went; a UAV that never had a path does not
//! search. Off by default, so the seeds' tables and every shipped flight keep their figures.

use serde::{Deserialize, Serialize};

/// The lost-contact behaviour of every controller (see the module doc).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LostContactParams {
    /// Off: the controller alone, as before (a lost UAV flies on).
    #[serde(default = "yes")]
    pub enabled: bool,
    /// With no neighbour estimate for this long, the UAV is lost [s]. 5 s: longer than the
    /// gaps of an ICP estimate among neighbours (a suspended entry waits 5 s too) and the
    /// 5 s link loss of `forest-5-linkloss`, so runs where nobody is cut off are untouched.
    #[serde(default = "d_after")]
    pub after_s: f64,
    /// Speed of the flight back [m/s]; below K21's 0.4 m/s so that the UAV slows down.
    #[serde(default = "d_speed")]
    pub speed_mps: f64,
    /// A neighbour estimate closer than this is contact [m]. Default (none): the reach of the
    /// scenario's controller: K21's `neighbour_radius_m` (it ignores farther neighbours, so a
    /// UAV that hears its swarm only beyond it flies on as if alone), any distance for the others
    /// (their cohesion pulls at any range).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_radius_m: Option<f64>,
    /// Within this distance of where the swarm was last estimated, the UAV hovers and waits [m].
    #[serde(default = "d_hold")]
    pub hold_radius_m: f64,
    /// An informed UAV goes back too, instead of flying on to its goal.
    #[serde(default)]
    pub informed_return: bool,
    /// With no path to an informed UAV for this long, an uninformed UAV that had one flies back
    /// to where it last had one [s] (see the module doc). 0 turns the group behaviour off.
    #[serde(default = "d_regroup")]
    pub regroup_after_s: f64,
    /// Hop counts of this or more mean "no path to an informed UAV". Once the informed are gone
    /// a group's counts rise by about one a tick, so this is also how fast "no path" is known;
    /// it must exceed the swarm's diameter in radio hops.
    #[serde(default = "d_max_hops")]
    pub max_hops: u8,
    /// Held this long [s], a UAV or group searches: on from where it holds along the way it last
    /// travelled with a path (see the module doc). 0 (the default) turns the search off.
    #[serde(default)]
    pub search_after_s: f64,
    /// How far the search flies on before holding again [m].
    #[serde(default = "d_search_distance")]
    pub search_distance_m: f64,
    /// A path leads only through a neighbour it localizes: a UAV whose lower hop count is heard
    /// only from UAVs it has no estimate of (ICP among few shared trees) for `after_s` flies
    /// back, flocking, to where it was last led, then holds (and searches) as a group with no
    /// path does. Off (the default): a path heard is a path, and the group flocks on, led by
    /// nobody it can see (issue 46's forest-9-cut-off over ICP flew out of the trees so).
    #[serde(default)]
    pub lead_in_sight: bool,
}

impl Default for LostContactParams {
    fn default() -> Self {
        LostContactParams {
            enabled: true,
            after_s: d_after(),
            speed_mps: d_speed(),
            hold_radius_m: d_hold(),
            contact_radius_m: None,
            informed_return: false,
            regroup_after_s: d_regroup(),
            max_hops: d_max_hops(),
            search_after_s: 0.0,
            search_distance_m: d_search_distance(),
            lead_in_sight: false,
        }
    }
}

fn yes() -> bool {
    true
}
fn d_after() -> f64 {
    5.0
}
fn d_regroup() -> f64 {
    10.0
}
fn d_max_hops() -> u8 {
    32
}
fn d_speed() -> f64 {
    0.25
}
fn d_hold() -> f64 {
    1.0
}
fn d_search_distance() -> f64 {
    30.0
}
