//! The files of a run folder that grow while the run goes (`trajectories.csv`,
//! `agent_states.csv`, `localization.csv`), the ones written at its end (`world.json`,
//! `connectivity.csv`: what `swarm plot` reads besides), and the recorder's decoding of what it
//! receives.

use super::fixed::Fixed;
use super::metrics::{ComponentsRow, Scored};
use anyhow::{Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use swarm_wire::{AgentState, Msg, TruthStep, TruthWorld};

/// The files of a run folder that grow while the run goes.
pub struct Files {
    traj: BufWriter<File>,
    states: BufWriter<File>,
    loc: BufWriter<File>,
}

fn create(dir: &Path, name: &str) -> Result<BufWriter<File>> {
    let p = dir.join(name);
    Ok(BufWriter::new(File::create(&p).with_context(|| format!("cannot create {}", p.display()))?))
}

impl Files {
    /// Creates `trajectories.csv`, `agent_states.csv` and `localization.csv` in `dir`, with
    /// headers.
    pub fn create(dir: &Path) -> Result<Files> {
        let open = |name: &str| create(dir, name);
        let mut traj = open("trajectories.csv")?;
        writeln!(traj, "{TRAJECTORY_HEADER}")?;
        let mut states = open("agent_states.csv")?;
        writeln!(states, "tick,t_s,id,step_time_us,obstacles,neighbours,in_radio_range,cohesion,separation,avoidance,navigation,output_mps,msgs_tx,bytes_tx,msgs_rx,bytes_rx,icp_short,icp_long,icp_initial,icp_deferred,db_entries,db_suspended")?;
        let mut loc = open("localization.csv")?;
        writeln!(loc, "tick,t_s,id,neighbours,scored,mean_error_m,max_error_m")?;
        Ok(Files { traj, states, loc })
    }

    /// Appends one step's rows.
    pub fn write_step(&mut self, s: &TruthStep) -> Result<()> {
        Ok(write_trajectory_rows(&mut self.traj, s)?)
    }

    /// Appends one agent state row.
    pub fn write_state(&mut self, st: &AgentState) -> Result<()> {
        let v = &st.vectors;
        let l = &st.link;
        let c = &st.icp;
        writeln!(
            self.states,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            st.tick,
            Fixed(st.t_s, 3),
            st.id,
            st.step_time_us,
            st.obstacles,
            st.neighbours.len(),
            st.in_radio_range,
            Fixed(f64::from(v.cohesion), 4),
            Fixed(f64::from(v.separation), 4),
            Fixed(f64::from(v.avoidance), 4),
            Fixed(f64::from(v.navigation), 4),
            Fixed(f64::from(v.output), 4),
            l.sent_msgs,
            l.sent_bytes,
            l.recv_msgs,
            l.recv_bytes,
            c.short,
            c.long,
            c.initial,
            c.deferred,
            c.entries,
            c.suspended
        )?;
        Ok(())
    }

    /// Appends scored states (rows in scoring order: a state waits for its tick's truth).
    pub fn write_scored(&mut self, rows: &[Scored]) -> Result<()> {
        for r in rows {
            writeln!(
                self.loc,
                "{},{},{},{},{},{},{}",
                r.tick,
                Fixed(r.t_s, 3),
                r.id,
                r.neighbours,
                r.scored,
                Fixed(r.mean_error_m, 4),
                Fixed(r.max_error_m, 4)
            )?;
        }
        Ok(())
    }

    /// Flushes every file.
    pub fn flush(&mut self) -> Result<()> {
        self.traj.flush()?;
        self.states.flush()?;
        self.loc.flush()?;
        Ok(())
    }
}

/// The header line of `trajectories.csv`, the columns [`write_trajectory_rows`] writes.
const TRAJECTORY_HEADER: &str =
    "tick,t_s,id,x_m,y_m,yaw_rad,vx_mps,vy_mps,obstacle_distance_m,agent_distance_m,colliding,alive,cmd_on_time";

/// Writes one step's `trajectories.csv` rows (one per body) to `out`.
pub fn write_trajectory_rows(out: &mut impl Write, s: &TruthStep) -> std::io::Result<()> {
    for b in &s.bodies {
        writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{}",
            s.tick,
            Fixed(s.t_s, 3),
            b.id,
            Fixed(b.x, 4),
            Fixed(b.y, 4),
            Fixed(b.yaw, 4),
            Fixed(b.vx, 4),
            Fixed(b.vy, 4),
            Fixed(b.obstacle_distance_m, 4),
            Fixed(b.agent_distance_m, 4),
            u8::from(b.colliding),
            u8::from(b.alive),
            u8::from(b.cmd_on_time)
        )?;
    }
    Ok(())
}

/// Writes `world.json` (trees, walls, starts, goal) into `dir`.
pub fn write_world(dir: &Path, world: &TruthWorld) -> Result<()> {
    let path = dir.join("world.json");
    std::fs::write(&path, serde_json::to_string(world)?).with_context(|| format!("cannot write {}", path.display()))
}

/// Writes `connectivity.csv` (the estimate graph's components per tick) into `dir`.
pub fn write_connectivity(dir: &Path, rows: &[ComponentsRow]) -> Result<()> {
    let mut f = create(dir, "connectivity.csv")?;
    writeln!(f, "tick,t_s,reporting,components")?;
    for r in rows {
        writeln!(f, "{},{},{},{}", r.tick, Fixed(r.t_s, 3), r.reporting, r.components)?;
    }
    f.flush()?;
    Ok(())
}

/// Decodes a recorder payload, counting what does not decode.
pub fn decode(bytes: &[u8], malformed: &mut u64) -> Option<Msg> {
    match Msg::decode(bytes) {
        Ok(m) => Some(m),
        Err(e) => {
            *malformed += 1;
            tracing::debug!("recorder dropped a malformed message: {e}");
            None
        }
    }
}
