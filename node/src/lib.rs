//! The processes a run is made of, and what every command shares below them: the `swarm hub`,
//! `swarm agent`, `swarm router` and `swarm credentials` commands, the arguments they and every
//! other command take, and who may touch what. It links neither the recorder, the live view nor
//! the figures, so the `swarm-node` binary built from it is what an agent host or a UAV's
//! companion computer needs and no more (docs/hosts-and-containers.md); the `swarm` command
//! dispatches the same four commands here. (The container image still ships the whole `swarm`,
//! whose recorder the compose file runs too.)
//!
//! - [`args`]: the crate `swarm-args`, re-exported: what every command shares, below all of them
//!   ([`args::ZenohArgs`]: endpoints, `--cfg`, `--user` and `--password-file`; run ids, UAV id
//!   lists, scenario values on the command line), a crate of its own so the recorder and the
//!   viewer take their arguments without linking the hub and the agent.
//! - [`auth`]: who may touch what: users and passwords (`swarm credentials`, and fresh ones for
//!   every `swarm run`), and the access-control rules the hub's router enforces per role.
//! - [`pieces`]: `swarm hub` and `swarm agent`, the processes the launcher starts (or a person,
//!   by hand).
//! - [`router`]: `swarm router`: a bare Zenoh router between a group of agents and the hub, for
//!   swarms spread over several machines.
//! - [`command`]: the `swarm-node` command line: `hub`, `agent`, `router` and `credentials`.
//! - [`process`]: what every binary of the workspace does around its command: logging to
//!   standard error and the async runtime.
//!
//! Dependencies run one way: `command` → `router` → `pieces` → `auth`; `process` imports
//! nothing of the crate.

pub use swarm_args as args;
pub mod auth;
pub mod command;
pub mod pieces;
pub mod process;
pub mod router;
