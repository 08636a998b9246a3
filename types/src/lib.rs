//! The ground floor: the words every crate of the swarm uses for the same things, so none spells
//! them out again and the copies cannot drift.
//!
//! - `id`, [`UavId`]: a UAV's id as the scenario, the keys and the messages number it (from 1),
//!   with the one conversion to and from its index in id order (from 0), and lists of ids as
//!   the `--ids` syntax writes them (`1-4,7`).
//! - `time`, [`SimTime`]: a time on the simulation's clock [s], and the tick arithmetic of a
//!   fixed rate.
//! - [`frame`]: 2D poses and points tagged with the frame they are expressed in (world, a body,
//!   an odometry frame), and the one angle wrap.
//! - [`mode`]: the localization and time modes with their names as the scenario spells them.
//! - [`radio`]: the radio's range-with-hysteresis rule, which the hub applies to links and the
//!   recorder to a UAV's time out of reach.
//!
//! Every type here serializes as the plain value it wraps (`serde(transparent)`), so a message or
//! a scenario that nests them is the same bytes and the same text as one that held the value.
//! **Invariant:** the leaf of the workspace: depends on no crate of it, no IO, no behaviour beyond
//! arithmetic on these values.

pub mod frame;
mod id;
pub mod mode;
pub mod radio;
mod time;

pub use frame::{wrap_angle, Point, Pose};
pub use id::{ids_text, parse_ids, ParseUavIdError, UavId};
pub use mode::{LocalizationMode, TimeMode};
pub use radio::Hysteresis;
pub use time::SimTime;
