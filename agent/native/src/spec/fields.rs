//! The spec's field checks: each names the field and the problem in one line ("agent spec: params.h ...").

use serde_json::{Map, Value};

use crate::fill;
use crate::keys;
use crate::obstacle::{Obstacle, MAX_VERTICES};
use crate::radio::{Radio, MAX_LATENCY};
use crate::robot::{Kind, Robot};
use crate::sph::{Control, Params};

pub(super) const PARAM_FIELDS: &[&str] =
    &["h", "mass", "rho0", "gamma", "beta", "beta_pi", "mu", "kappa", "dt", "v_max", "drag", "domain", "border"];
pub(super) const CONTROL_FIELDS: &[&str] = &["wx", "wy", "r", "s", "alpha", "beta", "mu", "push_x", "push_y"];
pub(super) const ROBOT_FIELDS: &[&str] = &["kind", "radius", "v_max", "a_max", "omega_max", "offset"];
pub(super) const RADIO_FIELDS: &[&str] = &["loss", "latency", "noise", "seed"];

pub(super) fn err<T>(msg: String) -> Result<T, String> {
    Err(format!("agent spec: {msg}"))
}

/// A JSON number (not a bool: serde_json keeps them apart), finite.
pub(super) fn number(v: &Value) -> Option<f64> {
    v.as_f64().filter(|x| x.is_finite())
}

pub(super) fn only(obj: &Map<String, Value>, allowed: &[&str], prefix: &str) -> Result<(), String> {
    let mut unknown: Vec<&String> = obj.keys().filter(|k| !allowed.contains(&k.as_str())).collect();
    unknown.sort();
    match unknown.first() {
        Some(k) => err(format!("unknown field {prefix}{k:?}")),
        None => Ok(()),
    }
}

pub(super) fn positive(obj: &Map<String, Value>, name: &str, default: f64) -> Result<f64, String> {
    match obj.get(name) {
        None => Ok(default),
        Some(v) => match number(v) {
            Some(x) if x > 0.0 => Ok(x),
            _ => err(format!("{name} must be > 0, got {v}")),
        },
    }
}

pub(super) fn string(obj: &Map<String, Value>, name: &str) -> Result<String, String> {
    match obj.get(name) {
        None => Ok(String::new()),
        Some(Value::String(s)) => Ok(s.clone()),
        Some(v) => err(format!("{name} must be a string, got {v}")),
    }
}

/// `neighbours`: a list of [id, x, y] (id an integer in [0, MAX_AGENTS): only those ids have a key; x and y
/// finite numbers).
pub(super) fn parse_neighbours(v: Option<&Value>) -> Result<Vec<(u32, f64, f64)>, String> {
    let Some(v) = v else { return Ok(Vec::new()) };
    let Some(rows) = v.as_array() else { return err(format!("neighbours must be a list of [id, x, y], got {v}")) };
    rows.iter()
        .map(|row| match row.as_array().map(|a| a.as_slice()) {
            Some([id, x, y]) => match (id.as_u64(), number(x), number(y)) {
                (Some(i), Some(x), Some(y)) if i < u64::from(keys::MAX_AGENTS) => Ok((i as u32, x, y)),
                _ => err(format!(
                    "neighbours entry must be [id, x, y] with an id in [0, {}) and finite x, y, got {row}",
                    keys::MAX_AGENTS
                )),
            },
            _ => err(format!("neighbours entry must be [id, x, y], got {row}")),
        })
        .collect()
}

pub(super) fn parse_params(v: Option<&Value>) -> Result<Params, String> {
    let mut p = Params::default();
    let obj = match v {
        None => return Ok(p),
        Some(Value::Object(o)) => o,
        Some(other) => return err(format!("params must be an object, got {other}")),
    };
    only(obj, PARAM_FIELDS, "params.")?;
    let positive_names = ["h", "mass", "rho0", "gamma", "kappa", "dt", "v_max"];
    for (name, value) in obj {
        let slot = match name.as_str() {
            "h" => &mut p.h,
            "mass" => &mut p.mass,
            "rho0" => &mut p.rho0,
            "gamma" => &mut p.gamma,
            "beta" => &mut p.beta,
            "beta_pi" => &mut p.beta_pi,
            "mu" => &mut p.mu,
            "kappa" => &mut p.kappa,
            "dt" => &mut p.dt,
            "v_max" => &mut p.v_max,
            "drag" => &mut p.drag,
            _ => continue,
        };
        let x = match number(value) {
            Some(x) => x,
            None => return err(format!("params.{name} must be a finite number, got {value}")),
        };
        if positive_names.contains(&name.as_str()) && x <= 0.0 {
            return err(format!("params.{name} must be > 0, got {value}"));
        }
        if x < 0.0 {
            return err(format!("params.{name} must be >= 0, got {value}"));
        }
        *slot = x;
    }
    if let Some(d) = obj.get("domain") {
        let values: Option<Vec<f64>> = d.as_array().map(|a| a.iter().filter_map(number).collect());
        match values {
            Some(v) if v.len() == 4 && d.as_array().map(|a| a.len()) == Some(4) && v[0] < v[1] && v[2] < v[3] => {
                p.domain = [v[0], v[1], v[2], v[3]]
            }
            _ => {
                return err(format!(
                    "params.domain must be [xmin, xmax, ymin, ymax] with xmin < xmax, ymin < ymax, got {d}"
                ))
            }
        }
    }
    if let Some(b) = obj.get("border") {
        p.reflect = match b.as_str() {
            Some("reflect") => true,
            Some("freeze") => false,
            _ => return err(format!("params.border must be \"freeze\" or \"reflect\", got {b}")),
        };
    }
    Ok(p)
}

pub(super) fn parse_control(v: Option<&Value>) -> Result<Control, String> {
    let mut c = Control::default();
    let obj = match v {
        None => return Ok(c),
        Some(Value::Object(o)) => o,
        Some(other) => return err(format!("control must be an object, got {other}")),
    };
    only(obj, CONTROL_FIELDS, "control.")?;
    for (name, value) in obj {
        let x = match number(value) {
            Some(x) => x,
            None => return err(format!("control.{name} must be a finite number, got {value}")),
        };
        match name.as_str() {
            "wx" => c.wx = x,
            "wy" => c.wy = x,
            "r" => c.r = x,
            "s" => c.s = x,
            "alpha" => c.alpha = x,
            "beta" => c.beta = x,
            "mu" => c.mu = x,
            "push_x" => c.push_x = x,
            "push_y" => c.push_y = x,
            _ => {}
        }
    }
    Ok(c)
}

/// `robot` (agent/sph/robot.py: RobotModel and its checks): kind point | holonomic | unicycle, a radius >= 0
/// (> 0 for a robot), positive finite limits, no faster than the fluid's `v_max` (the neighbour protocol's bound).
pub(super) fn parse_robot(v: Option<&Value>, fluid_v_max: f64) -> Result<Robot, String> {
    let mut r = Robot::default();
    let obj = match v {
        None => return Ok(r),
        Some(Value::Object(o)) => o,
        Some(other) => return err(format!("robot must be an object, got {other}")),
    };
    only(obj, ROBOT_FIELDS, "robot.")?;
    for (name, value) in obj {
        if name == "kind" {
            r.kind = match value.as_str() {
                Some("point") => Kind::Point,
                Some("holonomic") => Kind::Holonomic,
                Some("unicycle") => Kind::Unicycle,
                _ => return err(format!("robot.kind must be one of ('point', 'holonomic', 'unicycle'), got {value}")),
            };
            continue;
        }
        let x = match number(value) {
            Some(x) if x > 0.0 || (name == "radius" && x >= 0.0) => x,
            _ => return err(format!("robot.{name} must be a finite number > 0, got {value}")),
        };
        match name.as_str() {
            "radius" => r.radius = x,
            "v_max" => r.v_max = x,
            "a_max" => r.a_max = x,
            "omega_max" => r.omega_max = x,
            "offset" => r.offset = x,
            _ => {}
        }
    }
    if r.kind != Kind::Point && r.radius <= 0.0 {
        return err(format!("robot.radius must be > 0 for a {:?} robot, got {}", r.kind, r.radius));
    }
    if r.kind != Kind::Point && r.top_particle_speed() > fluid_v_max {
        return err(format!(
            "robot.v_max: the robot's point can move {} m/s, more than the fluid's v_max {fluid_v_max} m/s",
            r.top_particle_speed()
        ));
    }
    Ok(r)
}

/// `radio` (agent/sph/radio.py: RadioModel and its checks): loss in [0, 1), latency an integer in
/// [0, MAX_LATENCY], noise finite >= 0, seed an unsigned 64-bit integer.
pub(super) fn parse_radio(v: Option<&Value>) -> Result<Radio, String> {
    let mut r = Radio::default();
    let obj = match v {
        None => return Ok(r),
        Some(Value::Object(o)) => o,
        Some(other) => return err(format!("radio must be an object, got {other}")),
    };
    only(obj, RADIO_FIELDS, "radio.")?;
    if let Some(v) = obj.get("loss") {
        r.loss = match number(v) {
            Some(x) if (0.0..1.0).contains(&x) => x,
            _ => return err(format!("radio.loss must be a probability in [0, 1), got {v}")),
        };
    }
    if let Some(v) = obj.get("latency") {
        r.latency = match v.as_u64() {
            Some(k) if k <= u64::from(MAX_LATENCY) => k as u32,
            _ => return err(format!("radio.latency must be an integer in [0, {MAX_LATENCY}], got {v}")),
        };
    }
    if let Some(v) = obj.get("noise") {
        r.noise = match number(v) {
            Some(x) if x >= 0.0 => x,
            _ => return err(format!("radio.noise must be a finite number >= 0, got {v}")),
        };
    }
    if let Some(v) = obj.get("seed") {
        r.seed = match v.as_u64() {
            Some(s) => s,
            None => return err(format!("radio.seed must be an integer in [0, 2^64), got {v}")),
        };
    }
    Ok(r)
}

/// [x, y], both finite numbers.
fn point(v: &Value) -> Option<(f64, f64)> {
    match v.as_array().map(|a| a.as_slice()) {
        Some([x, y]) => Some((number(x)?, number(y)?)),
        _ => None,
    }
}

/// `obstacles` (agent/sph/obstacles.py: obstacle_from and its checks): a list of {"kind": "circle", "centre":
/// [x, y], "radius": r > 0} and {"kind": "polygon", "vertices": [[x, y], ...]} (3 to MAX_VERTICES, with an
/// area, no two sides crossing).
pub(super) fn parse_obstacles(v: Option<&Value>) -> Result<Vec<Obstacle>, String> {
    let Some(v) = v else { return Ok(Vec::new()) };
    let Some(list) = v.as_array() else { return err(format!("obstacles must be a list of obstacles, got {v}")) };
    let mut out = Vec::with_capacity(list.len());
    for (k, item) in list.iter().enumerate() {
        let at = format!("obstacles[{k}]");
        let Some(obj) = item.as_object() else { return err(format!("{at} must be an object, got {item}")) };
        let kind = obj.get("kind").and_then(|k| k.as_str());
        match kind {
            Some("circle") => {
                only(obj, &["kind", "centre", "radius"], &format!("{at}."))?;
                let Some((x, y)) = obj.get("centre").and_then(point) else {
                    return err(format!("{at}.centre must be [x, y] finite numbers"));
                };
                let radius = match obj.get("radius").and_then(number) {
                    Some(r) if r > 0.0 => r,
                    _ => return err(format!("{at}.radius must be a finite number > 0")),
                };
                out.push(Obstacle::Circle { x, y, radius });
            }
            Some("polygon") => {
                only(obj, &["kind", "vertices"], &format!("{at}."))?;
                let raw = obj.get("vertices").and_then(|v| v.as_array());
                let vertices: Option<Vec<(f64, f64)>> = raw.map(|a| a.iter().map(point).collect()).unwrap_or(None);
                let vertices = match vertices {
                    Some(vs) if (3..=MAX_VERTICES).contains(&vs.len()) => vs,
                    _ => {
                        return err(format!("{at}.vertices must be a list of 3 to {MAX_VERTICES} [x, y] finite points"))
                    }
                };
                let n = vertices.len();
                let area2: f64 = (0..n)
                    .map(|k| vertices[k].0 * vertices[(k + 1) % n].1 - vertices[(k + 1) % n].0 * vertices[k].1)
                    .sum();
                if fill::edges_cross(std::slice::from_ref(&vertices)) {
                    return err(format!("{at}.vertices: the polygon intersects itself (two sides cross)"));
                }
                if area2 == 0.0 {
                    return err(format!("{at}.vertices: the polygon has no area"));
                }
                out.push(Obstacle::Polygon(vertices));
            }
            _ => return err(format!("{at}.kind must be one of ('circle', 'polygon'), got {:?}", obj.get("kind"))),
        }
    }
    Ok(out)
}
