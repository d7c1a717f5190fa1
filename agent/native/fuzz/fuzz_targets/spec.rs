//! The agent's spec (spec.rs, `--spec JSON`), the one implementation the launcher encodes with (through
//! agent._native): an accepted spec holds only values in its documented bounds and re-encodes (spec/encode.rs)
//! to a text that decodes to the same spec, bit for bit; a refusal is one line naming the spec.
#![no_main]

use fluidswarm_agent::keys;
use fluidswarm_agent::spec::{unhex, AgentSpec};
use libfuzzer_sys::fuzz_target;

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match AgentSpec::from_json(text) {
        Ok(s) => {
            assert!(keys::valid_run_name(&s.run) && s.id < keys::MAX_AGENTS);
            assert!(s.connect.iter().all(|c| !c.is_empty()));
            assert!(finite(&s.initial));
            let p = &s.params;
            for v in [p.h, p.mass, p.rho0, p.gamma, p.kappa, p.dt, p.v_max] {
                assert!(v.is_finite() && v > 0.0, "{p:?}");
            }
            for v in [p.beta, p.beta_pi, p.mu, p.drag] {
                assert!(v.is_finite() && v >= 0.0, "{p:?}");
            }
            assert!(finite(&p.domain) && p.domain[0] < p.domain[1] && p.domain[2] < p.domain[3]);
            let c = &s.control;
            assert!(finite(&[c.wx, c.wy, c.r, c.s, c.alpha, c.beta, c.mu, c.push_x, c.push_y]));
            for v in [s.timeout, s.start_timeout, s.rate, s.max_age] {
                assert!(v.is_finite() && v > 0.0);
            }
            assert!((0.0..1.0).contains(&s.drop_out));
            assert!(unhex(&s.secret).is_some());
            for &(id, x, y) in &s.neighbours {
                assert!(id < keys::MAX_AGENTS, "neighbour id {id} has no key (keys: [0, MAX_AGENTS))");
                assert!(x.is_finite() && y.is_finite());
            }
            let again = AgentSpec::from_json(&s.to_json()).expect("the encoder's output decodes");
            assert_eq!(format!("{again:?}"), format!("{s:?}"), "to_json -> from_json changed the spec");
        }
        Err(e) => {
            assert!(e.starts_with("agent spec: "), "{e}");
            assert!(!e.contains('\n'), "not one line: {e:?}");
        }
    }
});
