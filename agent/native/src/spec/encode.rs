//! The spec's one encoder: what `AgentSpec::from_json` reads back to the same spec (floats written shortest
//! round-trip by serde_json, read correctly rounded: `float_roundtrip`). A point robot with the default body,
//! a perfect radio and an empty list of obstacles are left out, so a run without them has the spec it had before robots and radios
//! (an older agent binary reads it: the side-by-side benchmarks run one).

use serde_json::{json, Map, Value};

use super::{AgentSpec, Mode};
use crate::obstacle::Obstacle;
use crate::radio::Radio;
use crate::robot::{Kind, Robot};
use crate::sph::{Control, Params};

impl AgentSpec {
    pub fn to_value(&self) -> Value {
        let mut obj = Map::new();
        obj.insert("run".into(), json!(self.run));
        obj.insert("id".into(), json!(self.id));
        obj.insert("connect".into(), json!(self.connect));
        obj.insert("steps".into(), json!(self.steps));
        obj.insert("initial".into(), json!(self.initial));
        obj.insert("control".into(), control(&self.control));
        obj.insert("params".into(), params(&self.params));
        obj.insert("timeout".into(), json!(self.timeout));
        obj.insert("start_timeout".into(), json!(self.start_timeout));
        obj.insert("drop_out".into(), json!(self.drop_out));
        obj.insert("secret".into(), json!(self.secret));
        obj.insert("join".into(), json!(self.join));
        obj.insert("state_key_ids".into(), json!(self.state_key_ids));
        if self.inbox {
            obj.insert("inbox".into(), json!(true)); // left out when false: an older agent reads the spec
        }
        let mode = match self.mode {
            Mode::Lockstep => "lockstep",
            Mode::Async => "async",
        };
        obj.insert("mode".into(), json!(mode));
        obj.insert("rate".into(), json!(self.rate));
        obj.insert("max_age".into(), json!(self.max_age));
        let neighbours: Vec<Value> = self.neighbours.iter().map(|&(id, x, y)| json!([id, x, y])).collect();
        obj.insert("neighbours".into(), Value::Array(neighbours));
        let body = if self.robot == Robot::default() { json!({}) } else { robot(&self.robot) };
        obj.insert("robot".into(), body);
        if !self.radio.is_perfect() {
            obj.insert("radio".into(), radio(&self.radio));
        }
        if !self.obstacles.is_empty() {
            obj.insert("obstacles".into(), Value::Array(self.obstacles.iter().map(obstacle).collect()));
        }
        Value::Object(obj)
    }

    pub fn to_json(&self) -> String {
        self.to_value().to_string()
    }
}

fn control(c: &Control) -> Value {
    json!({"wx": c.wx, "wy": c.wy, "r": c.r, "s": c.s, "alpha": c.alpha, "beta": c.beta, "mu": c.mu,
           "push_x": c.push_x, "push_y": c.push_y})
}

fn params(p: &Params) -> Value {
    json!({"h": p.h, "mass": p.mass, "rho0": p.rho0, "gamma": p.gamma, "beta": p.beta, "beta_pi": p.beta_pi,
           "mu": p.mu, "kappa": p.kappa, "dt": p.dt, "v_max": p.v_max, "drag": p.drag, "domain": p.domain,
           "border": if p.reflect { "reflect" } else { "freeze" }})
}

fn robot(r: &Robot) -> Value {
    let kind = match r.kind {
        Kind::Point => "point",
        Kind::Holonomic => "holonomic",
        Kind::Unicycle => "unicycle",
    };
    json!({"kind": kind, "radius": r.radius, "v_max": r.v_max, "a_max": r.a_max, "omega_max": r.omega_max,
           "offset": r.offset})
}

fn obstacle(o: &Obstacle) -> Value {
    match o {
        Obstacle::Circle { x, y, radius } => json!({"kind": "circle", "centre": [x, y], "radius": radius}),
        Obstacle::Polygon(vertices) => {
            let points: Vec<Value> = vertices.iter().map(|&(x, y)| json!([x, y])).collect();
            json!({"kind": "polygon", "vertices": points})
        }
    }
}

fn radio(r: &Radio) -> Value {
    json!({"loss": r.loss, "latency": r.latency, "noise": r.noise, "seed": r.seed})
}

#[cfg(test)]
mod tests {
    use super::super::fields::{CONTROL_FIELDS, PARAM_FIELDS, RADIO_FIELDS, ROBOT_FIELDS};
    use super::super::FIELDS;
    use super::*;

    const FULL: &str = r#"{"run":"r1","id":3,"connect":["tcp/127.0.0.1:7447"],"steps":10,
        "initial":[1,2.000000000000001,0.5,-0.1],"params":{"h":0.7,"domain":[0,10,0,10],"border":"reflect"},
        "control":{"alpha":0.5,"wx":1e-300},"timeout":5,"join":true,"secret":"ab01","neighbours":[[4,2.5,3]],
        "state_key_ids":true,"inbox":true,
        "robot":{"kind":"unicycle","radius":0.3},"radio":{"loss":0.1,"latency":2,"noise":0.05,"seed":7},
        "obstacles":[{"kind":"circle","centre":[5,5],"radius":0.5},{"kind":"polygon","vertices":[[1,1],[2,1],[2,2]]}]}"#;

    #[test]
    fn encodes_what_it_decodes() {
        for text in [FULL, r#"{"run":"r","id":0,"connect":["tcp/h:1"],"steps":0,"initial":[0,0,0,0]}"#] {
            let spec = AgentSpec::from_json(text).unwrap();
            let again = AgentSpec::from_json(&spec.to_json()).unwrap();
            assert_eq!(again.to_json(), spec.to_json());
            assert_eq!(format!("{again:?}"), format!("{spec:?}"), "every field, bit for bit");
        }
    }

    #[test]
    fn writes_every_field_of_each_table() {
        let v = AgentSpec::from_json(FULL).unwrap().to_value();
        let names = |v: &Value| -> Vec<String> {
            let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
            k.sort();
            k
        };
        let sorted = |f: &[&str]| -> Vec<String> {
            let mut k: Vec<String> = f.iter().map(|s| s.to_string()).collect();
            k.sort();
            k
        };
        assert_eq!(names(&v), sorted(FIELDS));
        assert_eq!(names(&v["params"]), sorted(PARAM_FIELDS));
        assert_eq!(names(&v["control"]), sorted(CONTROL_FIELDS));
        assert_eq!(names(&v["robot"]), sorted(ROBOT_FIELDS));
        assert_eq!(names(&v["radio"]), sorted(RADIO_FIELDS));
    }

    #[test]
    fn leaves_out_the_default_robot_and_a_perfect_radio() {
        let plain = r#"{"run":"r","id":0,"connect":["tcp/h:1"],"steps":0,"initial":[0,0,0,0]}"#;
        let v = AgentSpec::from_json(plain).unwrap().to_value();
        assert_eq!(v["robot"], json!({}));
        assert!(v.get("radio").is_none() && v.get("obstacles").is_none());
    }
}
