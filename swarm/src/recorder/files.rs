//! The files of a run folder that grow while the run goes (`trajectories.csv`,
//! `agent_states.csv`), and the recorder's decoding of what it receives.

use anyhow::{Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use swarm_wire::{AgentState, Msg, TruthStep};

/// The files of a run folder that grow while the run goes.
pub struct Files {
    traj: BufWriter<File>,
    states: BufWriter<File>,
}

impl Files {
    /// Creates `trajectories.csv` and `agent_states.csv` in `dir`, with headers.
    pub fn create(dir: &Path) -> Result<Files> {
        let open = |name: &str| -> Result<BufWriter<File>> {
            let p = dir.join(name);
            Ok(BufWriter::new(File::create(&p).with_context(|| format!("cannot create {}", p.display()))?))
        };
        let mut traj = open("trajectories.csv")?;
        writeln!(traj, "tick,t_s,id,x_m,y_m,yaw_rad,vx_mps,vy_mps,obstacle_distance_m,agent_distance_m,colliding,alive,cmd_on_time")?;
        let mut states = open("agent_states.csv")?;
        writeln!(states, "tick,t_s,id,step_time_us,obstacles,neighbours,in_radio_range,cohesion,separation,avoidance,navigation,output_mps,msgs_tx,bytes_tx,msgs_rx,bytes_rx,icp_short,icp_long,icp_initial,icp_deferred,db_entries,db_suspended")?;
        Ok(Files { traj, states })
    }

    /// Appends one step's rows.
    pub fn write_step(&mut self, s: &TruthStep) -> Result<()> {
        for b in &s.bodies {
            writeln!(
                self.traj,
                "{},{:.3},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{}",
                s.tick, s.t_secs, b.id, b.x, b.y, b.yaw, b.vx, b.vy, b.obstacle_distance_m, b.agent_distance_m,
                u8::from(b.colliding), u8::from(b.alive), u8::from(b.cmd_on_time)
            )?;
        }
        Ok(())
    }

    /// Appends one agent state row.
    pub fn write_state(&mut self, st: &AgentState) -> Result<()> {
        let v = &st.vectors;
        let l = &st.link;
        let c = &st.icp;
        writeln!(
            self.states,
            "{},{:.3},{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{},{},{},{},{},{},{}",
            st.tick, st.t_secs, st.id, st.step_time_us, st.obstacles, st.neighbours.len(), st.in_radio_range,
            v.cohesion, v.separation, v.avoidance, v.navigation, v.output, l.sent_msgs, l.sent_bytes, l.recv_msgs, l.recv_bytes,
            c.short, c.long, c.initial, c.deferred, c.entries, c.suspended
        )?;
        Ok(())
    }

    /// Flushes both files.
    pub fn flush(&mut self) -> Result<()> {
        self.traj.flush()?;
        self.states.flush()?;
        Ok(())
    }
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
