//! The typed gesture command and `parse_body` (agent/protocol/command.py): every field checked, every failure
//! "malformed".

use serde_json::{Map, Value};

use super::{MALFORMED, MAX_CLASSES, MAX_COORD, MAX_RINGS, MAX_ROUTE, MAX_VERTICES, MAX_ZONES};
use crate::fill::{edges_cross, Ring, Zone};

#[derive(Clone, Debug, PartialEq)]
pub struct Waypoint {
    pub x: f64,
    pub y: f64,
    pub r: f64,
    pub s: f64,
    pub alpha: f64,
    /// Stiffness / viscosity to switch to when the waypoint is reached (None: keep).
    pub beta: Option<f64>,
    pub mu: Option<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ParticleClass {
    /// For logs.
    pub name: String,
    pub share: f64,
    pub route: Vec<Waypoint>,
}

/// The silhouette the swarm fills (agent/fill.py): `rings` of (x, y) vertices [m], closed implicitly,
/// even-odd (a ring inside another is a hole), no two edges crossing. A particle outside is pulled towards
/// the nearest boundary point with gain `alpha` [1/s^2] over ramp `s` [m] (eq. 6.2); inside, no body force.
#[derive(Clone, Debug, PartialEq)]
pub struct Fill {
    pub rings: Vec<Ring>,
    pub alpha: f64,
    pub s: f64,
    /// Where stiffness/viscosity differ from the command's (fingers, arms); empty when not sent.
    pub zones: Vec<Zone>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct GestureCommand {
    pub seq: u64,
    /// For logs.
    pub gesture: String,
    pub n_agents: u64,
    pub classes: Vec<ParticleClass>,
    pub beta: f64,
    pub mu: f64,
    /// The shape to fill; with it, routes are not followed (classes still label the particles). (The body's
    /// `extra` annotations are checked to be an object and not kept: agents ignore them.)
    pub fill: Option<Fill>,
}

type Obj = Map<String, Value>;

/// `_only`: an object with no key outside `allowed`.
fn only<'a>(v: &'a Value, allowed: &[&str]) -> Result<&'a Obj, &'static str> {
    match v {
        Value::Object(d) if d.keys().all(|k| allowed.contains(&k.as_str())) => Ok(d),
        _ => Err(MALFORMED),
    }
}

/// `_num`: an int or float (not bool) within [lo, hi], as a float.
fn num(d: &Obj, k: &str, lo: f64, hi: f64) -> Result<Option<f64>, &'static str> {
    d.get(k).map(|v| number(v, lo, hi)).transpose()
}

/// `_num` on a present value. (An integer beyond 64 bits is read as a float by serde_json: out of range.)
fn number(v: &Value, lo: f64, hi: f64) -> Result<f64, &'static str> {
    match v.as_f64() {
        Some(x) if lo <= x && x <= hi => Ok(x),
        _ => Err(MALFORMED),
    }
}

fn required(d: &Obj, k: &str, lo: f64, hi: f64) -> Result<f64, &'static str> {
    num(d, k, lo, hi)?.ok_or(MALFORMED)
}

/// An integer (not bool, not written with a fraction or exponent, not -0) in [lo, hi).
fn int_in(v: Option<&Value>, lo: u64, hi: u64) -> Result<u64, &'static str> {
    match v.and_then(Value::as_u64) {
        Some(x) if lo <= x && x < hi => Ok(x),
        _ => Err(MALFORMED),
    }
}

/// A string of at most 64 code points (Python's len); "" when absent.
fn short_str(v: Option<&Value>) -> Result<String, &'static str> {
    match v {
        None => Ok(String::new()),
        Some(Value::String(s)) if s.chars().count() <= 64 => Ok(s.clone()),
        _ => Err(MALFORMED),
    }
}

fn list(v: Option<&Value>, max: usize) -> Result<&[Value], &'static str> {
    match v {
        Some(Value::Array(items)) if (1..=max).contains(&items.len()) => Ok(items),
        _ => Err(MALFORMED),
    }
}

/// `parse_body`: the typed command from a verified body; every failure is "malformed".
pub fn parse_body(body: &Value) -> Result<GestureCommand, &'static str> {
    let body = only(body, &["seq", "gesture", "n_agents", "classes", "beta", "mu", "extra", "fill"])?;
    let seq = int_in(body.get("seq"), 0, 1 << 62)?;
    let n_agents = int_in(body.get("n_agents"), 1, 100_001)?;
    let gesture = short_str(body.get("gesture"))?;
    let mut classes = Vec::new();
    for c in list(body.get("classes"), MAX_CLASSES)? {
        let c = only(c, &["name", "share", "route"])?;
        let name = short_str(c.get("name"))?;
        let share = required(c, "share", 0.0, 1e6)?;
        let mut route = Vec::new();
        for w in list(c.get("route"), MAX_ROUTE)? {
            let w = only(w, &["x", "y", "r", "s", "alpha", "beta", "mu"])?;
            route.push(Waypoint {
                x: required(w, "x", -MAX_COORD, MAX_COORD)?,
                y: required(w, "y", -MAX_COORD, MAX_COORD)?,
                r: required(w, "r", 0.0, MAX_COORD)?,
                s: required(w, "s", 0.0, MAX_COORD)?,
                alpha: required(w, "alpha", 0.0, 1e4)?,
                beta: num(w, "beta", 0.0, 1e4)?,
                mu: num(w, "mu", 0.0, 1e4)?,
            });
        }
        classes.push(ParticleClass { name, share, route });
    }
    // Python's sum: left to right from 0
    if classes.iter().fold(0.0, |acc, c| acc + c.share) <= 0.0 {
        return Err(MALFORMED);
    }
    if body.get("extra").is_some_and(|e| !e.is_object()) {
        return Err(MALFORMED);
    }
    let fill = body.get("fill").map(parse_fill).transpose()?;
    Ok(GestureCommand {
        seq,
        gesture,
        n_agents,
        classes,
        beta: required(body, "beta", 0.0, 1e4)?,
        mu: required(body, "mu", 0.0, 1e4)?,
        fill,
    })
}

/// `_fill`: 1..=MAX_RINGS rings of at least 3 [x, y] vertices, at most MAX_VERTICES in all, no two edges
/// crossing; alpha in [0, 1e4], s in [0, MAX_COORD]; no other key. Every failure is "malformed".
fn parse_fill(f: &Value) -> Result<Fill, &'static str> {
    let f = only(f, &["rings", "alpha", "s", "zones"])?;
    let mut rings = Vec::new();
    let mut total = 0;
    for ring in list(f.get("rings"), MAX_RINGS)? {
        let ring = match ring {
            Value::Array(vs) if vs.len() >= 3 => vs,
            _ => return Err(MALFORMED),
        };
        total += ring.len();
        if total > MAX_VERTICES {
            return Err(MALFORMED);
        }
        let mut vs = Vec::with_capacity(ring.len());
        for v in ring {
            match v {
                Value::Array(xy) if xy.len() == 2 => {
                    vs.push((number(&xy[0], -MAX_COORD, MAX_COORD)?, number(&xy[1], -MAX_COORD, MAX_COORD)?))
                }
                _ => return Err(MALFORMED),
            }
        }
        rings.push(vs);
    }
    if edges_cross(&rings) {
        return Err(MALFORMED);
    }
    let zones = match f.get("zones") {
        None => Vec::new(),
        Some(Value::Array(zs)) if zs.len() <= MAX_ZONES => zs.iter().map(parse_zone).collect::<Result<_, _>>()?,
        Some(_) => return Err(MALFORMED),
    };
    Ok(Fill { rings, alpha: required(f, "alpha", 0.0, 1e4)?, s: required(f, "s", 0.0, MAX_COORD)?, zones })
}

/// `_zone`: an ellipse with a unit axis (|ux^2 + uy^2 - 1| <= 1e-6) and semi-axes > 0; no other key.
fn parse_zone(z: &Value) -> Result<Zone, &'static str> {
    let z = only(z, &["x", "y", "ux", "uy", "a", "b", "beta", "mu"])?;
    let (ux, uy) = (required(z, "ux", -1.0, 1.0)?, required(z, "uy", -1.0, 1.0)?);
    if (ux * ux + uy * uy - 1.0).abs() > 1e-6 {
        return Err(MALFORMED);
    }
    let (a, b) = (required(z, "a", 0.0, MAX_COORD)?, required(z, "b", 0.0, MAX_COORD)?);
    if !(a > 0.0 && b > 0.0) {
        return Err(MALFORMED);
    }
    Ok(Zone {
        x: required(z, "x", -MAX_COORD, MAX_COORD)?,
        y: required(z, "y", -MAX_COORD, MAX_COORD)?,
        ux,
        uy,
        a,
        b,
        beta: required(z, "beta", 0.0, 1e4)?,
        mu: required(z, "mu", 0.0, 1e4)?,
    })
}
