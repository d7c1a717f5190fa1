//! What an agent tells the launcher and the recorder as it runs (`event/<id>`, docs/protocol.md "Events"):
//! the same records as agent/protocol/events.py (which decodes and validates them), encoded only here.
//!
//! JSON: {"v": 1, "id": <agent>, "step": <its step>, "event": <kind>, ...the kind's fields}.

use serde_json::{json, Map, Value};

pub const VERSION: u64 = 1;

/// What a lockstep agent knew of a neighbour it timed out on: its last sighting's step (-1: known only from
/// the launcher's placement), its distance then [m] (None: no position yet), whether its cell was watched.
#[derive(Clone, Debug, PartialEq)]
pub struct Sighting {
    pub agent: u32,
    pub step: i64,
    pub distance: Option<f64>,
    pub watched: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub enum EventKind {
    /// passed the start barrier (or joined)
    Started,
    /// its first gesture command, this long after its session opened [s]
    CommandReceived { seconds_since_session_open: f64 },
    /// expected neighbours it stopped waiting for; `last_seen` from a lockstep agent only
    NeighbourTimeout { neighbours: Vec<u32>, last_seen: Option<Vec<Sighting>> },
    /// the swarm went on without it: it leaves (agents before issue 36; today's rejoin instead)
    FellBehind,
    /// it stalled (frozen) while its neighbours went on, and adopted their step; `from_step`: where it stalled
    Rejoined { from_step: u32 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    pub id: u32,
    pub step: u32,
    pub kind: EventKind,
}

impl Event {
    pub fn name(&self) -> &'static str {
        match self.kind {
            EventKind::Started => "started",
            EventKind::CommandReceived { .. } => "command_received",
            EventKind::NeighbourTimeout { .. } => "neighbour_timeout",
            EventKind::FellBehind => "fell_behind",
            EventKind::Rejoined { .. } => "rejoined",
        }
    }

    pub fn to_json(&self) -> Value {
        let mut m = Map::new();
        m.insert("v".into(), json!(VERSION));
        m.insert("id".into(), json!(self.id));
        m.insert("step".into(), json!(self.step));
        m.insert("event".into(), json!(self.name()));
        match &self.kind {
            EventKind::CommandReceived { seconds_since_session_open } => {
                m.insert("seconds_since_session_open".into(), json!(seconds_since_session_open));
            }
            EventKind::NeighbourTimeout { neighbours, last_seen } => {
                m.insert("neighbours".into(), json!(neighbours));
                if let Some(seen) = last_seen {
                    let rows: Vec<Value> = seen
                        .iter()
                        .map(|s| json!([s.agent, s.step, s.distance.filter(|d| d.is_finite()), s.watched]))
                        .collect();
                    m.insert("last_seen".into(), Value::Array(rows));
                }
            }
            EventKind::Rejoined { from_step } => {
                m.insert("from_step".into(), json!(from_step));
            }
            EventKind::Started | EventKind::FellBehind => {}
        }
        Value::Object(m)
    }

    pub fn encode(&self) -> String {
        self.to_json().to_string()
    }
}
