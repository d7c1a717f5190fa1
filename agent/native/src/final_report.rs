//! The agent's final report (`final/<id>`, docs/protocol.md "Final report"): typed, encoded (by the agent) and
//! decoded and validated (for the launcher and the recorder, through agent._native: agent/protocol/report.py)
//! only here (JSON, version 1).

use std::collections::BTreeMap;

use serde_json::{json, Map, Value};

pub const VERSION: u64 = 1;
/// A report is ~1 kB; anything far larger is not one.
pub const MAX_BYTES: usize = 64 * 1024;
/// Counters are u64 in the agent; the reader takes what fits an i64 (a Python int it can compare and sum).
pub const MAX_COUNT: i64 = i64::MAX;
/// As for state records (wire.rs): larger magnitudes are garbage, not physics.
pub const MAX_ABS: f64 = 1e12;
pub const MAX_ID: i64 = (1 << 31) - 1;
/// Refusal reasons a report may list (one per kind of record refused: far more than there are).
pub const MAX_REASONS: usize = 64;
/// The shortest state row a reader takes: an agent of wire v1 reported x, y, vx, vy, rho, p and the stress.
pub const MIN_STATE: usize = 9;
const MAX_AGENT_NAME: usize = 32;
const MAX_REASON_NAME: usize = 64;

const COUNTS: [&str; 9] = [
    "msgs_received",
    "neighbours",
    "timeouts",
    "deaths_seen",
    "stale",
    "dropped_out",
    "lost",
    "commands_accepted",
    "particle_class",
];
const SIGNED: [&str; 2] = ["waypoint_index", "command_seq"];
const OPTIONAL_TIMES: [&str; 5] = ["t_start", "t_end", "session_opened_at", "cpu_seconds_at_start", "first_command_at"];
const TIMES: [&str; 3] = ["rss_mb", "pss_mb", "cpu_seconds"];

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
    pub fn from_name(name: &str) -> Option<Status> {
        [Status::Done, Status::Stopped, Status::FellBehind].into_iter().find(|s| s.name() == name)
    }

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
/// Unix seconds (None: never reached); `rss_mb` its peak RSS [MB], `pss_mb` its proportional set size at the
/// end [MB] (shared pages, the program's text above all, divided among the processes that map them: what one
/// more agent costs), `cpu_seconds` its CPU time [s].
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
    pub pss_mb: f64,
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
        m.insert("pss_mb".into(), json!(self.pss_mb));
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

fn integer(v: &Value, lo: i64, hi: i64) -> Option<Value> {
    v.as_i64().filter(|x| (lo..=hi).contains(x)).map(Value::from)
}

/// A number (int or float, not a bool) in [lo, hi], as a float.
fn number(v: &Value, lo: f64, hi: f64) -> Option<Value> {
    v.as_f64().filter(|x| lo <= *x && *x <= hi).map(Value::from)
}

fn truncated(s: &str, chars: usize) -> String {
    s.chars().take(chars).collect()
}

/// A received report, validated: the object of report.py's `FinalReport` fields (every one present, those the
/// sender left out at their defaults), or None if any field it carries is malformed. Untrusted input: every
/// kept field is checked (type, range, finiteness, size); fields the reader does not know are ignored
/// (forward compatibility), so an agent may report more than this reader keeps.
pub fn decode(data: &[u8]) -> Option<Map<String, Value>> {
    if data.len() > MAX_BYTES {
        return None;
    }
    let msg: Map<String, Value> = serde_json::from_slice(data).ok()?;
    if msg.get("v").is_some_and(|v| v.as_u64() != Some(VERSION)) {
        return None;
    }
    let state = msg.get("state")?.as_array().filter(|s| (MIN_STATE..=crate::sph::NFIELDS).contains(&s.len()))?;
    let rejected = match msg.get("rejected") {
        None => Map::new(),
        Some(r) => {
            let r = r.as_object().filter(|r| r.len() <= MAX_REASONS)?;
            let mut out = Map::new();
            for (reason, n) in r {
                out.insert(truncated(reason, MAX_REASON_NAME), integer(n, 0, MAX_COUNT)?);
            }
            out
        }
    };
    let agent = match msg.get("agent") {
        None => String::new(),
        Some(a) => truncated(a.as_str()?, MAX_AGENT_NAME),
    };
    let mut out = Map::new();
    out.insert("id".into(), integer(msg.get("id")?, 0, MAX_ID)?);
    out.insert("status".into(), Value::from(Status::from_name(msg.get("status")?.as_str()?)?.name()));
    out.insert("steps".into(), integer(msg.get("steps")?, 0, MAX_COUNT)?);
    let state: Option<Vec<Value>> = state.iter().map(|v| number(v, -MAX_ABS, MAX_ABS)).collect();
    out.insert("state".into(), Value::Array(state?));
    out.insert("rejected".into(), Value::Object(rejected));
    out.insert("agent".into(), Value::from(agent));
    let field = |name: &str, default: Value, check: &dyn Fn(&Value) -> Option<Value>| match msg.get(name) {
        None => Some(default),
        Some(v) => check(v),
    };
    for name in COUNTS {
        out.insert(name.into(), field(name, Value::from(0), &|v| integer(v, 0, MAX_COUNT))?);
    }
    for name in SIGNED {
        out.insert(name.into(), field(name, Value::from(-1), &|v| integer(v, -1, MAX_COUNT))?);
    }
    for name in TIMES {
        out.insert(name.into(), field(name, Value::from(0.0), &|v| number(v, -MAX_ABS, MAX_ABS))?);
    }
    for name in OPTIONAL_TIMES {
        let time = |v: &Value| if v.is_null() { Some(Value::Null) } else { number(v, -MAX_ABS, MAX_ABS) };
        out.insert(name.into(), field(name, Value::Null, &time)?);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report() -> FinalReport {
        FinalReport {
            id: 3,
            status: Status::Done,
            steps: 40,
            state: vec![1.5; crate::sph::NFIELDS],
            counters: Counters { msgs_received: 9, ..Counters::default() },
            t_start: Some(10.0),
            t_end: Some(12.5),
            session_opened_at: 9.0,
            rss_mb: 4.0,
            pss_mb: 1.5,
            cpu_seconds: 0.5,
            cpu_seconds_at_start: None,
            following: None,
        }
    }

    #[test]
    fn what_the_agent_encodes_the_reader_decodes() {
        let r = report();
        let m = decode(r.encode().as_bytes()).expect("an agent's own report");
        assert_eq!((m["id"].as_u64(), m["status"].as_str(), m["steps"].as_u64()), (Some(3), Some("done"), Some(40)));
        assert_eq!((m["msgs_received"].as_u64(), m["command_seq"].as_i64()), (Some(9), Some(-1)));
        assert_eq!((m["t_end"].as_f64(), m["cpu_seconds_at_start"].clone()), (Some(12.5), Value::Null));
        assert_eq!(m.len(), 25); // report.py FinalReport's fields, every one
    }

    #[test]
    fn malformed_fields_are_refused_unknown_ones_ignored() {
        let good = report().to_json();
        let with = |k: &str, v: Value| {
            let mut m = good.as_object().unwrap().clone();
            m.insert(k.into(), v);
            serde_json::to_vec(&Value::Object(m)).unwrap()
        };
        assert!(decode(&with("future_field", json!({"any": [1, 2]}))).is_some());
        for (k, v) in [
            ("v", json!(2)),
            ("id", json!(-1)),
            ("id", json!(1u64 << 31)),
            ("id", json!(true)),
            ("steps", json!(1.0)),
            ("status", json!("lost")),
            ("state", json!(vec![1.0; 8])),
            ("state", json!([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 2e12])),
            ("rejected", json!({"id": -1})),
            ("agent", json!(5)),
            ("timeouts", json!("3")),
            ("waypoint_index", json!(-2)),
            ("t_start", json!("now")),
        ] {
            assert!(decode(&with(k, v.clone())).is_none(), "{k}: {v}");
        }
        assert!(decode(b"[1, 2]").is_none() && decode(b"{").is_none() && decode(&vec![b' '; MAX_BYTES + 1]).is_none());
    }

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
            pss_mb: 1.5,
            cpu_seconds: 0.25,
            cpu_seconds_at_start: None,
            following: None,
        };
        let v: Value = serde_json::from_str(&r.encode()).unwrap();
        assert_eq!((v["v"].as_u64(), v["id"].as_u64(), v["status"].as_str()), (Some(1), Some(7), Some("fell_behind")));
        assert_eq!((v["t_end"].clone(), v["msgs_received"].as_u64()), (Value::Null, Some(3)));
        assert_eq!(v.as_object().unwrap().len(), 21); // "v" and report.py FinalReport's 20 fields but the follower's
        r.following = Some(Following {
            commands_accepted: 2,
            particle_class: 1,
            waypoint_index: 0,
            command_seq: 5,
            first_command_at: Some(2.5),
        });
        let v = r.to_json();
        assert_eq!((v["command_seq"].as_i64(), v["first_command_at"].as_f64()), (Some(5), Some(2.5)));
        assert_eq!(v.as_object().unwrap().len(), 26);
    }
}
