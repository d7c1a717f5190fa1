//! The typed gesture command and `parse_body` (agent/protocol/command.py): every field checked, every failure
//! "malformed".

use std::collections::BTreeMap;

use super::pyjson::{key, py_eq, to_string, Json, PyStr};
use super::{MALFORMED, MAX_CLASSES, MAX_COORD, MAX_RINGS, MAX_ROUTE, MAX_VERTICES, MAX_ZONES};
use crate::fill::{edges_cross, Ring};

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
    /// For logs; a lone surrogate in the command shows as U+FFFD.
    pub name: String,
    pub share: f64,
    pub route: Vec<Waypoint>,
}

/// The silhouette the swarm fills (agent/fill.py): `rings` of (x, y) vertices [m], closed implicitly,
/// even-odd (a ring inside another is a hole), no two edges crossing. A particle outside is pulled towards
/// the nearest boundary point with gain `alpha` [1/s^2] over ramp `s` [m] (eq. 6.2); inside, no body force.
/// Equality is Python's: vertex by vertex with `==` (0.0 == -0.0).
#[derive(Clone, Debug, PartialEq)]
pub struct Fill {
    pub rings: Vec<Ring>,
    pub alpha: f64,
    pub s: f64,
    /// Where stiffness/viscosity differ from the command's (fingers, arms); empty when not sent.
    pub zones: Vec<Zone>,
}

/// A material zone of the shape (agent/protocol/command.py `Zone`): an ellipse with centre (x, y) [m], unit
/// major axis (ux, uy) and semi-axes a, b [m]; an agent inside it uses `beta` and `mu`.
#[derive(Clone, Debug, PartialEq)]
pub struct Zone {
    pub x: f64,
    pub y: f64,
    pub ux: f64,
    pub uy: f64,
    pub a: f64,
    pub b: f64,
    pub beta: f64,
    pub mu: f64,
}

#[derive(Clone, Debug)]
pub struct GestureCommand {
    pub seq: u64,
    /// For logs; a lone surrogate in the command shows as U+FFFD.
    pub gesture: String,
    pub n_agents: u64,
    pub classes: Vec<ParticleClass>,
    pub beta: f64,
    pub mu: f64,
    /// Free-form annotations (an object), for logs only.
    pub extra: Json,
    /// The shape to fill; with it, routes are not followed (classes still label the particles).
    pub fill: Option<Fill>,
    /// The gesture and class names as Python strs, for an exact `==`.
    texts: Vec<PyStr>,
}

/// Python's dataclass equality: field by field with `==` (so 1 == 1.0 and 0.0 == -0.0), `extra` included.
impl PartialEq for GestureCommand {
    fn eq(&self, o: &Self) -> bool {
        self.seq == o.seq
            && self.n_agents == o.n_agents
            && self.texts == o.texts
            && self.classes == o.classes
            && self.beta == o.beta
            && self.mu == o.mu
            && py_eq(&self.extra, &o.extra)
            && self.fill == o.fill
    }
}

pub(super) type Obj = BTreeMap<PyStr, Json>;

pub(super) fn get<'a>(d: &'a Obj, k: &str) -> Option<&'a Json> {
    d.get(&key(k))
}

/// `_only`: an object with no key outside `allowed`.
pub(super) fn only<'a>(v: &'a Json, allowed: &[&str]) -> Result<&'a Obj, &'static str> {
    match v {
        Json::Object(d) if d.keys().all(|k| allowed.iter().any(|a| key(a) == *k)) => Ok(d),
        _ => Err(MALFORMED),
    }
}

/// `_num`: an int or float (not bool) within [lo, hi], as a float.
fn num(d: &Obj, k: &str, lo: f64, hi: f64) -> Result<Option<f64>, &'static str> {
    get(d, k).map(|v| number(v, lo, hi)).transpose()
}

/// `_num` on a present value.
fn number(v: &Json, lo: f64, hi: f64) -> Result<f64, &'static str> {
    let v = match v {
        Json::Float(f) => *f,
        // Exact for every int in range (the bounds are at most 1e6); anything beyond i128 is out of range,
        // as Python finds it (an int beyond 2**1023 is refused as "malformed" before float() overflows).
        Json::Int(n) => n.small().ok_or(MALFORMED)? as f64,
        _ => return Err(MALFORMED),
    };
    if lo <= v && v <= hi {
        Ok(v)
    } else {
        Err(MALFORMED)
    }
}

fn required(d: &Obj, k: &str, lo: f64, hi: f64) -> Result<f64, &'static str> {
    num(d, k, lo, hi)?.ok_or(MALFORMED)
}

/// An int (not bool) in [lo, hi).
fn int_in(v: Option<&Json>, lo: i128, hi: i128) -> Result<u64, &'static str> {
    match v {
        Some(Json::Int(n)) => match n.small() {
            Some(x) if lo <= x && x < hi => Ok(x as u64),
            _ => Err(MALFORMED),
        },
        _ => Err(MALFORMED),
    }
}

/// A str of at most 64 code points (Python's len); "" when absent.
fn short_str(v: Option<&Json>) -> Result<PyStr, &'static str> {
    match v {
        None => Ok(Vec::new()),
        Some(Json::Str(s)) if s.len() <= 64 => Ok(s.clone()),
        _ => Err(MALFORMED),
    }
}

fn list(v: Option<&Json>, max: usize) -> Result<&[Json], &'static str> {
    match v {
        Some(Json::Array(items)) if (1..=max).contains(&items.len()) => Ok(items),
        _ => Err(MALFORMED),
    }
}

/// `parse_body`: the typed command from a verified body; every failure is "malformed".
pub fn parse_body(body: &Json) -> Result<GestureCommand, &'static str> {
    let body = only(body, &["seq", "gesture", "n_agents", "classes", "beta", "mu", "extra", "fill"])?;
    let seq = int_in(get(body, "seq"), 0, 1 << 62)?;
    let n_agents = int_in(get(body, "n_agents"), 1, 100_001)?;
    let gesture = short_str(get(body, "gesture"))?;
    let mut texts = vec![gesture.clone()];
    let mut classes = Vec::new();
    for c in list(get(body, "classes"), MAX_CLASSES)? {
        let c = only(c, &["name", "share", "route"])?;
        let name = short_str(get(c, "name"))?;
        let share = required(c, "share", 0.0, 1e6)?;
        let mut route = Vec::new();
        for w in list(get(c, "route"), MAX_ROUTE)? {
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
        classes.push(ParticleClass { name: to_string(&name), share, route });
        texts.push(name);
    }
    // Python's sum: left to right from 0
    if classes.iter().fold(0.0, |acc, c| acc + c.share) <= 0.0 {
        return Err(MALFORMED);
    }
    let extra = match get(body, "extra") {
        None => Json::Object(BTreeMap::new()),
        Some(e @ Json::Object(_)) => e.clone(),
        Some(_) => return Err(MALFORMED),
    };
    let fill = get(body, "fill").map(parse_fill).transpose()?;
    Ok(GestureCommand {
        seq,
        gesture: to_string(&gesture),
        n_agents,
        classes,
        beta: required(body, "beta", 0.0, 1e4)?,
        mu: required(body, "mu", 0.0, 1e4)?,
        extra,
        fill,
        texts,
    })
}

/// `_fill`: 1..=MAX_RINGS rings of at least 3 [x, y] vertices, at most MAX_VERTICES in all, no two edges
/// crossing; alpha in [0, 1e4], s in [0, MAX_COORD]; no other key. Every failure is "malformed".
fn parse_fill(f: &Json) -> Result<Fill, &'static str> {
    let f = only(f, &["rings", "alpha", "s", "zones"])?;
    let mut rings = Vec::new();
    let mut total = 0;
    for ring in list(get(f, "rings"), MAX_RINGS)? {
        let ring = match ring {
            Json::Array(vs) if vs.len() >= 3 => vs,
            _ => return Err(MALFORMED),
        };
        total += ring.len();
        if total > MAX_VERTICES {
            return Err(MALFORMED);
        }
        let mut vs = Vec::with_capacity(ring.len());
        for v in ring {
            match v {
                Json::Array(xy) if xy.len() == 2 => {
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
    let zones = match get(f, "zones") {
        None => Vec::new(),
        Some(Json::Array(zs)) if zs.len() <= MAX_ZONES => zs.iter().map(parse_zone).collect::<Result<_, _>>()?,
        Some(_) => return Err(MALFORMED),
    };
    Ok(Fill { rings, alpha: required(f, "alpha", 0.0, 1e4)?, s: required(f, "s", 0.0, MAX_COORD)?, zones })
}

/// `_zone`: an ellipse with a unit axis (|ux^2 + uy^2 - 1| <= 1e-6) and semi-axes > 0; no other key.
fn parse_zone(z: &Json) -> Result<Zone, &'static str> {
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
