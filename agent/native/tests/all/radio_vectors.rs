//! The imperfect radio's draws (radio.rs) against agent/sph/radio.py, the oracle the reference driver uses:
//! tests/vectors/radio.json (made by tests/vectors/make/radio.py). The uniforms and the losses are integer
//! arithmetic and must be equal; the position errors go through ln, sqrt, cos and sin of the platform's libm on
//! both sides and must be equal to 1e-15 m.

use fluidswarm_agent::radio::{uniform, Radio};
use serde_json::Value;

fn u(v: &Value, k: &str) -> u64 {
    v[k].as_u64().unwrap_or_else(|| panic!("{k}: not an unsigned integer in {v}"))
}

fn f(v: &Value, k: &str) -> f64 {
    v[k].as_f64().unwrap_or_else(|| panic!("{k}: not a number in {v}"))
}

#[test]
fn uniforms_match_the_oracle() {
    let file = crate::common::load("radio.json");
    let cases = file["uniforms"].as_array().expect("uniforms");
    assert!(cases.len() > 30);
    for c in cases {
        let got = uniform(u(c, "seed"), u(c, "stream"), u(c, "a"), u(c, "b"), u(c, "step"));
        assert_eq!(got, f(c, "u"), "{c}");
    }
}

#[test]
fn losses_and_position_errors_match_the_oracle() {
    let file = crate::common::load("radio.json");
    let mut lost = 0;
    for setting in file["radios"].as_array().expect("radios") {
        let r = &setting["radio"];
        let radio =
            Radio { loss: f(r, "loss"), latency: u(r, "latency") as u32, noise: f(r, "noise"), seed: u(r, "seed") };
        for d in setting["draws"].as_array().expect("draws") {
            let (i, j, s) = (u(d, "receiver") as u32, u(d, "sender") as u32, u(d, "step") as u32);
            assert_eq!(radio.lost(i, j, s), d["lost"].as_bool().expect("lost"), "{d}");
            lost += usize::from(radio.lost(i, j, s));
            let (ex, ey) = radio.position_error(j, s);
            let want = d["error"].as_array().expect("error");
            let (wx, wy) = (want[0].as_f64().unwrap(), want[1].as_f64().unwrap());
            assert!((ex - wx).abs() <= 1e-15 && (ey - wy).abs() <= 1e-15, "{d}: ({ex}, {ey})");
        }
    }
    assert!(lost > 0, "the vectors include lost states");
}
