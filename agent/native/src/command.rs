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
//!
//! The parts: `pyjson` (Python's JSON values and `==`), `text` (bytes to code points as json.loads does),
//! `reader` (CPython's scanner), `writer` (the canonical text), `body` (the typed command, `parse_body`);
//! this module holds the envelope: its signature check and `decode`.

mod body;
mod pyjson;
mod reader;
mod text;
mod writer;

use hmac::{Hmac, Mac};
use sha2::Sha256;

pub use body::{parse_body, Fill, GestureCommand, ParticleClass, Waypoint, Zone};
use body::{get, only};
pub use pyjson::{py_eq, Json, PyInt, PyStr};
pub use reader::parse;
pub use writer::{canonical, float_repr};

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
