//! Test fixtures shared by the tests of every part: a truth body and a blank agent state, so
//! each part's tests build their messages alike.

use swarm_types::UavId;
use swarm_wire::{AgentState, TruthBody};

/// UAV `id`'s body at `(x, 0)`, with the hub's obstacle and nearest-UAV distances `od` and `ad`,
/// alive, its command on time or not.
pub(super) fn body(id: u32, x: f64, od: f64, ad: f64, on_time: bool) -> TruthBody {
    TruthBody {
        id: UavId::new(id),
        x,
        y: 0.0,
        yaw: 0.0,
        vx: 0.0,
        vy: 0.0,
        alive: true,
        cmd_on_time: on_time,
        obstacle_distance_m: od,
        agent_distance_m: ad,
        colliding: false,
    }
}

/// A state of UAV `id` with no estimate, at tick 0.
pub(super) fn blank_state(id: u32) -> AgentState {
    AgentState { id: UavId::new(id), step_time_us: 10, ..AgentState::default() }
}
