//! The launcher's ctl messages and the agent's events against the shared vectors (tests/vectors/ctl.json,
//! events.json, made from agent/protocol/ctl.py and events.py): the agent decodes every ctl payload as
//! Python does, and encodes each valid event to the JSON Python decodes it to.

use crate::common::{load, unhex};
use fluidswarm_agent::ctl::{self, Ctl};
use fluidswarm_agent::event::{Event, EventKind, Sighting};
use serde_json::{json, Value};

fn as_json(msg: Option<Ctl>) -> Value {
    match msg {
        None => Value::Null,
        Some(Ctl::Start) => json!({"kind": "start"}),
        Some(Ctl::Stop) => json!({"kind": "stop"}),
        Some(Ctl::Clock(step)) => json!({"kind": "clock", "step": step}),
        Some(Ctl::End(step)) => json!({"kind": "end", "step": step}),
        Some(Ctl::Gone(agent)) => json!({"kind": "gone", "agent": agent}),
    }
}

#[test]
fn ctl_payloads_decode_as_in_python() {
    let cases = load("ctl.json");
    let cases = cases.as_array().expect("a list");
    assert!(cases.len() >= 30);
    for case in cases {
        let (name, what) = (&case["name"], case["what"].as_str().unwrap());
        let payload = unhex(case["payload_hex"].as_str().unwrap());
        let got = ctl::decode(Some(what), &payload);
        assert_eq!(as_json(got), case["expect"], "{name}");
        if let Some(msg) = got {
            assert_eq!(ctl::encode(&msg), payload, "{name}: encoded differently");
            assert_eq!(msg.what(), what, "{name}");
        }
        assert_eq!(ctl::decode(None, &payload), None, "{name}: a key that is no exact ctl key");
    }
}

fn u32_of(v: &Value) -> u32 {
    u32::try_from(v.as_u64().unwrap_or_else(|| panic!("not a u32: {v}"))).unwrap()
}

/// The typed event a valid vector stands for, built field by field.
fn event_of(v: &Value) -> Event {
    let kind = match v["event"].as_str().unwrap() {
        "started" => EventKind::Started,
        "fell_behind" => EventKind::FellBehind,
        "rejoined" => EventKind::Rejoined { from_step: u32_of(&v["from_step"]) },
        "command_received" => {
            EventKind::CommandReceived { seconds_since_session_open: v["seconds_since_session_open"].as_f64().unwrap() }
        }
        "neighbour_timeout" => EventKind::NeighbourTimeout {
            neighbours: v["neighbours"].as_array().unwrap().iter().map(u32_of).collect(),
            last_seen: v.get("last_seen").map(|rows| {
                rows.as_array()
                    .unwrap()
                    .iter()
                    .map(|r| Sighting {
                        agent: u32_of(&r[0]),
                        step: r[1].as_i64().unwrap(),
                        distance: r[2].as_f64(),
                        watched: r[3].as_bool().unwrap(),
                    })
                    .collect()
            }),
        },
        other => panic!("unknown event {other}"),
    };
    Event { id: u32_of(&v["id"]), step: u32_of(&v["step"]), kind }
}

#[test]
fn events_encode_to_what_python_decodes() {
    let cases = load("events.json");
    let valid: Vec<&Value> = cases.as_array().unwrap().iter().filter(|c| !c["expect"].is_null()).collect();
    assert!(valid.len() >= 6);
    for case in valid {
        let want = &case["expect"];
        let text = event_of(want).encode();
        let got: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(&got, want, "{}", case["name"]);
    }
}

#[test]
fn an_unknown_distance_is_null() {
    let seen = vec![Sighting { agent: 1, step: -1, distance: None, watched: false }];
    let ev = Event { id: 2, step: 3, kind: EventKind::NeighbourTimeout { neighbours: vec![1], last_seen: Some(seen) } };
    assert_eq!(ev.to_json()["last_seen"], json!([[1, -1, null, false]]));
}

#[test]
fn events_decode_as_the_vectors_say() {
    let cases = load("events.json");
    let cases = cases.as_array().unwrap();
    assert!(cases.iter().filter(|c| c["expect"].is_null()).count() >= 20);
    for case in cases {
        let got = fluidswarm_agent::event::decode(&unhex(case["payload_hex"].as_str().unwrap()));
        let want = &case["expect"];
        match got {
            None => assert!(want.is_null(), "{}: dropped, the vector decodes it", case["name"]),
            Some(ev) => assert_eq!(&ev.to_json(), want, "{}", case["name"]),
        }
    }
}
