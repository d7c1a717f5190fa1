//! Python's JSON values as `json.loads` builds them (arbitrary ints, code-point strings with lone surrogates)
//! and Python's `==` on them, for CommandFollower.offer's `cmd == newest` on the free-form `extra`.

use std::collections::BTreeMap;

/// A Python str: code points, which may include lone surrogates (not representable in a Rust String).
pub type PyStr = Vec<u32>;

/// A Python int of any size: sign and decimal digits without leading zeros ("0" is never negative).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PyInt {
    pub negative: bool,
    pub digits: String,
}

impl PyInt {
    /// The value if it fits an i128 (|n| < 10^38), else None.
    pub(super) fn small(&self) -> Option<i128> {
        if self.digits.len() > 38 {
            return None;
        }
        let v: i128 = self.digits.parse().ok()?;
        Some(if self.negative { -v } else { v })
    }
}

/// A JSON value as Python's `json.loads` builds it.
#[derive(Clone, Debug)]
pub enum Json {
    Null,
    Bool(bool),
    Int(PyInt),
    Float(f64),
    Str(PyStr),
    Array(Vec<Json>),
    /// Keys in code point order, which is the order of Python's `sorted` on str.
    Object(BTreeMap<PyStr, Json>),
}

pub(super) fn key(s: &str) -> PyStr {
    s.chars().map(u32::from).collect()
}

/// Lossy conversion for logs: a lone surrogate becomes U+FFFD.
pub(super) fn to_string(s: &[u32]) -> String {
    s.iter().map(|&c| char::from_u32(c).unwrap_or(char::REPLACEMENT_CHARACTER)).collect()
}

// ---------------------------------------------------------------------------------------------------------
// Python equality (`==`), for CommandFollower.offer's `cmd == newest` on the free-form `extra`.

enum Num<'a> {
    Int(std::borrow::Cow<'a, PyInt>),
    Float(f64),
}

fn as_num(v: &Json) -> Option<Num<'_>> {
    match v {
        // bool is an int in Python: True == 1 == 1.0
        Json::Bool(b) => Some(Num::Int(std::borrow::Cow::Owned(PyInt {
            negative: false,
            digits: if *b { "1" } else { "0" }.to_string(),
        }))),
        Json::Int(n) => Some(Num::Int(std::borrow::Cow::Borrowed(n))),
        Json::Float(f) => Some(Num::Float(*f)),
        _ => None,
    }
}

/// Python's exact int/float comparison.
fn int_eq_float(n: &PyInt, f: f64) -> bool {
    if !f.is_finite() || f.fract() != 0.0 {
        return false;
    }
    let exact = format!("{:.0}", f.abs()); // exact decimal digits of an integral float
    let negative = f < 0.0;
    n.digits == exact && (n.negative == negative || n.digits == "0")
}

pub fn py_eq(a: &Json, b: &Json) -> bool {
    if let (Some(x), Some(y)) = (as_num(a), as_num(b)) {
        return match (x, y) {
            (Num::Int(p), Num::Int(q)) => p == q,
            (Num::Float(p), Num::Float(q)) => p == q,
            (Num::Int(p), Num::Float(q)) | (Num::Float(q), Num::Int(p)) => int_eq_float(&p, q),
        };
    }
    match (a, b) {
        (Json::Null, Json::Null) => true,
        (Json::Str(p), Json::Str(q)) => p == q,
        (Json::Array(p), Json::Array(q)) => p.len() == q.len() && p.iter().zip(q).all(|(x, y)| py_eq(x, y)),
        (Json::Object(p), Json::Object(q)) => {
            p.len() == q.len() && p.iter().all(|(k, x)| q.get(k).is_some_and(|y| py_eq(x, y)))
        }
        _ => false,
    }
}
