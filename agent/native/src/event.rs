//! What an agent tells the launcher and the recorder as it runs (`event/<id>`, docs/protocol.md "Events"):
//! encoded and decoded (validated) only here; agent/protocol/events.py calls `decode` through agent._native.
//!
//! JSON: {"v": 1, "id": <agent>, "step": <its step>, "event": <kind>, ...the kind's fields}.

use serde_json::{json, Map, Value};

pub const VERSION: u64 = 1;
pub const MAX_BYTES: usize = 64 * 1024;
pub const MAX_AGENT: i64 = (1 << 31) - 1;
pub const MAX_STEP: i64 = u32::MAX as i64;
/// Neighbours in one timeout event: far more than fit in a kernel support.
pub const MAX_LISTED: usize = 4096;
pub const MAX_SECONDS: f64 = 1e9;

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

/// An integer (not a bool, not written as a float) in [lo, hi].
fn integer(v: &Value, lo: i64, hi: i64) -> Option<i64> {
    v.as_i64().filter(|x| (lo..=hi).contains(x))
}

/// A number (int or float, not a bool) in [lo, hi].
fn number(v: &Value, lo: f64, hi: f64) -> Option<f64> {
    v.as_f64().filter(|x| lo <= *x && *x <= hi)
}

fn listed<T>(v: &Value, item: impl Fn(&Value) -> Option<T>) -> Option<Vec<T>> {
    let items = v.as_array().filter(|xs| xs.len() <= MAX_LISTED)?;
    items.iter().map(item).collect()
}

fn sighting(v: &Value) -> Option<Sighting> {
    match v.as_array()?.as_slice() {
        [agent, step, distance, Value::Bool(watched)] => Some(Sighting {
            agent: integer(agent, 0, MAX_AGENT)? as u32,
            step: integer(step, -1, MAX_STEP)?,
            distance: if distance.is_null() { None } else { Some(number(distance, 0.0, MAX_SECONDS)?) },
            watched: *watched,
        }),
        _ => None,
    }
}

/// The event in `data` (JSON in UTF-8), None if anything in it is malformed: another version, an unknown
/// kind or field, a field of another kind, a missing one, a value of the wrong type or out of range.
pub fn decode(data: &[u8]) -> Option<Event> {
    if data.len() > MAX_BYTES {
        return None;
    }
    let msg: Map<String, Value> = serde_json::from_slice(data).ok()?;
    if msg.get("v").and_then(Value::as_u64) != Some(VERSION) {
        return None;
    }
    let (fields, required): (&[&str], &[&str]) = match msg.get("event")?.as_str()? {
        "started" | "fell_behind" => (&[], &[]),
        "command_received" => (&["seconds_since_session_open"], &["seconds_since_session_open"]),
        "neighbour_timeout" => (&["neighbours", "last_seen"], &["neighbours"]),
        "rejoined" => (&["from_step"], &["from_step"]),
        _ => return None,
    };
    let known = |k: &str| ["v", "id", "step", "event"].contains(&k) || fields.contains(&k);
    if !msg.keys().all(|k| known(k)) || !required.iter().all(|k| msg.contains_key(*k)) {
        return None;
    }
    let id = integer(msg.get("id")?, 0, MAX_AGENT)? as u32;
    let step = integer(msg.get("step")?, 0, MAX_STEP)? as u32;
    let kind = match msg["event"].as_str()? {
        "started" => EventKind::Started,
        "fell_behind" => EventKind::FellBehind,
        "command_received" => EventKind::CommandReceived {
            seconds_since_session_open: number(&msg["seconds_since_session_open"], 0.0, MAX_SECONDS)?,
        },
        "rejoined" => EventKind::Rejoined { from_step: integer(&msg["from_step"], 0, MAX_STEP)? as u32 },
        _ => EventKind::NeighbourTimeout {
            neighbours: listed(&msg["neighbours"], |j| integer(j, 0, MAX_AGENT).map(|j| j as u32))?,
            last_seen: msg.get("last_seen").map(|v| listed(v, sighting)).map_or(Some(None), |s| s.map(Some))?,
        },
    };
    Some(Event { id, step, kind })
}
