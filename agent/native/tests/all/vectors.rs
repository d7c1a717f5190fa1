//! The Rust codecs against the shared test vectors in tests/vectors/ (made from the Python codecs by
//! tests/vectors/make_vectors.py; tests/test_vectors.py checks Python against the same files).
//!
//! The files are read as serde_json values (floats correctly rounded); floats compare bit for bit.

use crate::common::{load, unhex};
use fluidswarm_agent::command;
use fluidswarm_agent::fill::{edges_cross, inside, nearest_point, Ring};
use fluidswarm_agent::route::{class_counts, class_of, CommandFollower, FillFollower, RouteFollower};
use fluidswarm_agent::sph::Control;
use fluidswarm_agent::wire;
use serde_json::Value;

/// An f64 field: the same bits (so -0.0 differs from 0.0); ints in the files stand for their float.
fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn same_f64(got: f64, want: &Value, what: &str) {
    assert_eq!(got.to_bits(), f(want).to_bits(), "{what}: got {got:?}, want {want}");
}

fn opt_f64(got: Option<f64>, want: &Value, what: &str) {
    match got {
        None => assert!(want.is_null(), "{what}: got None, want {want}"),
        Some(x) => same_f64(x, want, what),
    }
}

fn control_fields(c: &Control) -> [f64; 9] {
    [c.wx, c.wy, c.r, c.s, c.alpha, c.beta, c.mu, c.push_x, c.push_y]
}

fn same_control(c: &Control, want: &Value, what: &str) {
    let want = want.as_array().unwrap();
    assert_eq!(want.len(), 9);
    for (k, (got, w)) in control_fields(c).iter().zip(want).enumerate() {
        same_f64(*got, w, &format!("{what} field {k}"));
    }
}

fn rings(v: &Value) -> Vec<Ring> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|ring| ring.as_array().unwrap().iter().map(|p| (f(&p[0]), f(&p[1]))).collect())
        .collect()
}

fn zones(v: &Value) -> Vec<command::Zone> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|z| {
            let z: Vec<f64> = z.as_array().unwrap().iter().map(f).collect();
            command::Zone { x: z[0], y: z[1], ux: z[2], uy: z[3], a: z[4], b: z[5], beta: z[6], mu: z[7] }
        })
        .collect()
}

fn same_rings(got: &[Ring], want: &Value, what: &str) {
    let want = want.as_array().unwrap();
    assert_eq!(got.len(), want.len(), "{what}: rings");
    for (k, (ring, w)) in got.iter().zip(want).enumerate() {
        let w = w.as_array().unwrap();
        assert_eq!(ring.len(), w.len(), "{what}: ring {k}");
        for (j, (&(x, y), p)) in ring.iter().zip(w).enumerate() {
            same_f64(x, &p[0], &format!("{what} ring {k} vertex {j} x"));
            same_f64(y, &p[1], &format!("{what} ring {k} vertex {j} y"));
        }
    }
}

#[test]
fn state_records() {
    for v in load("state_records.json").as_array().unwrap() {
        let name = v["name"].as_str().unwrap();
        let data = unhex(v["hex"].as_str().unwrap());
        let expect = &v["expect"];
        match wire::decode_state(&data) {
            Err(reason) => assert_eq!(Some(reason), expect["reject"].as_str(), "{name}"),
            Ok(rec) => {
                assert!(expect.get("reject").is_none(), "{name}: accepted, want {expect}");
                assert_eq!(u64::from(rec.id), expect["id"].as_u64().unwrap(), "{name}");
                assert_eq!(u64::from(rec.step), expect["step"].as_u64().unwrap(), "{name}");
                assert_eq!(u64::from(rec.class), expect["class"].as_u64().unwrap(), "{name}");
                let values = expect["values"].as_array().unwrap();
                assert_eq!(values.len(), rec.values.len(), "{name}");
                for (k, (got, want)) in rec.values.iter().zip(values).enumerate() {
                    same_f64(*got, want, &format!("{name} value {k}"));
                }
                assert_eq!(wire::peek_id_step(&data), Some((rec.id, rec.step)), "{name}");
                if data[14..16] == [0, 0] {
                    assert_eq!(wire::encode_state(rec.id, rec.step, &rec.values, rec.class)[..], data[..], "{name}");
                }
            }
        }
    }
}

#[test]
fn commands() {
    let file = load("commands.json");
    let secret = unhex(file["secret_hex"].as_str().unwrap());
    let vectors = file["vectors"].as_array().unwrap();
    assert!(vectors.len() > 100);
    for v in vectors {
        let name = v["name"].as_str().unwrap();
        let expect = &v["expect"];
        match command::decode(&unhex(v["payload_hex"].as_str().unwrap()), &secret) {
            Err(reason) => assert_eq!(Some(reason), expect["reject"].as_str(), "{name}"),
            Ok(cmd) => {
                assert_eq!(expect["accept"], Value::Bool(true), "{name}: accepted, want {expect}");
                assert_eq!(cmd.seq, expect["seq"].as_u64().unwrap(), "{name}");
                assert_eq!(cmd.gesture, expect["gesture"].as_str().unwrap(), "{name}");
                assert_eq!(cmd.n_agents, expect["n_agents"].as_u64().unwrap(), "{name}");
                same_f64(cmd.beta, &expect["beta"], name);
                same_f64(cmd.mu, &expect["mu"], name);
                let classes = expect["classes"].as_array().unwrap();
                assert_eq!(cmd.classes.len(), classes.len(), "{name}");
                for (c, want) in cmd.classes.iter().zip(classes) {
                    assert_eq!(c.name, want[0].as_str().unwrap(), "{name}");
                    same_f64(c.share, &want[1], name);
                    let route = want[2].as_array().unwrap();
                    assert_eq!(c.route.len(), route.len(), "{name}");
                    for (w, want) in c.route.iter().zip(route) {
                        for (k, got) in [w.x, w.y, w.r, w.s, w.alpha].into_iter().enumerate() {
                            same_f64(got, &want[k], &format!("{name} waypoint field {k}"));
                        }
                        opt_f64(w.beta, &want[5], &format!("{name} waypoint beta"));
                        opt_f64(w.mu, &want[6], &format!("{name} waypoint mu"));
                    }
                }
                match (&cmd.fill, expect.get("fill")) {
                    (None, None) => {}
                    (Some(fill), Some(want)) => {
                        same_rings(&fill.rings, &want["rings"], name);
                        same_f64(fill.alpha, &want["alpha"], &format!("{name} fill alpha"));
                        same_f64(fill.s, &want["s"], &format!("{name} fill s"));
                        let want_zones = zones(&want["zones"]);
                        assert_eq!(fill.zones.len(), want_zones.len(), "{name} zones");
                        for (k, (z, w)) in fill.zones.iter().zip(&want_zones).enumerate() {
                            let got = [z.x, z.y, z.ux, z.uy, z.a, z.b, z.beta, z.mu];
                            let want = [w.x, w.y, w.ux, w.uy, w.a, w.b, w.beta, w.mu];
                            for (g, w) in got.iter().zip(want) {
                                assert_eq!(g.to_bits(), w.to_bits(), "{name} zone {k}: {z:?}");
                            }
                        }
                    }
                    (got, want) => panic!("{name}: fill {got:?}, want {want:?}"),
                }
            }
        }
    }
}

#[test]
fn command_follower_sequences() {
    let file = load("command_sequences.json");
    let secret = unhex(file["secret_hex"].as_str().unwrap());
    let static_control =
        Control { wx: 1.0, wy: 2.0, r: 0.5, s: 1.0, alpha: 0.0, beta: 2.0, mu: 0.0, push_x: 0.0, push_y: 0.0 };
    for seq in file["sequences"].as_array().unwrap() {
        let id = seq["agent_id"].as_u64().unwrap() as u32;
        let mut follower = CommandFollower::new(secret.clone(), id, static_control);
        for (k, step) in seq["steps"].as_array().unwrap().iter().enumerate() {
            let what = format!("agent {id} step {k}");
            if let Some(hex) = step.get("offer_hex") {
                let got = follower.offer(&unhex(hex.as_str().unwrap()), 1e9 + k as f64);
                assert_eq!(got, step["expect"].as_str(), "{what}");
                assert_eq!(Value::Bool(follower.has_command()), step["has_command"], "{what}");
            } else {
                let mut state = [0.0; fluidswarm_agent::sph::NFIELDS];
                state[0] = f(&step["control"][0]);
                state[1] = f(&step["control"][1]);
                same_control(&follower.control(&state), &step["expect"], &what);
                assert_eq!(u64::from(follower.particle_class()), step["particle_class"].as_u64().unwrap(), "{what}");
                let mut report = follower.report().to_json();
                let first = report.remove("first_command_at").expect("first_command_at");
                assert_eq!(first.is_null(), report["commands_accepted"] == 0, "{what}");
                assert_eq!(Value::Object(report), step["report"], "{what}");
            }
        }
    }
}

#[test]
fn classes_of_agents() {
    let file = load("route.json");
    for case in file["class_of"].as_array().unwrap() {
        let n = case["n"].as_u64().unwrap();
        let shares: Vec<f64> = case["shares"].as_array().unwrap().iter().map(f).collect();
        let counts: Vec<u64> = case["counts"].as_array().unwrap().iter().map(|c| c.as_u64().unwrap()).collect();
        assert_eq!(class_counts(n, &shares), counts, "n={n} shares={shares:?}");
        for (id, want) in case["ids"].as_array().unwrap().iter().zip(case["classes"].as_array().unwrap()) {
            let id = id.as_u64().unwrap();
            assert_eq!(class_of(id, n, &shares) as u64, want.as_u64().unwrap(), "n={n} id={id}");
        }
    }
}

#[test]
fn route_followers() {
    let file = load("route.json");
    for (k, case) in file["route_follower"].as_array().unwrap().iter().enumerate() {
        let route = case["route"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| command::Waypoint {
                x: f(&w[0]),
                y: f(&w[1]),
                r: f(&w[2]),
                s: f(&w[3]),
                alpha: f(&w[4]),
                beta: w[5].as_f64(),
                mu: w[6].as_f64(),
            })
            .collect();
        let mut follower = RouteFollower::new(route, f(&case["beta"]), f(&case["mu"]), (0.0, 0.0));
        for (j, step) in case["steps"].as_array().unwrap().iter().enumerate() {
            let what = format!("route {k} step {j}");
            let c = follower.control(f(&step["position"][0]), f(&step["position"][1]));
            same_control(&c, &step["control"], &what);
            assert_eq!(follower.index as u64, step["index"].as_u64().unwrap(), "{what}");
        }
    }
}

#[test]
fn fill_followers() {
    let file = load("fill.json");
    let cases = file["followers"].as_array().unwrap();
    assert!(!cases.is_empty());
    for case in cases {
        let name = case["name"].as_str().unwrap();
        let fill = command::Fill {
            rings: rings(&case["rings"]),
            alpha: f(&case["alpha"]),
            s: f(&case["s"]),
            zones: zones(&case["zones"]),
        };
        let follower = FillFollower::new(&fill, f(&case["beta"]), f(&case["mu"]));
        for (j, step) in case["steps"].as_array().unwrap().iter().enumerate() {
            let what = format!("{name} step {j} at {}", step["position"]);
            let (x, y) = (f(&step["position"][0]), f(&step["position"][1]));
            assert_eq!(Value::Bool(inside(&fill.rings, x, y)), step["inside"], "{what}");
            let (px, py) = nearest_point(&fill.rings, x, y);
            same_f64(px, &step["nearest"][0], &what);
            same_f64(py, &step["nearest"][1], &what);
            same_control(&follower.control(x, y), &step["control"], &what);
        }
    }
}

#[test]
fn fill_edges_cross() {
    let file = load("fill.json");
    for (k, case) in file["edges_cross"].as_array().unwrap().iter().enumerate() {
        assert_eq!(Value::Bool(edges_cross(&rings(&case["rings"]))), case["cross"], "case {k}: {}", case["rings"]);
    }
}
