//! The agent's final report (`final/<id>`, docs/protocol.md "Final report"): the record agent/protocol/report.py
//! decodes and validates, typed here and encoded only here (JSON, version 1).

use std::collections::BTreeMap;

use serde_json::{json, Map, Value};

pub const VERSION: u64 = 1;

/// How the agent's run ended (report.py: Status).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// its last step reached
    Done,
    /// told to stop (ctl/stop, a signal)
    Stopped,
    /// the swarm went on without it
    FellBehind,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Status::Done => "done",
            Status::Stopped => "stopped",
            Status::FellBehind => "fell_behind",
        }
    }
}

/// What the agent counted over its run: states received, neighbours used (summed over steps), records refused
/// by reason, neighbours it stopped waiting for, deaths it saw, stale states, its own dropped-out steps, states
/// lost (docs/protocol.md).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Counters {
    pub msgs_received: u64,
    pub neighbours: u64,
    pub rejected: BTreeMap<String, u64>,
    pub timeouts: u64,
    pub deaths_seen: u64,
    pub stale: u64,
    pub dropped_out: u64,
    pub lost: u64,
}

/// The command follower's part (coordinator/control/route.py: CommandFollower.report): commands accepted, the
/// particle's class, the waypoint it heads for and the command it follows (-1: none), the first command's
/// arrival [Unix s].
#[derive(Clone, Debug, PartialEq)]
pub struct Following {
    pub commands_accepted: u64,
    pub particle_class: u16,
    pub waypoint_index: i64,
    pub command_seq: i64,
    pub first_command_at: Option<f64>,
}

impl Following {
    pub fn to_json(&self) -> Map<String, Value> {
        let mut m = Map::new();
        m.insert("commands_accepted".into(), json!(self.commands_accepted));
        m.insert("particle_class".into(), json!(self.particle_class));
        m.insert("waypoint_index".into(), json!(self.waypoint_index));
        m.insert("command_seq".into(), json!(self.command_seq));
        m.insert("first_command_at".into(), json!(self.first_command_at));
        m
    }
}

/// One agent's end: `state` its final row (x, y, vx, vy, rho, p, sxx, sxy, syy, frozen, heading, speed) in SI units; times in
/// Unix seconds (None: never reached); `rss_mb` its peak RSS [MB], `cpu_seconds` its CPU time [s].
#[derive(Clone, Debug, PartialEq)]
pub struct FinalReport {
    pub id: u32,
    pub status: Status,
    pub steps: u32,
    pub state: Vec<f64>,
    pub counters: Counters,
    pub t_start: Option<f64>,
    pub t_end: Option<f64>,
    pub session_opened_at: f64,
    pub rss_mb: f64,
    pub cpu_seconds: f64,
    pub cpu_seconds_at_start: Option<f64>,
    pub following: Option<Following>,
}

impl FinalReport {
    pub fn to_json(&self) -> Value {
        let c = &self.counters;
        let mut m = Map::new();
        m.insert("v".into(), json!(VERSION));
        m.insert("id".into(), json!(self.id));
        m.insert("status".into(), json!(self.status.name()));
        m.insert("steps".into(), json!(self.steps));
        m.insert("state".into(), json!(self.state));
        m.insert("msgs_received".into(), json!(c.msgs_received));
        m.insert("neighbours".into(), json!(c.neighbours));
        m.insert("rejected".into(), json!(c.rejected));
        m.insert("timeouts".into(), json!(c.timeouts));
        m.insert("deaths_seen".into(), json!(c.deaths_seen));
        m.insert("stale".into(), json!(c.stale));
        m.insert("dropped_out".into(), json!(c.dropped_out));
        m.insert("lost".into(), json!(c.lost));
        m.insert("t_start".into(), json!(self.t_start));
        m.insert("t_end".into(), json!(self.t_end));
        m.insert("session_opened_at".into(), json!(self.session_opened_at));
        m.insert("rss_mb".into(), json!(self.rss_mb));
        m.insert("cpu_seconds".into(), json!(self.cpu_seconds));
        m.insert("cpu_seconds_at_start".into(), json!(self.cpu_seconds_at_start));
        m.insert("agent".into(), json!("native"));
        if let Some(f) = &self.following {
            m.extend(f.to_json());
        }
        Value::Object(m)
    }

    pub fn encode(&self) -> String {
        self.to_json().to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_field_is_written_once_with_its_python_name() {
        let mut r = FinalReport {
            id: 7,
            status: Status::FellBehind,
            steps: 12,
            state: vec![0.5; 10],
            counters: Counters { msgs_received: 3, ..Counters::default() },
            t_start: Some(1.0),
            t_end: None,
            session_opened_at: 0.5,
            rss_mb: 9.0,
            cpu_seconds: 0.25,
            cpu_seconds_at_start: None,
            following: None,
        };
        let v: Value = serde_json::from_str(&r.encode()).unwrap();
        assert_eq!((v["v"].as_u64(), v["id"].as_u64(), v["status"].as_str()), (Some(1), Some(7), Some("fell_behind")));
        assert_eq!((v["t_end"].clone(), v["msgs_received"].as_u64()), (Value::Null, Some(3)));
        assert_eq!(v.as_object().unwrap().len(), 20); // "v" and report.py FinalReport's 19 fields but the follower's
        r.following = Some(Following {
            commands_accepted: 2,
            particle_class: 1,
            waypoint_index: 0,
            command_seq: 5,
            first_command_at: Some(2.5),
        });
        let v = r.to_json();
        assert_eq!((v["command_seq"].as_i64(), v["first_command_at"].as_f64()), (Some(5), Some(2.5)));
        assert_eq!(v.as_object().unwrap().len(), 25);
    }
}
