//! The agent's spec (spec.rs, `--spec JSON`): an accepted spec holds only what agent/protocol/spec.py's
//! `validate` allows (so the agent never runs on a value the launcher could not have written); a refusal is
//! one line naming the spec.
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
                assert!(id < keys::MAX_AGENTS, "neighbour id {id} has no key (spec.py: [0, MAX_AGENTS))");
                assert!(x.is_finite() && y.is_finite());
            }
        }
        Err(e) => {
            assert!(e.starts_with("agent spec: "), "{e}");
            assert!(!e.contains('\n'), "not one line: {e:?}");
        }
    }
});
