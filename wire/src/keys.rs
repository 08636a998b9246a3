//! The key-expression space of one run, `swarm/{run}/...`: [`Keys`] is the one place key strings
//! are made, so a key cannot be misspelt at one end only.
//!
//! Each method's doc shows the key it builds. ARCHITECTURE.md's key table says what travels on
//! each key and from whom to whom; `tests/tests/tidy.rs` fails when the table and these methods
//! disagree (a method added here needs its row there). The families:
//! - run-wide: `clock`, `scenario` (a queryable answering the scenario TOML), `netem/rules` and
//!   `netem/add` (the `[[netem]]` and `[[failures]]` timeline, as JSON text);
//! - one UAV's: `uav/{id}/sense` (its sensor frame, hub -> agent), `uav/{id}/cmd`
//!   (agent -> hub), `uav/{id}/share/{pose,obstacles}` (agent -> neighbours), `uav/{id}/state`;
//! - an agent host's: `host/{ids}/sense` (the sensor frames of its UAVs `ids`, `1-4,7`, in one
//!   message a tick, hub -> host), `host/{ids}/cmd` and `host/{ids}/state` (their commands and
//!   states, in one message each a lockstep tick, host -> hub and recorder);
//! - ground truth for the recorder: `truth/world`, `truth/step`;
//! - liveliness tokens: `alive/hub`, `alive/uav/{id}`, `alive/host/{ids}`, `alive/recorder`;
//! - wildcards for subscribers: `uav/*/sense`, `uav/*/cmd`, `uav/*/state`, `truth/**`,
//!   `alive/uav/*`, `host/*/sense`, `host/*/cmd`, `host/*/state`, `alive/host/*`.
//!
//! Run ids are checked ([`check_component`]), and [`Keys::uav_id_of`] reads a UAV id back from a
//! key of this run, [`Keys::host_ids_of`] a host's UAVs.

use crate::WireError;
use swarm_types::mode::{LocalizationMode, ShareKind};
use swarm_types::UavId;

/// Builds every key of run `run`.
#[derive(Debug, Clone)]
pub struct Keys {
    prefix: String,
}

/// Checks a run id or key component: non-empty, `[A-Za-z0-9_-]` only.
pub fn check_component(s: &str) -> Result<(), WireError> {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
        Ok(())
    } else {
        Err(WireError::BadKey(s.to_string()))
    }
}

impl Keys {
    /// Keys of run `run`; the id must be `[A-Za-z0-9_-]`.
    pub fn new(run: &str) -> Result<Keys, WireError> {
        check_component(run)?;
        Ok(Keys { prefix: format!("swarm/{run}") })
    }

    /// `swarm/{run}`
    pub fn prefix(&self) -> &str {
        &self.prefix
    }
    /// `swarm/{run}/**`: every key of the run.
    pub fn all(&self) -> String {
        format!("{}/**", self.prefix)
    }
    /// `swarm/{run}/clock`
    pub fn clock(&self) -> String {
        format!("{}/clock", self.prefix)
    }
    /// `swarm/{run}/scenario`
    pub fn scenario(&self) -> String {
        format!("{}/scenario", self.prefix)
    }
    /// `swarm/{run}/uav/{id}/sense`
    pub fn sense(&self, id: UavId) -> String {
        format!("{}/uav/{id}/sense", self.prefix)
    }
    /// `swarm/{run}/uav/*/sense`: every UAV's sensor frames.
    pub fn sense_any(&self) -> String {
        format!("{}/uav/*/sense", self.prefix)
    }
    /// `swarm/{run}/host/{ids}/sense`: the sensor frames of an agent host's UAVs `ids`
    /// (ascending, `1-4,7`), in one message a tick.
    pub fn host_sense(&self, ids: &[UavId]) -> String {
        format!("{}/host/{}/sense", self.prefix, swarm_types::ids_text(ids))
    }
    /// `swarm/{run}/host/*/sense`: every agent host's sensor frames.
    pub fn host_sense_any(&self) -> String {
        format!("{}/host/*/sense", self.prefix)
    }
    /// `swarm/{run}/host/{ids}/cmd`: the commands of an agent host's UAVs `ids` (ascending), in
    /// one message a lockstep tick.
    pub fn host_cmd(&self, ids: &[UavId]) -> String {
        format!("{}/host/{}/cmd", self.prefix, swarm_types::ids_text(ids))
    }
    /// `swarm/{run}/host/*/cmd`: every agent host's commands.
    pub fn host_cmd_any(&self) -> String {
        format!("{}/host/*/cmd", self.prefix)
    }
    /// `swarm/{run}/host/{ids}/state`: the states of an agent host's UAVs `ids` (ascending), in
    /// one message a lockstep tick.
    pub fn host_state(&self, ids: &[UavId]) -> String {
        format!("{}/host/{}/state", self.prefix, swarm_types::ids_text(ids))
    }
    /// `swarm/{run}/host/*/state`: every agent host's states.
    pub fn host_state_any(&self) -> String {
        format!("{}/host/*/state", self.prefix)
    }
    /// `swarm/{run}/uav/{id}/cmd`
    pub fn cmd(&self, id: UavId) -> String {
        format!("{}/uav/{id}/cmd", self.prefix)
    }
    /// `swarm/{run}/uav/*/cmd`
    pub fn cmd_any(&self) -> String {
        format!("{}/uav/*/cmd", self.prefix)
    }
    /// `swarm/{run}/uav/{id}/share/pose`
    pub fn share_pose(&self, id: UavId) -> String {
        self.share(id, ShareKind::Pose)
    }
    /// `swarm/{run}/uav/{id}/share/obstacles`
    pub fn share_obstacles(&self, id: UavId) -> String {
        self.share(id, ShareKind::Obstacles)
    }
    /// `swarm/{run}/uav/{id}/share/{kind}`
    pub fn share(&self, id: UavId, kind: ShareKind) -> String {
        format!("{}/uav/{id}/share/{}", self.prefix, kind.name())
    }
    /// The key UAV `id` shares on in localization mode `mode`, if it shares anything.
    pub fn share_of(&self, mode: LocalizationMode, id: UavId) -> Option<String> {
        mode.share().map(|kind| self.share(id, kind))
    }
    /// `swarm/{run}/uav/{id}/state`
    pub fn state(&self, id: UavId) -> String {
        format!("{}/uav/{id}/state", self.prefix)
    }
    /// `swarm/{run}/uav/*/state`
    pub fn state_any(&self) -> String {
        format!("{}/uav/*/state", self.prefix)
    }
    /// `swarm/{run}/uav/*/share/pose`: every UAV's broadcast pose.
    pub fn share_pose_any(&self) -> String {
        format!("{}/uav/*/share/pose", self.prefix)
    }
    /// `swarm/{run}/uav/*/share/obstacles`: every UAV's obstacle set.
    pub fn share_obstacles_any(&self) -> String {
        format!("{}/uav/*/share/obstacles", self.prefix)
    }
    /// `swarm/{run}/uav/{id}/share/**`: whatever UAV `id` shares.
    pub fn shares_of(&self, id: UavId) -> String {
        format!("{}/uav/{id}/share/**", self.prefix)
    }
    /// `swarm/{run}/uav/*/share/**`: whatever any UAV shares.
    pub fn shares_any(&self) -> String {
        format!("{}/uav/*/share/**", self.prefix)
    }
    /// `swarm/{run}/netem/rules`
    pub fn netem_rules(&self) -> String {
        format!("{}/netem/rules", self.prefix)
    }
    /// `swarm/{run}/netem/add`
    pub fn netem_add(&self) -> String {
        format!("{}/netem/add", self.prefix)
    }
    /// `swarm/{run}/netem/ack`: the hub's answer to each timeline on `netem/add` (JSON).
    pub fn netem_ack(&self) -> String {
        format!("{}/netem/ack", self.prefix)
    }
    /// `swarm/{run}/truth/world`
    pub fn truth_world(&self) -> String {
        format!("{}/truth/world", self.prefix)
    }
    /// `swarm/{run}/truth/step`
    pub fn truth_step(&self) -> String {
        format!("{}/truth/step", self.prefix)
    }
    /// `swarm/{run}/truth/**`
    pub fn truth_all(&self) -> String {
        format!("{}/truth/**", self.prefix)
    }
    /// `swarm/{run}/alive/hub`
    pub fn alive_hub(&self) -> String {
        format!("{}/alive/hub", self.prefix)
    }
    /// `swarm/{run}/alive/uav/{id}`
    pub fn alive_uav(&self, id: UavId) -> String {
        format!("{}/alive/uav/{id}", self.prefix)
    }
    /// `swarm/{run}/alive/host/{ids}`: an agent host of UAVs `ids` (ascending) takes their
    /// sensor frames on [`Keys::host_sense`].
    pub fn alive_host(&self, ids: &[UavId]) -> String {
        format!("{}/alive/host/{}", self.prefix, swarm_types::ids_text(ids))
    }
    /// `swarm/{run}/alive/host/*`
    pub fn alive_host_any(&self) -> String {
        format!("{}/alive/host/*", self.prefix)
    }
    /// `swarm/{run}/alive/ext/{id}`: an external controller of UAV `id` is connected.
    pub fn alive_ext(&self, id: UavId) -> String {
        format!("{}/alive/ext/{id}", self.prefix)
    }
    /// `swarm/{run}/uav/{id}/ext/view`: each tick's view of an externally controlled UAV (JSON).
    pub fn ext_view(&self, id: UavId) -> String {
        format!("{}/uav/{id}/ext/view", self.prefix)
    }
    /// `swarm/{run}/uav/{id}/ext/cmd`: an external controller's command (JSON).
    pub fn ext_cmd(&self, id: UavId) -> String {
        format!("{}/uav/{id}/ext/cmd", self.prefix)
    }
    /// `swarm/{run}/uav/*/ext/view`
    pub fn ext_view_any(&self) -> String {
        format!("{}/uav/*/ext/view", self.prefix)
    }
    /// `swarm/{run}/uav/*/ext/cmd`
    pub fn ext_cmd_any(&self) -> String {
        format!("{}/uav/*/ext/cmd", self.prefix)
    }
    /// `swarm/{run}/alive/ext/*`
    pub fn alive_ext_any(&self) -> String {
        format!("{}/alive/ext/*", self.prefix)
    }
    /// `swarm/{run}/alive/recorder`
    pub fn alive_recorder(&self) -> String {
        format!("{}/alive/recorder", self.prefix)
    }
    /// `swarm/{run}/alive/uav/*`
    pub fn alive_uav_any(&self) -> String {
        format!("{}/alive/uav/*", self.prefix)
    }

    /// The UAV id in a key of this run: `swarm/{run}/uav/{id}/...` or `swarm/{run}/alive/uav/{id}`,
    /// read by position after the run prefix (so a run named `uav` cannot confuse it). Ids are
    /// 1-based: 0, non-numbers and other keys give `None`.
    pub fn uav_id_of(&self, key: &str) -> Option<UavId> {
        let rest = key.strip_prefix(self.prefix.as_str())?.strip_prefix('/')?;
        match rest.split('/').collect::<Vec<_>>().as_slice() {
            ["uav", id, ..] | ["alive", "uav", id] => id.parse::<UavId>().ok(),
            _ => None,
        }
    }

    /// The UAVs of an agent host's key of this run (`swarm/{run}/host/{ids}/{sense,cmd,state}`
    /// or `swarm/{run}/alive/host/{ids}`), ascending; `None` for other keys and for a list that
    /// is not the canonical `1-4,7` (a repeat, a range going down, not ascending), which no host
    /// writes.
    pub fn host_ids_of(&self, key: &str) -> Option<Vec<UavId>> {
        let rest = key.strip_prefix(self.prefix.as_str())?.strip_prefix('/')?;
        let text = match rest.split('/').collect::<Vec<_>>().as_slice() {
            ["host", ids, "sense" | "cmd" | "state"] | ["alive", "host", ids] => *ids,
            _ => return None,
        };
        let ids = swarm_types::parse_ids(text).ok()?;
        let canonical = ids.windows(2).all(|w| w[0] < w[1]) && swarm_types::ids_text(&ids) == text;
        canonical.then_some(ids)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_under_the_run_prefix() {
        let k = Keys::new("r-1_a").expect("valid run id");
        assert_eq!(k.sense(UavId::new(3)), "swarm/r-1_a/uav/3/sense");
        assert_eq!(k.cmd_any(), "swarm/r-1_a/uav/*/cmd");
        assert_eq!(k.truth_step(), "swarm/r-1_a/truth/step");
        assert_eq!(k.alive_uav(UavId::new(7)), "swarm/r-1_a/alive/uav/7");
    }

    #[test]
    fn bad_run_ids_are_refused() {
        for bad in ["", "a/b", "a*", "x y", "$x", "a#"] {
            assert!(Keys::new(bad).is_err(), "{bad:?} should be refused");
        }
    }

    #[test]
    fn uav_id_is_read_back_from_keys() {
        let k = Keys::new("r").expect("valid");
        assert_eq!(k.uav_id_of(&k.cmd(UavId::new(12))), Some(UavId::new(12)));
        assert_eq!(k.uav_id_of(&k.alive_uav(UavId::new(4))), Some(UavId::new(4)));
        assert_eq!(k.uav_id_of(&k.clock()), None);
        assert_eq!(k.uav_id_of("swarm/r/uav/x/cmd"), None);
        assert_eq!(k.uav_id_of("swarm/r/uav/0/cmd"), None, "ids are 1-based");
        assert_eq!(k.uav_id_of("swarm/other/uav/3/cmd"), None, "another run");
    }

    #[test]
    fn host_keys_name_their_uavs_and_read_back() {
        let k = Keys::new("r").expect("valid");
        let ids: Vec<UavId> = [1, 2, 3, 4, 7].map(UavId::new).to_vec();
        assert_eq!(k.host_sense(&ids), "swarm/r/host/1-4,7/sense");
        assert_eq!(k.alive_host(&ids), "swarm/r/alive/host/1-4,7");
        assert_eq!(k.host_ids_of(&k.host_sense(&ids)), Some(ids.clone()));
        assert_eq!(k.host_ids_of(&k.alive_host(&ids)), Some(ids.clone()));
        assert_eq!(k.host_cmd(&ids), "swarm/r/host/1-4,7/cmd");
        assert_eq!(k.host_ids_of(&k.host_cmd(&ids)), Some(ids.clone()));
        assert_eq!(k.host_ids_of(&k.host_state(&ids)), Some(ids.clone()));
        assert_eq!(k.host_ids_of("swarm/r/host/1-4,7/share"), None, "no such host key");
        assert_eq!(k.host_ids_of("swarm/r/alive/host/4,1-3"), None, "not ascending");
        assert_eq!(k.host_ids_of("swarm/r/alive/host/1-2,2"), None, "a repeat");
        assert_eq!(k.host_ids_of(&k.sense(UavId::new(3))), None);
        // Zenoh takes the list as one chunk of a key, and the wildcard matches it.
        let key = zenoh::key_expr::KeyExpr::try_from(k.host_sense(&ids)).expect("a valid key expression");
        let any = zenoh::key_expr::KeyExpr::try_from(k.host_sense_any()).expect("valid");
        assert!(any.intersects(&key));
    }

    #[test]
    fn a_run_named_uav_parses() {
        let k = Keys::new("uav").expect("valid");
        assert_eq!(k.uav_id_of(&k.alive_uav(UavId::new(1))), Some(UavId::new(1)));
        assert_eq!(k.uav_id_of(&k.cmd(UavId::new(2))), Some(UavId::new(2)));
        assert_eq!(k.uav_id_of(&k.alive_hub()), None);
    }
}
