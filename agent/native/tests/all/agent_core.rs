//! The agent's core (agent.rs) driven by the message sequences of tests/vectors/agent_core/*.json, one test
//! per file: a spec and a list of calls, each a time, the inputs handed over at it and the actions expected
//! back (docs/protocol.md, "Failures": every row names its sequence). No session, no process, no clock: each
//! sequence runs in milliseconds.
//!
//! A file: {"about", "spec": fields over the defaults of `spec_of`, "follower"?: true, "calls": [{"t",
//! "in": [...], "out": [...], "step"}]}. Inputs: {"state": {"id", "step", "x", "y", "vx"?, "vy"?},
//! "on_key"?} (a record made with wire::encode_state), {"state_record": name, "on_key"?} (a record of
//! tests/vectors/state_records.json), {"ctl": "start"|"stop"|"clock"|"end"|"gone", "step"|"id"}
//! (ctl::encode on this run's exact key), {"ctl_key", "payload_hex"} (raw), {"command": name} (a payload
//! of tests/vectors/commands.json), {"stop": true} (a signal). Actions are written as `render` writes them;
//! an expected action names only the fields it checks, and a call's "out" lists every action of the call,
//! in order. "step": the core's step after the call.

use std::path::PathBuf;

use crate::common::{load, unhex};
use fluidswarm_agent::agent::{Action, AgentCore, Input};
use fluidswarm_agent::ctl::{self, Ctl};
use fluidswarm_agent::route::CommandFollower;
use fluidswarm_agent::spec::AgentSpec;
use fluidswarm_agent::sph::{self, NFIELDS, X, Y};
use fluidswarm_agent::wire;
use serde_json::{json, Map, Value};

const RUN: &str = "r";
/// The Unix time of t = 0 in every sequence (the reports' times are Unix).
const UNIX0: f64 = 1.0e9;

fn dir() -> PathBuf {
    [env!("CARGO_MANIFEST_DIR"), "..", "..", "tests", "vectors", "agent_core"].iter().collect()
}

/// The spec's defaults (one agent at (5, 5) of a 10 x 10 domain, h = 1, 10 lockstep steps), then the file's.
fn spec_of(fields: &Value) -> AgentSpec {
    let mut spec = json!({
        "run": RUN, "id": 0, "connect": ["tcp/127.0.0.1:7447"], "steps": 10, "initial": [5.0, 5.0, 0.0, 0.0],
        "params": {"h": 1.0, "domain": [0.0, 10.0, 0.0, 10.0], "border": "reflect"},
    });
    for (k, v) in fields.as_object().expect("spec: an object") {
        spec[k] = v.clone();
    }
    AgentSpec::from_json(&spec.to_string()).unwrap_or_else(|e| panic!("spec: {e}"))
}

fn num(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key}: a number in {v}"))
}

fn input_of(v: &Value, spec: &AgentSpec, commands: &Value, records: &Value) -> Input {
    let on_key = v.get("on_key").and_then(Value::as_bool).unwrap_or(true);
    if let Some(s) = v.get("state") {
        let values = sph::initial_state(
            num(s, "x"),
            num(s, "y"),
            s.get("vx").and_then(Value::as_f64).unwrap_or(0.0),
            s.get("vy").and_then(Value::as_f64).unwrap_or(0.0),
            &spec.params,
            &spec.robot,
        );
        let record = wire::encode_state(num(s, "id") as u32, num(s, "step") as u32, &values, 0);
        return Input::State { record: record.to_vec(), on_key };
    }
    if let Some(name) = v.get("state_record") {
        let found = records.as_array().unwrap().iter().find(|r| r["name"] == *name);
        let hex = found.unwrap_or_else(|| panic!("no record {name} in state_records.json"))["hex"].as_str();
        return Input::State { record: unhex(hex.unwrap()), on_key };
    }
    if let Some(what) = v.get("ctl") {
        let msg = match what.as_str().unwrap() {
            "start" => Ctl::Start,
            "stop" => Ctl::Stop,
            "clock" => Ctl::Clock(num(v, "step") as u64),
            "end" => Ctl::End(num(v, "step") as u64),
            "gone" => Ctl::Gone(num(v, "id") as u32),
            other => panic!("ctl {other}"),
        };
        return Input::Ctl { key: format!("fluidswarm/{RUN}/ctl/{}", msg.what()), payload: ctl::encode(&msg) };
    }
    if let Some(key) = v.get("ctl_key") {
        return Input::Ctl { key: key.as_str().unwrap().into(), payload: unhex(v["payload_hex"].as_str().unwrap()) };
    }
    if let Some(name) = v.get("command") {
        let found = commands["vectors"].as_array().unwrap().iter().find(|c| c["name"] == *name);
        let payload = found.unwrap_or_else(|| panic!("no command {name} in commands.json"))["payload_hex"].as_str();
        return Input::Command(unhex(payload.unwrap()));
    }
    if v.get("stop") == Some(&Value::Bool(true)) {
        return Input::Stop;
    }
    panic!("not an input: {v}")
}

/// An action as the files write it.
fn render(action: &Action) -> Value {
    match action {
        Action::Subscribe(c) => json!({"subscribe": [c.0, c.1]}),
        Action::Unsubscribe(c) => json!({"unsubscribe": [c.0, c.1]}),
        Action::Publish { cell, record } => {
            let rec = wire::decode_state(record).expect("a published record decodes");
            json!({"publish": rec.step, "cell": [cell.0, cell.1], "x": rec.values[X], "y": rec.values[Y]})
        }
        Action::DeclareAlive => json!({"alive": true}),
        Action::Event(e) => {
            let mut m = e.to_json().as_object().unwrap().clone();
            m.remove("v");
            m.remove("id");
            Value::Object(m)
        }
        Action::Report(r) => {
            let full = r.to_json();
            let mut m = Map::new();
            m.insert("report".into(), full["status"].clone());
            for k in ["steps", "msgs_received", "rejected", "timeouts", "deaths_seen", "stale", "lost", "dropped_out"] {
                m.insert(k.into(), full[k].clone());
            }
            m.insert("t_start".into(), full["t_start"].clone());
            m.insert("t_end".into(), full["t_end"].clone());
            Value::Object(m)
        }
        Action::Sleep { until, wake } => json!({"sleep": until, "awaited": wake.awaited, "await_step": wake.step,
            "on_state": wake.on_state, "on_clock": wake.on_clock}),
        Action::Exit(code) => json!({"exit": code}),
    }
}

/// Subscriptions come by the dozen: a call's run of them is written as one {"subscribe": n} (or
/// "unsubscribe"), the cells being keys::covering_cells' (tested in keys.rs).
fn collapse(actions: Vec<Value>) -> Vec<Value> {
    let mut out: Vec<Value> = Vec::new();
    for a in actions {
        let kind = ["subscribe", "unsubscribe"].into_iter().find(|k| a.get(*k).is_some());
        if let Some(k) = kind {
            if let Some(n) = out.last_mut().and_then(|l| l.get_mut(k)).filter(|n| n.is_u64()) {
                *n = json!(n.as_u64().unwrap() + 1);
                continue;
            }
            out.push(json!({k: 1}));
            continue;
        }
        out.push(a);
    }
    out
}

fn same(got: &Value, want: &Value) -> bool {
    match (got, want) {
        (Value::Number(g), Value::Number(w)) => (g.as_f64().unwrap() - w.as_f64().unwrap()).abs() <= 1e-9,
        (Value::Array(g), Value::Array(w)) => g.len() == w.len() && g.iter().zip(w).all(|(g, w)| same(g, w)),
        (Value::Object(g), Value::Object(w)) => {
            g.len() == w.len() && w.iter().all(|(k, w)| g.get(k).is_some_and(|g| same(g, w)))
        }
        _ => got == want,
    }
}

/// The expected action's fields, each as the rendered action has it.
fn matches(got: &Value, want: &Value) -> bool {
    want.as_object().unwrap().iter().all(|(k, w)| got.get(k).is_some_and(|g| same(g, w)))
}

fn run_sequence(name: &str, commands: &Value, records: &Value) {
    let file = load(&format!("agent_core/{name}"));
    let spec = spec_of(&file["spec"]);
    let follower = file.get("follower").and_then(Value::as_bool).unwrap_or(false);
    let controller = follower.then(|| {
        let secret = unhex(commands["secret_hex"].as_str().unwrap());
        CommandFollower::new(secret, spec.id, spec.control)
    });
    let mut core = AgentCore::new(spec.clone(), controller, 0.0, UNIX0);
    for (k, call) in file["calls"].as_array().expect("calls").iter().enumerate() {
        let t = num(call, "t");
        let inputs: Vec<Input> = call
            .get("in")
            .and_then(Value::as_array)
            .map(|a| a.iter().map(|v| input_of(v, &spec, commands, records)).collect())
            .unwrap_or_default();
        let got = collapse(core.handle(t, inputs).iter().map(render).collect());
        let at = format!("{name}, call {k} (t = {t})");
        if let Some(want) = call.get("out").and_then(Value::as_array) {
            let ok = got.len() == want.len() && got.iter().zip(want).all(|(g, w)| matches(g, w));
            assert!(ok, "{at}:\n  got  {}\n  want {}", Value::Array(got.clone()), Value::Array(want.clone()));
        }
        if let Some(step) = call.get("step") {
            assert_eq!(u64::from(core.step()), step.as_u64().unwrap(), "{at}: the step");
        }
        assert!(core.state()[..NFIELDS].iter().all(|v| v.is_finite()), "{at}: a state that is not finite");
    }
}

/// One test per sequence file, each named for it.
macro_rules! sequences {
    ($($name:ident),* $(,)?) => {
        $(
            #[test]
            fn $name() {
                run_sequence(concat!(stringify!($name), ".json"), &load("commands.json"), &load("state_records.json"));
            }
        )*
        const LISTED: &[&str] = &[$(concat!(stringify!($name), ".json")),*];
    };
}

sequences!(
    async_mode,
    catch_up_after_short_freeze,
    command_before_start,
    ctl_messages,
    falling_behind,
    frozen_neighbour,
    hostile_states,
    late_joiner,
    late_joiner_alone,
    lockstep_expected_set,
    lost_neighbour,
    no_command,
    no_start,
    pacing,
    radio_lost_state,
    rejoin_after_freeze,
    stop_signal,
    the_end,
    the_end_after_the_spec,
);

/// Every file of tests/vectors/agent_core is one of the tests above.
#[test]
fn every_sequence_file_is_a_test() {
    let mut names: Vec<String> = std::fs::read_dir(dir())
        .expect("tests/vectors/agent_core")
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".json"))
        .collect();
    names.sort();
    assert_eq!(names, LISTED, "add the new file to sequences!()");
}
/// Every row of docs/protocol.md's failure table names a sequence file that exists.
#[test]
fn the_failure_table_names_existing_sequences() {
    let doc: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", "docs", "protocol.md"].iter().collect();
    let text = std::fs::read_to_string(doc).unwrap();
    let table: Vec<&str> = text
        .split("## Failures")
        .nth(1)
        .unwrap()
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .collect();
    assert!(table.len() >= 10, "rows: {table:?}");
    for row in table {
        let cell = row.trim_end_matches('|').rsplit('|').next().unwrap().trim();
        let names: Vec<&str> = cell.split(['`', ',', ' ']).filter(|n| n.ends_with(".json")).collect();
        assert!(!names.is_empty(), "no sequence named in: {row}");
        for n in names {
            assert!(dir().join(n).is_file(), "{n} (named in the failure table) is not in tests/vectors/agent_core");
        }
    }
}
