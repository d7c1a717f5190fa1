//! What one agent process is told at start (`--spec JSON`): the one implementation of the record. The launcher
//! (swarmhost/launcher.py) fills agent/protocol/spec.py's `AgentSpec` and encodes it here through agent._native
//! (`from_value` checks every field, `to_json` writes it); the agent decodes it with `from_json`. Validated
//! once, at the edge: every error names the field. The field checks are in spec/fields.rs, the encoder in
//! spec/encode.rs.

mod encode;
mod fields;

use serde_json::Value;

use crate::keys;
use crate::obstacle::Obstacle;
use crate::radio::Radio;
use crate::robot::Robot;
use crate::sph::{Control, Params};
use fields::{
    err, number, only, parse_control, parse_neighbours, parse_obstacles, parse_params, parse_radio, parse_robot,
    positive, string,
};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    Lockstep,
    Async,
}

#[derive(Clone, Debug)]
pub struct AgentSpec {
    pub run: String,
    pub id: u32,
    pub connect: Vec<String>,
    pub steps: u32,
    pub initial: [f64; 4],
    pub control: Control,
    pub params: Params,
    pub timeout: f64,
    pub start_timeout: f64,
    pub drop_out: f64,
    pub secret: String,
    pub join: bool,
    /// Access level `acl` (the router lets each agent publish only its own keys): states go on `state/<id>`,
    /// the launcher's relay puts them on the cell keys; else on the cell's key (docs/protocol.md,
    /// docs/security.md).
    pub state_key_ids: bool,
    /// The launcher's embedded router hands this agent its neighbours' states in one message per lockstep step
    /// on `inbox/<id>`, after the cells it says it hears on `watch/<id>` (relay/inboxes.rs, watch.rs), instead
    /// of a subscription per cell; under per-process rights and in lockstep only (an async agent ignores it).
    pub inbox: bool,
    pub mode: Mode,
    pub rate: f64,
    pub max_age: f64,
    /// (id, x, y) of the agents the launcher placed near this one: the step-0 neighbours are those whose
    /// initial cell is within R_sub (docs/protocol.md, "Step 0")
    pub neighbours: Vec<(u32, f64, f64)>,
    /// The particle's body and drive (agent/sph/robot.py); a point unless told
    pub robot: Robot,
    /// What this agent's radio and localisation make of the states it receives (agent/sph/radio.py); perfect
    /// unless told
    pub radio: Radio,
    /// The domain's static obstacles (agent/sph/obstacles.py): discs and simple polygons; none unless told
    pub obstacles: Vec<Obstacle>,
}

/// The defaults of the optional fields, written once (agent/protocol/spec.py reads them through agent._native).
pub const DEFAULT_TIMEOUT: f64 = 2.0;
pub const DEFAULT_START_TIMEOUT: f64 = 120.0;
pub const DEFAULT_RATE: f64 = 12.0;
pub const DEFAULT_MAX_AGE: f64 = 1.0;

pub const FIELDS: &[&str] = &[
    "run",
    "id",
    "connect",
    "steps",
    "initial",
    "control",
    "params",
    "timeout",
    "start_timeout",
    "drop_out",
    "secret",
    "join",
    "state_key_ids",
    "inbox",
    "mode",
    "rate",
    "max_age",
    "neighbours",
    "robot",
    "radio",
    "obstacles",
];

impl AgentSpec {
    pub fn from_json(text: &str) -> Result<AgentSpec, String> {
        match serde_json::from_str(text) {
            Ok(v) => AgentSpec::from_value(v),
            Err(e) => err(format!("not JSON ({e})")),
        }
    }

    /// The spec in a parsed JSON value (what `from_json` reads, and what the launcher's fields are before
    /// they are encoded): every field checked.
    pub fn from_value(raw: Value) -> Result<AgentSpec, String> {
        let obj = match raw {
            Value::Object(o) => o,
            _ => return err("must be a JSON object".into()),
        };
        only(&obj, FIELDS, "")?;
        for required in ["run", "id", "connect", "steps", "initial"] {
            if !obj.contains_key(required) {
                return err(format!("missing field {required:?}"));
            }
        }
        let run = match obj.get("run").and_then(|v| v.as_str()) {
            Some(r) if keys::valid_run_name(r) => r.to_string(),
            _ => return err(format!("run {} must be 1-64 letters, digits, '-' or '_'", obj["run"])),
        };
        let id = match obj["id"].as_u64() {
            // Only ids below MAX_AGENTS have a key (keys::id_chunk): a larger one could not publish or be heard.
            Some(i) if i < u64::from(keys::MAX_AGENTS) => i as u32,
            _ => return err(format!("id must be an integer in [0, {}), got {}", keys::MAX_AGENTS, obj["id"])),
        };
        let steps = match obj["steps"].as_u64() {
            Some(s) if s <= u32::MAX as u64 => s as u32,
            _ => return err(format!("steps must be a non-negative integer, got {}", obj["steps"])),
        };
        let initial: Vec<f64> =
            obj["initial"].as_array().map(|a| a.iter().filter_map(number).collect()).unwrap_or_default();
        if initial.len() != 4 || obj["initial"].as_array().map(|a| a.len()) != Some(4) {
            return err(format!("initial must be [x, y, vx, vy] finite numbers, got {}", obj["initial"]));
        }
        let connect: Vec<String> = match obj["connect"].as_array() {
            Some(a) if a.iter().all(|e| e.as_str().is_some_and(|s| !s.is_empty())) => {
                a.iter().map(|e| e.as_str().unwrap_or_default().to_string()).collect()
            }
            _ => return err("connect must be a list of endpoints".into()),
        };
        let mode = match obj.get("mode").map(|m| m.as_str()) {
            None | Some(Some("lockstep")) => Mode::Lockstep,
            Some(Some("async")) => Mode::Async,
            _ => return err(format!("mode must be one of ('lockstep', 'async'), got {}", obj["mode"])),
        };
        let drop_out = match obj.get("drop_out") {
            None => 0.0,
            Some(v) => match number(v) {
                Some(x) if (0.0..1.0).contains(&x) => x,
                _ => return err(format!("drop_out must be in [0, 1), got {v}")),
            },
        };
        let join = match obj.get("join") {
            None => false,
            Some(Value::Bool(b)) => *b,
            Some(v) => return err(format!("join must be true or false, got {v}")),
        };
        let state_key_ids = match obj.get("state_key_ids") {
            None => false,
            Some(Value::Bool(b)) => *b,
            Some(v) => return err(format!("state_key_ids must be true or false, got {v}")),
        };
        let inbox = match obj.get("inbox") {
            None => false,
            Some(Value::Bool(b)) => *b,
            Some(v) => return err(format!("inbox must be true or false, got {v}")),
        };
        if inbox && !state_key_ids {
            return err(
                "inbox: the relay that fills the inboxes runs under per-process rights only (state_key_ids)".into()
            );
        }
        let secret = string(&obj, "secret")?;
        if secret.len() % 2 != 0 || !secret.bytes().all(|b| b.is_ascii_hexdigit()) {
            return err("secret must be hex".into());
        }
        let params = parse_params(obj.get("params"))?;
        let robot = parse_robot(obj.get("robot"), params.v_max)?;
        let radio = parse_radio(obj.get("radio"))?;
        if mode == Mode::Async && !radio.is_perfect() {
            return err("radio: the imperfect radio is modelled in lockstep only (mode async)".into());
        }
        Ok(AgentSpec {
            run,
            id,
            connect,
            steps,
            initial: [initial[0], initial[1], initial[2], initial[3]],
            control: parse_control(obj.get("control"))?,
            params,
            timeout: positive(&obj, "timeout", DEFAULT_TIMEOUT)?,
            start_timeout: positive(&obj, "start_timeout", DEFAULT_START_TIMEOUT)?,
            drop_out,
            secret,
            join,
            state_key_ids,
            inbox,
            mode,
            rate: positive(&obj, "rate", DEFAULT_RATE)?,
            max_age: positive(&obj, "max_age", DEFAULT_MAX_AGE)?,
            neighbours: parse_neighbours(obj.get("neighbours"))?,
            robot,
            radio,
            obstacles: parse_obstacles(obj.get("obstacles"))?,
        })
    }
}

/// Hex to bytes (the run's command secret); the spec check above guarantees even length and hex digits.
pub fn unhex(text: &str) -> Option<Vec<u8>> {
    if !text.len().is_multiple_of(2) {
        return None;
    }
    (0..text.len()).step_by(2).map(|i| u8::from_str_radix(text.get(i..i + 2)?, 16).ok()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"{"run":"r1","id":3,"connect":["tcp/127.0.0.1:7447"],"steps":10,"initial":[1,2,0.5,0],
        "params":{"h":1.0,"domain":[0,10,0,10],"border":"reflect"},"control":{"alpha":0.5}}"#;

    #[test]
    fn parses_a_launcher_spec() {
        let s = AgentSpec::from_json(GOOD).unwrap();
        assert_eq!(s.id, 3);
        assert!(s.params.reflect);
        assert_eq!(s.control.alpha, 0.5);
        assert_eq!(s.mode, Mode::Lockstep);
    }

    #[test]
    fn errors_name_the_field() {
        let bad = GOOD.replace("\"h\":1.0", "\"h\":-1");
        assert!(AgentSpec::from_json(&bad).unwrap_err().contains("params.h"));
        let bad = GOOD.replace("\"id\":3", "\"id\":-3");
        assert!(AgentSpec::from_json(&bad).unwrap_err().contains("id"));
        let bad = GOOD.replace("\"id\":3", "\"id\":8192");
        assert!(AgentSpec::from_json(&bad).unwrap_err().contains("id must be an integer in [0, 8192)"));
        let bad = GOOD.replace("\"steps\":10", "\"steps\":10,\"bogus\":1");
        assert!(AgentSpec::from_json(&bad).unwrap_err().contains("bogus"));
        assert!(AgentSpec::from_json("[").unwrap_err().contains("not JSON"));
        let bad = GOOD.replace("\"steps\":10", "\"steps\":10,\"neighbours\":[[1,2]]");
        assert!(AgentSpec::from_json(&bad).unwrap_err().contains("neighbours"));
        let bad = GOOD.replace("\"steps\":10", "\"steps\":10,\"neighbours\":[[-1,2,3]]");
        assert!(AgentSpec::from_json(&bad).unwrap_err().contains("neighbours"));
        let good = GOOD.replace("\"steps\":10", "\"steps\":10,\"neighbours\":[[4,2.5,3]]");
        assert_eq!(AgentSpec::from_json(&good).unwrap().neighbours, vec![(4, 2.5, 3.0)]);
    }

    #[test]
    fn robot_models() {
        use crate::robot::Kind;
        assert_eq!(AgentSpec::from_json(GOOD).unwrap().robot.kind, Kind::Point);
        let with = |r: &str| GOOD.replace("\"steps\":10", &format!("\"steps\":10,\"robot\":{r}"));
        let s = AgentSpec::from_json(&with(r#"{"kind":"unicycle","radius":0.3}"#)).unwrap();
        assert_eq!((s.robot.kind, s.robot.radius, s.robot.v_max), (Kind::Unicycle, 0.3, 0.86));
        for (bad, names) in [
            (r#"{"kind":"tank"}"#, "robot.kind"),
            (r#"{"kind":"unicycle","radius":-1}"#, "robot.radius"),
            (r#"{"kind":"unicycle","radius":0}"#, "robot.radius"),
            (r#"{"kind":"holonomic","a_max":0}"#, "robot.a_max"),
            (r#"{"kind":"unicycle","v_max":1e400}"#, "out of range"), // serde_json (float_roundtrip) refuses it while parsing
            (r#"{"kind":"unicycle","v_max":5}"#, "robot.v_max"),
            (r#"{"kind":"unicycle","wheels":2}"#, "robot.\"wheels\""),
            ("3", "robot must be an object"),
        ] {
            let e = AgentSpec::from_json(&with(bad)).unwrap_err();
            assert!(e.contains(names), "{bad}: {e}");
        }
    }

    #[test]
    fn radio_settings() {
        assert!(AgentSpec::from_json(GOOD).unwrap().radio.is_perfect());
        let with = |r: &str| GOOD.replace("\"steps\":10", &format!("\"steps\":10,\"radio\":{r}"));
        let s = AgentSpec::from_json(&with(r#"{"loss":0.1,"latency":2,"noise":0.05,"seed":18446744073709551615}"#));
        let r = s.unwrap().radio;
        assert_eq!((r.loss, r.latency, r.noise, r.seed), (0.1, 2, 0.05, u64::MAX));
        for (bad, names) in [
            (r#"{"loss":1}"#, "radio.loss"),
            (r#"{"loss":-0.1}"#, "radio.loss"),
            (r#"{"latency":5}"#, "radio.latency"),
            (r#"{"latency":1.5}"#, "radio.latency"),
            (r#"{"noise":-1}"#, "radio.noise"),
            (r#"{"seed":-1}"#, "radio.seed"),
            (r#"{"jitter":1}"#, "radio.\"jitter\""),
            ("[]", "radio must be an object"),
        ] {
            let e = AgentSpec::from_json(&with(bad)).unwrap_err();
            assert!(e.contains(names), "{bad}: {e}");
        }
        let lossy_async = with(r#"{"loss":0.1}"#).replace("\"steps\":10", "\"steps\":10,\"mode\":\"async\"");
        assert!(AgentSpec::from_json(&lossy_async).unwrap_err().contains("lockstep only"));
    }
}

#[cfg(test)]
mod obstacle_tests {
    use super::*;
    use crate::obstacle::Obstacle;

    const GOOD: &str = r#"{"run":"r1","id":3,"connect":["tcp/127.0.0.1:7447"],"steps":10,"initial":[1,2,0.5,0]}"#;

    fn with(o: &str) -> String {
        GOOD.replace("\"steps\":10", &format!("\"steps\":10,\"obstacles\":{o}"))
    }

    #[test]
    fn obstacles() {
        assert!(AgentSpec::from_json(GOOD).unwrap().obstacles.is_empty());
        let s = AgentSpec::from_json(&with(
            r#"[{"kind":"circle","centre":[4,5],"radius":0.5},{"kind":"polygon","vertices":[[0,0],[1,0],[1,1]]}]"#,
        ))
        .unwrap();
        assert_eq!(
            s.obstacles,
            vec![
                Obstacle::Circle { x: 4.0, y: 5.0, radius: 0.5 },
                Obstacle::Polygon(vec![(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)])
            ]
        );
        for (bad, names) in [
            ("{}", "obstacles must be a list"),
            (r#"[{"kind":"square"}]"#, "obstacles[0].kind"),
            (r#"[{"kind":"circle","centre":[4,5],"radius":0}]"#, "obstacles[0].radius"),
            (r#"[{"kind":"circle","centre":[4],"radius":1}]"#, "obstacles[0].centre"),
            (r#"[{"kind":"circle","radius":1}]"#, "obstacles[0].centre"),
            (r#"[{"kind":"circle","centre":[4,5],"radius":1,"height":2}]"#, "obstacles[0].\"height\""),
            (r#"[{"kind":"polygon","vertices":[[0,0],[1,0]]}]"#, "obstacles[0].vertices"),
            (r#"[{"kind":"polygon","vertices":[[0,0],[1,1],[1,0],[0,1]]}]"#, "intersects itself"),
            (r#"[{"kind":"polygon","vertices":[[0,0],[1,1],[2,2]]}]"#, "no area"),
            (r#"[{"kind":"polygon","vertices":[[0,0],[1,"a"],[2,2]]}]"#, "obstacles[0].vertices"),
        ] {
            let e = AgentSpec::from_json(&with(bad)).unwrap_err();
            assert!(e.contains(names), "{bad}: {e}");
        }
    }
}
