//! Decoding the gesture command (wire format v1, docs/command.md): a port of `decode` and `parse_body` of
//! agent/protocol/command.py, with the same accept/reject decisions and reasons.
//!
//! The envelope is JSON: {"v": 1, "body": {...}, "sig": HMAC-SHA256(secret, canonical body) in hex}, the
//! canonical body being Python's `json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)`.
//! The signature covers that text, so it must be rebuilt byte for byte: this module carries its own small
//! JSON reader and writer that follow CPython's `json` module instead of serde_json, because serde_json
//! (without features we do not enable) parses floats only to "best effort" precision (a 1-ulp error changes
//! the canonical text and so fails the HMAC of a legitimate command), turns integers beyond 64 bits into
//! floats, and cannot hold the lone surrogates a Python str may carry. Python's rules reproduced here:
//! `json.loads(bytes)` guesses UTF-8/16/32 from BOMs and zero bytes and decodes with 'surrogatepass';
//! NaN/Infinity and floats that overflow are refused (decode's parse_constant/parse_float); integers have
//! arbitrary size up to CPython's 4300-digit limit; duplicate keys keep the last value; strings are
//! sequences of code points (lone surrogates allowed) and sort by code point; floats are written with
//! `repr` (shortest round-trip digits) and strings with `ensure_ascii`.

use std::collections::BTreeMap;

use hmac::{Hmac, Mac};
use sha2::Sha256;

use crate::fill::{edges_cross, Ring};

pub const VERSION: i64 = 1;
pub const MAX_BYTES: usize = 64 * 1024;
pub const MAX_CLASSES: usize = 64;
pub const MAX_ROUTE: usize = 32;
pub const MAX_COORD: f64 = 1e6;
pub const MAX_RINGS: usize = 32;
/// Over all rings of a fill shape: the crossing check is O(V^2) in every agent.
pub const MAX_VERTICES: usize = 512;
/// Material zones of a fill shape (fingers, arms).
pub const MAX_ZONES: usize = 16;
/// Containers nested deeper than this are refused. CPython has no fixed limit: its RecursionError comes at
/// the interpreter's recursion limit (1000) minus the frames already on the stack, 993 levels when decode is
/// called from a shallow stack in CPython 3.11, fewer from deeper ones. A legitimate command nests 5 deep
/// plus its `extra` annotations.
pub const MAX_DEPTH: usize = 900;
/// CPython refuses to convert an integer of more decimal digits (sys.int_info.default_max_str_digits).
const MAX_INT_DIGITS: usize = 4300;

pub const MALFORMED: &str = "malformed";
pub const REJECT_VERSION: &str = "version";
pub const SIGNATURE: &str = "signature";

const HEAD: &[u8] = b"{\"v\":1,\"body\":";
const SIG_KEY: &[u8] = b",\"sig\":\"";
const TAIL_END: &[u8] = b"\"}";
const TAIL_LEN: usize = 8 + 64 + 2;

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
    fn small(&self) -> Option<i128> {
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

fn key(s: &str) -> PyStr {
    s.chars().map(u32::from).collect()
}

/// Lossy conversion for logs: a lone surrogate becomes U+FFFD.
fn to_string(s: &[u32]) -> String {
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

// ---------------------------------------------------------------------------------------------------------
// Bytes to text: json.loads(bytes) = bytes.decode(json.detect_encoding(b), 'surrogatepass').

fn decode_text(b: &[u8]) -> Option<Vec<u32>> {
    if b.starts_with(&[0, 0, 0xFE, 0xFF]) {
        return utf32(&b[4..], true);
    }
    if b.starts_with(&[0xFF, 0xFE, 0, 0]) {
        return utf32(&b[4..], false);
    }
    if b.starts_with(&[0xFE, 0xFF]) {
        return utf16(&b[2..], true);
    }
    if b.starts_with(&[0xFF, 0xFE]) {
        return utf16(&b[2..], false);
    }
    if let Some(rest) = b.strip_prefix(&[0xEF, 0xBB, 0xBF]) {
        return utf8(rest);
    }
    if b.len() >= 4 {
        if b[0] == 0 {
            return if b[1] != 0 { utf16(b, true) } else { utf32(b, true) };
        }
        if b[1] == 0 {
            return if b[2] != 0 || b[3] != 0 { utf16(b, false) } else { utf32(b, false) };
        }
    } else if b.len() == 2 {
        if b[0] == 0 {
            return utf16(b, true);
        }
        if b[1] == 0 {
            return utf16(b, false);
        }
    }
    utf8(b)
}

/// Strict UTF-8, except that 'surrogatepass' lets 3-byte encodings of surrogates (ED A0 80..ED BF BF) through.
fn utf8(mut b: &[u8]) -> Option<Vec<u32>> {
    let mut out = Vec::with_capacity(b.len());
    loop {
        match std::str::from_utf8(b) {
            Ok(s) => {
                out.extend(s.chars().map(u32::from));
                return Some(out);
            }
            Err(e) => {
                let (good, rest) = b.split_at(e.valid_up_to());
                out.extend(std::str::from_utf8(good).ok()?.chars().map(u32::from));
                match rest {
                    [0xED, c1 @ 0xA0..=0xBF, c2 @ 0x80..=0xBF, ..] => {
                        out.push(0xD000 | (u32::from(c1 & 0x3F) << 6) | u32::from(c2 & 0x3F));
                        b = &rest[3..];
                    }
                    _ => return None,
                }
            }
        }
    }
}

fn utf16(b: &[u8], big_endian: bool) -> Option<Vec<u32>> {
    if !b.len().is_multiple_of(2) {
        return None; // truncated data: not a surrogate, so 'surrogatepass' does not excuse it
    }
    let units: Vec<u32> = b
        .chunks_exact(2)
        .map(|c| {
            u32::from(if big_endian { u16::from_be_bytes([c[0], c[1]]) } else { u16::from_le_bytes([c[0], c[1]]) })
        })
        .collect();
    let mut out = Vec::with_capacity(units.len());
    let mut i = 0;
    while i < units.len() {
        let u = units[i];
        match units.get(i + 1) {
            Some(&l) if (0xD800..0xDC00).contains(&u) && (0xDC00..0xE000).contains(&l) => {
                out.push(0x10000 + ((u - 0xD800) << 10) + (l - 0xDC00));
                i += 2;
            }
            _ => {
                out.push(u); // lone surrogates pass
                i += 1;
            }
        }
    }
    Some(out)
}

fn utf32(b: &[u8], big_endian: bool) -> Option<Vec<u32>> {
    if !b.len().is_multiple_of(4) {
        return None;
    }
    b.chunks_exact(4)
        .map(|c| {
            let a = [c[0], c[1], c[2], c[3]];
            let u = if big_endian { u32::from_be_bytes(a) } else { u32::from_le_bytes(a) };
            (u <= 0x10FFFF).then_some(u)
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------------------
// The reader: CPython's json scanner (Modules/_json.c) with decode's parse_constant/parse_float.

struct Reader<'a> {
    s: &'a [u32],
    i: usize,
}

type Parsed<T> = Result<T, ()>;

fn is_digit(c: u32) -> bool {
    (0x30..=0x39).contains(&c)
}

fn hex4(s: &[u32]) -> Option<u32> {
    if s.len() < 4 {
        return None;
    }
    s[..4].iter().try_fold(0u32, |acc, &c| Some(acc * 16 + char::from_u32(c)?.to_digit(16)?))
}

impl Reader<'_> {
    fn peek(&self) -> Option<u32> {
        self.s.get(self.i).copied()
    }

    fn skip_ws(&mut self) {
        while matches!(self.peek(), Some(0x20 | 0x09 | 0x0A | 0x0D)) {
            self.i += 1;
        }
    }

    fn literal(&mut self, word: &str, v: Json) -> Parsed<Json> {
        let w = key(word);
        if self.s[self.i..].starts_with(&w) {
            self.i += w.len();
            Ok(v)
        } else {
            Err(())
        }
    }

    fn value(&mut self, depth: usize) -> Parsed<Json> {
        match char::from_u32(self.peek().ok_or(())?) {
            Some('"') => {
                self.i += 1;
                Ok(Json::Str(self.string()?))
            }
            Some('{') => self.object(depth + 1),
            Some('[') => self.array(depth + 1),
            Some('n') => self.literal("null", Json::Null),
            Some('t') => self.literal("true", Json::Bool(true)),
            Some('f') => self.literal("false", Json::Bool(false)),
            // NaN, Infinity, -Infinity: decode's parse_constant refuses them; anything else there is no JSON
            Some('N' | 'I') => Err(()),
            _ => self.number(),
        }
    }

    /// After the opening quote.
    fn string(&mut self) -> Parsed<PyStr> {
        let mut out = Vec::new();
        loop {
            let c = self.peek().ok_or(())?;
            self.i += 1;
            match c {
                0x22 => return Ok(out),
                0x5C => {
                    let e = char::from_u32(self.peek().ok_or(())?).ok_or(())?;
                    self.i += 1;
                    let v = match e {
                        '"' | '\\' | '/' => u32::from(e),
                        'b' => 0x08,
                        'f' => 0x0C,
                        'n' => 0x0A,
                        'r' => 0x0D,
                        't' => 0x09,
                        'u' => {
                            let mut v = hex4(&self.s[self.i..]).ok_or(())?;
                            self.i += 4;
                            // A high surrogate escape followed by a low one is one character; else it stays lone.
                            if (0xD800..0xDC00).contains(&v) && self.s[self.i..].starts_with(&[0x5C, 0x75]) {
                                let low = hex4(&self.s[self.i + 2..]).ok_or(())?;
                                if (0xDC00..0xE000).contains(&low) {
                                    v = 0x10000 + ((v - 0xD800) << 10) + (low - 0xDC00);
                                    self.i += 6;
                                }
                            }
                            v
                        }
                        _ => return Err(()),
                    };
                    out.push(v);
                }
                0..=0x1F => return Err(()), // strict: no raw control characters
                _ => out.push(c),
            }
        }
    }

    fn object(&mut self, depth: usize) -> Parsed<Json> {
        if depth > MAX_DEPTH {
            return Err(());
        }
        self.i += 1;
        let mut map = BTreeMap::new();
        self.skip_ws();
        if self.peek() == Some(0x7D) {
            self.i += 1;
            return Ok(Json::Object(map));
        }
        loop {
            if self.peek() != Some(0x22) {
                return Err(());
            }
            self.i += 1;
            let k = self.string()?;
            self.skip_ws();
            if self.peek() != Some(0x3A) {
                return Err(());
            }
            self.i += 1;
            self.skip_ws();
            let v = self.value(depth)?;
            map.insert(k, v); // a repeated key keeps its last value, as in a Python dict
            self.skip_ws();
            match self.peek() {
                Some(0x7D) => {
                    self.i += 1;
                    return Ok(Json::Object(map));
                }
                Some(0x2C) => {
                    self.i += 1;
                    self.skip_ws();
                }
                _ => return Err(()),
            }
        }
    }

    fn array(&mut self, depth: usize) -> Parsed<Json> {
        if depth > MAX_DEPTH {
            return Err(());
        }
        self.i += 1;
        let mut items = Vec::new();
        self.skip_ws();
        if self.peek() == Some(0x5D) {
            self.i += 1;
            return Ok(Json::Array(items));
        }
        loop {
            items.push(self.value(depth)?);
            self.skip_ws();
            match self.peek() {
                Some(0x5D) => {
                    self.i += 1;
                    return Ok(Json::Array(items));
                }
                Some(0x2C) => {
                    self.i += 1;
                    self.skip_ws();
                }
                _ => return Err(()),
            }
        }
    }

    /// -?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][-+]?[0-9]+)? as the scanner matches it (a dangling "." or "e" is
    /// left for the caller, where it is a syntax error).
    fn number(&mut self) -> Parsed<Json> {
        let s = self.s;
        let start = self.i;
        let mut i = start;
        if s.get(i) == Some(&0x2D) {
            i += 1;
        }
        match s.get(i) {
            Some(&c) if (0x31..=0x39).contains(&c) => {
                i += 1;
                while s.get(i).is_some_and(|&c| is_digit(c)) {
                    i += 1;
                }
            }
            Some(0x30) => i += 1,
            _ => return Err(()),
        }
        let int_end = i;
        let mut is_float = false;
        if s.get(i) == Some(&0x2E) && s.get(i + 1).is_some_and(|&c| is_digit(c)) {
            is_float = true;
            i += 2;
            while s.get(i).is_some_and(|&c| is_digit(c)) {
                i += 1;
            }
        }
        if matches!(s.get(i), Some(0x65 | 0x45)) {
            let e = i;
            i += 1;
            if matches!(s.get(i), Some(0x2B | 0x2D)) {
                i += 1;
            }
            let digits_at = i;
            while s.get(i).is_some_and(|&c| is_digit(c)) {
                i += 1;
            }
            if i > digits_at {
                is_float = true;
            } else {
                i = e;
            }
        }
        self.i = i;
        // ASCII only from here on, so the code points are bytes.
        let text: String = s[start..i].iter().map(|&c| c as u8 as char).collect();
        if is_float {
            let v: f64 = text.parse().map_err(|_| ())?;
            return if v.is_finite() { Ok(Json::Float(v)) } else { Err(()) }; // decode's _finite
        }
        let negative = s[start] == 0x2D;
        let digits = text[usize::from(negative)..int_end - start].to_string();
        if digits.len() > MAX_INT_DIGITS {
            return Err(());
        }
        Ok(Json::Int(PyInt { negative: negative && digits != "0", digits }))
    }
}

/// `json.loads(data)` for bytes, with decode's refusals; None for anything Python raises on.
pub fn parse(data: &[u8]) -> Option<Json> {
    let text = decode_text(data)?;
    let mut r = Reader { s: &text, i: 0 };
    r.skip_ws();
    let v = r.value(0).ok()?;
    r.skip_ws();
    (r.i == text.len()).then_some(v)
}

// ---------------------------------------------------------------------------------------------------------
// The writer: json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False) (ensure_ascii).

/// Python's `repr(float)`: the shortest digits that round-trip, positional for 1e-4 <= |v| < 1e16, else
/// exponent form with a sign and at least two exponent digits.
pub fn float_repr(v: f64) -> String {
    if v == 0.0 {
        return if v.is_sign_negative() { "-0.0" } else { "0.0" }.to_string();
    }
    // Rust's `{:e}` prints the same shortest round-trip digits (closest among the shortest) as Python's repr,
    // except on an exact tie between two shortest candidates, which Python breaks to the even last digit.
    let sci = format!("{:e}", v.abs());
    let (mantissa, exp) = sci.split_once('e').expect("{:e} has an exponent");
    let mut exp: i32 = exp.parse().expect("integer exponent");
    let mut digits = mantissa.replace('.', "");
    if let Some((even, even_exp)) = tie_to_even(v.abs(), &digits) {
        digits = even;
        exp = even_exp;
    }
    let sign = if v < 0.0 { "-" } else { "" };
    if !(-4..16).contains(&exp) {
        let (first, rest) = digits.split_at(1);
        let dot = if rest.is_empty() { String::new() } else { format!(".{rest}") };
        let esign = if exp < 0 { '-' } else { '+' };
        return format!("{sign}{first}{dot}e{esign}{:02}", exp.abs());
    }
    if exp < 0 {
        return format!("{sign}0.{}{digits}", "0".repeat((-exp - 1) as usize));
    }
    let int_len = exp as usize + 1;
    if digits.len() > int_len {
        format!("{sign}{}.{}", &digits[..int_len], &digits[int_len..])
    } else {
        format!("{sign}{digits}{}.0", "0".repeat(int_len - digits.len()))
    }
}

/// When `v`'s exact decimal value lies exactly halfway between two candidates of `shortest`'s length (a
/// binary fraction such as 0.87348175048828125), the candidate with the even last digit and its exponent.
fn tie_to_even(v: f64, shortest: &str) -> Option<(String, i32)> {
    let n = shortest.len();
    // Exact digits: a double's decimal expansion that ends within n + 40 digits is printed exactly.
    let exact = format!("{:.*e}", n + 40, v);
    let (mantissa, exp) = exact.split_once('e')?;
    let exp: i32 = exp.parse().ok()?;
    let all = mantissa.replace('.', "");
    let (lower, rest) = all.split_at(n);
    if !rest.starts_with('5') || !rest[1..].bytes().all(|b| b == b'0') {
        return None;
    }
    if (lower.as_bytes()[n - 1] - b'0') % 2 == 0 {
        return Some((lower.to_string(), exp));
    }
    // The upper candidate: lower + 1 in its last digit, with the carry.
    let mut up: Vec<u8> = lower.bytes().collect();
    let mut k = n;
    loop {
        if k == 0 {
            up.insert(0, b'1');
            up.pop();
            return Some((String::from_utf8(up).ok()?, exp + 1));
        }
        k -= 1;
        if up[k] == b'9' {
            up[k] = b'0';
        } else {
            up[k] += 1;
            break;
        }
    }
    Some((String::from_utf8(up).ok()?, exp))
}

fn write_str(s: &[u32], out: &mut Vec<u8>) {
    out.push(b'"');
    for &c in s {
        match c {
            0x22 => out.extend_from_slice(b"\\\""),
            0x5C => out.extend_from_slice(b"\\\\"),
            0x0A => out.extend_from_slice(b"\\n"),
            0x0D => out.extend_from_slice(b"\\r"),
            0x09 => out.extend_from_slice(b"\\t"),
            0x08 => out.extend_from_slice(b"\\b"),
            0x0C => out.extend_from_slice(b"\\f"),
            0x20..=0x7E => out.push(c as u8),
            0x10000.. => {
                let v = c - 0x10000;
                out.extend_from_slice(
                    format!("\\u{:04x}\\u{:04x}", 0xD800 | (v >> 10), 0xDC00 | (v & 0x3FF)).as_bytes(),
                );
            }
            _ => out.extend_from_slice(format!("\\u{c:04x}").as_bytes()),
        }
    }
    out.push(b'"');
}

fn write(v: &Json, out: &mut Vec<u8>) {
    match v {
        Json::Null => out.extend_from_slice(b"null"),
        Json::Bool(b) => out.extend_from_slice(if *b { b"true" } else { b"false" }),
        Json::Int(n) => {
            if n.negative {
                out.push(b'-');
            }
            out.extend_from_slice(n.digits.as_bytes());
        }
        Json::Float(f) => out.extend_from_slice(float_repr(*f).as_bytes()),
        Json::Str(s) => write_str(s, out),
        Json::Array(items) => {
            out.push(b'[');
            for (k, item) in items.iter().enumerate() {
                if k > 0 {
                    out.push(b',');
                }
                write(item, out);
            }
            out.push(b']');
        }
        Json::Object(map) => {
            out.push(b'{');
            for (k, (name, item)) in map.iter().enumerate() {
                if k > 0 {
                    out.push(b',');
                }
                write_str(name, out);
                out.push(b':');
                write(item, out);
            }
            out.push(b'}');
        }
    }
}

/// The canonical text the signature covers.
pub fn canonical(v: &Json) -> Vec<u8> {
    let mut out = Vec::new();
    write(v, &mut out);
    out
}

// ---------------------------------------------------------------------------------------------------------
// Signature.

fn hmac_hex(secret: &[u8], msg: &[u8]) -> [u8; 64] {
    let mut mac = Hmac::<Sha256>::new_from_slice(secret).expect("HMAC takes keys of any length");
    mac.update(msg);
    let digest = mac.finalize().into_bytes();
    let mut hex = [0u8; 64];
    for (k, b) in digest.iter().enumerate() {
        hex[2 * k] = b"0123456789abcdef"[usize::from(b >> 4)];
        hex[2 * k + 1] = b"0123456789abcdef"[usize::from(b & 15)];
    }
    hex
}

/// hmac.compare_digest: time independent of where the first difference is.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

// ---------------------------------------------------------------------------------------------------------
// The command.

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

type Obj = BTreeMap<PyStr, Json>;

fn get<'a>(d: &'a Obj, k: &str) -> Option<&'a Json> {
    d.get(&key(k))
}

/// `_only`: an object with no key outside `allowed`.
fn only<'a>(v: &'a Json, allowed: &[&str]) -> Result<&'a Obj, &'static str> {
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

/// Verify and parse an envelope from the network: Err("malformed" | "version" | "signature").
pub fn decode(data: &[u8], secret: &[u8]) -> Result<GestureCommand, &'static str> {
    if data.len() > MAX_BYTES {
        return Err(MALFORMED);
    }
    let n = data.len();
    // (Shorter data cannot hold the head and the tail without overlapping them: Python's test fails too.)
    if n >= HEAD.len() + TAIL_LEN
        && data.starts_with(HEAD)
        && data.ends_with(TAIL_END)
        && &data[n - TAIL_LEN..n - 66] == SIG_KEY
    {
        // The envelope as `encode` writes it: check the HMAC over the raw body bytes before parsing
        // anything, so a flood of forged commands costs an agent microseconds each, not a JSON parse.
        if !same(&hmac_hex(secret, &data[HEAD.len()..n - TAIL_LEN]), &data[n - 66..n - 2]) {
            return Err(SIGNATURE);
        }
    }
    let env = parse(data).ok_or(MALFORMED)?;
    let env = only(&env, &["v", "body", "sig"])?;
    // Python's `env.get("v") != 1`: 1, 1.0 and True all equal 1.
    let one = Json::Int(PyInt { negative: false, digits: "1".into() });
    if !get(env, "v").is_some_and(|v| py_eq(v, &one)) {
        return Err(REJECT_VERSION);
    }
    let (body, sig) = match (get(env, "body"), get(env, "sig")) {
        (Some(b @ Json::Object(_)), Some(Json::Str(s))) => (b, s),
        _ => return Err(MALFORMED),
    };
    if sig.len() != 64 || sig.iter().any(|&c| c >= 0x80) {
        return Err(SIGNATURE);
    }
    let sig: Vec<u8> = sig.iter().map(|&c| c as u8).collect();
    if !same(&hmac_hex(secret, &canonical(body)), &sig) {
        return Err(SIGNATURE);
    }
    parse_body(body)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SECRET: &[u8] = b"0123456789abcdef";

    fn sign(body: &str) -> Vec<u8> {
        let sig = hmac_hex(SECRET, body.as_bytes());
        [HEAD, body.as_bytes(), SIG_KEY, &sig, TAIL_END].concat()
    }

    const BODY: &str = r#"{"beta":2.0,"classes":[{"name":"a","route":[{"alpha":1.0,"mu":0.5,"r":1.0,"s":2.0,"x":3.0,"y":4.0}],"share":1.0}],"extra":{},"gesture":"v","mu":0.0,"n_agents":10,"seq":1}"#;

    #[test]
    fn accepts_a_signed_command() {
        let cmd = decode(&sign(BODY), SECRET).unwrap();
        assert_eq!((cmd.seq, cmd.n_agents, cmd.gesture.as_str(), cmd.beta, cmd.mu), (1, 10, "v", 2.0, 0.0));
        let w = &cmd.classes[0].route[0];
        assert_eq!((w.x, w.y, w.r, w.s, w.alpha, w.beta, w.mu), (3.0, 4.0, 1.0, 2.0, 1.0, None, Some(0.5)));
        assert_eq!(canonical(&parse(BODY.as_bytes()).unwrap()), BODY.as_bytes());
    }

    #[test]
    fn rejects() {
        let mut forged = sign(BODY);
        forged[30] ^= 1;
        assert_eq!(decode(&forged, SECRET), Err(SIGNATURE));
        assert_eq!(decode(&sign(BODY), b"other"), Err(SIGNATURE));
        assert_eq!(decode(b"{\"v\":2,\"body\":{},\"sig\":\"\"}", SECRET), Err(REJECT_VERSION));
        assert_eq!(decode(b"[", SECRET), Err(MALFORMED));
        assert_eq!(decode(&vec![b' '; MAX_BYTES + 1], SECRET), Err(MALFORMED));
        let deep = format!("{}{}", "[".repeat(10000), "]".repeat(10000));
        assert_eq!(decode(deep.as_bytes(), SECRET), Err(MALFORMED));
    }

    #[test]
    fn fill_shape() {
        let with = |fill: &str| BODY.replacen("\"extra\":{}", &format!("\"extra\":{{}},\"fill\":{fill}"), 1);
        let body = with(r#"{"alpha":80,"rings":[[[0,0],[10.5,0.0],[12.3456,-1e-05]]],"s":0.2}"#);
        let cmd = decode(&sign(&body), SECRET).unwrap();
        let fill = cmd.fill.as_ref().unwrap();
        assert_eq!(fill.rings, vec![vec![(0.0, 0.0), (10.5, 0.0), (12.3456, -1e-05)]]);
        assert_eq!((fill.alpha, fill.s), (80.0, 0.2));
        // ints stay ints in the canonical text the signature covers
        assert_eq!(canonical(&parse(body.as_bytes()).unwrap()), body.as_bytes());
        // Python's equality: 0 == 0.0, so the same shape written with floats is the same command
        let floats = with(r#"{"alpha":80.0,"rings":[[[0.0,0.0],[10.5,0],[12.3456,-1e-05]]],"s":0.2}"#);
        assert!(decode(&sign(&floats), SECRET).unwrap() == cmd);
        assert!(decode(&sign(BODY), SECRET).unwrap().fill.is_none());
        for bad in [
            r#"{"alpha":80,"rings":[[[0,0],[1,1],[1,0],[0,1]]],"s":0.2}"#, // bow-tie
            r#"{"alpha":80,"rings":[[[0,0],[1,1]]],"s":0.2}"#,
            r#"{"alpha":80,"rings":[[[0,0],[1,1],[true,0]]],"s":0.2}"#,
            r#"{"alpha":80,"rings":[[[0,0],[1,1],[0,1,2]]],"s":0.2}"#,
            r#"{"alpha":80,"r":1,"rings":[[[0,0],[1,0],[0,1]]],"s":0.2}"#, // keys sorted: canonical
        ] {
            assert_eq!(decode(&sign(&with(bad)), SECRET), Err(MALFORMED), "{bad}");
        }
    }

    #[test]
    fn float_repr_like_python() {
        for (v, s) in [
            (1e-5, "1e-05"),
            (1.5e16, "1.5e+16"),
            (1e16, "1e+16"),
            (0.0001, "0.0001"),
            (123.0, "123.0"),
            (-0.0, "-0.0"),
            (0.1 + 0.2, "0.30000000000000004"),
            (1234567890123456.0, "1234567890123456.0"),
            (5e-324, "5e-324"),
            (1.7976931348623157e308, "1.7976931348623157e+308"),
            (-123.456, "-123.456"),
        ] {
            assert_eq!(float_repr(v), s);
        }
    }

    #[test]
    fn strings_like_python() {
        let v = parse("\"a\\u00e9\u{1F600}\\ud800\\n\u{7f}\\\"\"".as_bytes()).unwrap();
        assert_eq!(canonical(&v), b"\"a\\u00e9\\ud83d\\ude00\\ud800\\n\\u007f\\\"\"");
        // keys sort by code point: a lone surrogate before U+E000 and after U+D7FF
        let v = parse("{\"\u{e000}\":1,\"\\ud800\":2,\"\u{d7ff}\":3}".as_bytes()).unwrap();
        assert_eq!(canonical(&v), b"{\"\\ud7ff\":3,\"\\ud800\":2,\"\\ue000\":1}");
    }

    #[test]
    fn python_equality() {
        let a = parse(br#"{"k":[1,true,2.0,null,"x"]}"#).unwrap();
        let b = parse(br#"{"k":[1.0,1,2,null,"x"]}"#).unwrap();
        assert!(py_eq(&a, &b));
        let c = parse(br#"{"k":[1.0,1,2,null,"y"]}"#).unwrap();
        assert!(!py_eq(&a, &c));
        let big = parse(b"[9007199254740993, 9007199254740992.0]").unwrap();
        let Json::Array(x) = big else { panic!() };
        assert!(!py_eq(&x[0], &x[1])); // exact, as Python: 2**53 + 1 != 2.0**53
    }
}
