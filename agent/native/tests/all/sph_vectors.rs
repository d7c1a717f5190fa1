//! The Rust SPH step (sph.rs) against the numpy one, the independent physics oracle of `fluidswarm verify`:
//! tests/vectors/sph_steps.json, one particle and its neighbour rows in, the next state out (made by
//! tests/vectors/make/sph_steps.py from agent.sph.particle.step_particle). The two evaluate the same
//! formulas in the same order; numpy's pairwise sums of a dozen terms against a plain loop differ by
//! rounding, so each field agrees to 1e-12 relative (1e-12 absolute near 0).

use fluidswarm_agent::obstacle::Obstacle;
use fluidswarm_agent::robot::{Kind, Robot};
use fluidswarm_agent::sph::{step_particle, Control, Params, State, NFIELDS};
use serde_json::Value;

fn f(v: &Value, k: &str) -> f64 {
    v[k].as_f64().unwrap_or_else(|| panic!("{k}: not a number"))
}

fn state(v: &Value) -> State {
    let xs: Vec<f64> = v.as_array().expect("a state row").iter().map(|x| x.as_f64().expect("a float")).collect();
    xs.try_into().unwrap_or_else(|xs: Vec<f64>| panic!("a state has {NFIELDS} fields, not {}", xs.len()))
}

fn params(p: &Value) -> Params {
    let d: Vec<f64> = p["domain"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    Params {
        h: f(p, "h"),
        mass: f(p, "mass"),
        rho0: f(p, "rho0"),
        gamma: f(p, "gamma"),
        beta: f(p, "beta"),
        beta_pi: f(p, "beta_pi"),
        mu: f(p, "mu"),
        kappa: f(p, "kappa"),
        dt: f(p, "dt"),
        v_max: f(p, "v_max"),
        drag: f(p, "drag"),
        domain: [d[0], d[1], d[2], d[3]],
        reflect: match p["border"].as_str() {
            Some("reflect") => true,
            Some("freeze") => false,
            other => panic!("border {other:?}"),
        },
    }
}

fn robot(r: &Value) -> Robot {
    Robot {
        kind: match r["kind"].as_str() {
            Some("point") => Kind::Point,
            Some("holonomic") => Kind::Holonomic,
            Some("unicycle") => Kind::Unicycle,
            other => panic!("robot kind {other:?}"),
        },
        radius: f(r, "radius"),
        v_max: f(r, "v_max"),
        a_max: f(r, "a_max"),
        omega_max: f(r, "omega_max"),
        offset: f(r, "offset"),
    }
}

fn control(c: &Value) -> Control {
    Control {
        wx: f(c, "wx"),
        wy: f(c, "wy"),
        r: f(c, "r"),
        s: f(c, "s"),
        alpha: f(c, "alpha"),
        beta: f(c, "beta"),
        mu: f(c, "mu"),
        push_x: f(c, "push_x"),
        push_y: f(c, "push_y"),
    }
}

fn obstacles(list: &Value) -> Vec<Obstacle> {
    let pt = |p: &Value| (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
    let list = list.as_array().map(|a| a.as_slice()).unwrap_or_default();
    list.iter()
        .map(|o| match o["kind"].as_str() {
            Some("circle") => {
                let (x, y) = pt(&o["centre"]);
                Obstacle::Circle { x, y, radius: f(o, "radius") }
            }
            Some("polygon") => Obstacle::Polygon(o["vertices"].as_array().unwrap().iter().map(pt).collect()),
            other => panic!("obstacle kind {other:?}"),
        })
        .collect()
}

#[test]
fn the_step_matches_the_numpy_oracle() {
    let cases = crate::common::load("sph_steps.json");
    let cases = cases.as_array().expect("a list of cases");
    assert!(cases.len() >= 20);
    let mut kinds = std::collections::HashSet::new();
    for case in cases {
        let name = case["name"].as_str().unwrap();
        let neighbours: Vec<State> = case["neighbours"].as_array().unwrap().iter().map(state).collect();
        let robot = robot(&case["robot"]);
        kinds.insert(format!("{:?}", robot.kind));
        let got = step_particle(
            &state(&case["own"]),
            &neighbours,
            &control(&case["control"]),
            &params(&case["params"]),
            &robot,
            &obstacles(&case["obstacles"]),
        );
        let want = state(&case["next"]);
        for k in 0..NFIELDS {
            let tol = 1e-12 * want[k].abs().max(1.0);
            assert!((got[k] - want[k]).abs() <= tol, "{name}: field {k}: rust {} numpy {}", got[k], want[k]);
        }
    }
    assert_eq!(kinds.len(), 3, "every robot kind is stepped: {kinds:?}");
    let among = cases.iter().filter(|c| c["obstacles"].as_array().is_some_and(|a| !a.is_empty())).count();
    assert!(among >= 18, "steps beside obstacles: {among}");
}
