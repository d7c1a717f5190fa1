//! Decoding the gesture command (wire format v1, docs/command.md): `verify` and `decode` of
//! agent/protocol/command.py, with the same accept/reject decisions and reasons.
//!
//! The envelope is exactly `{"v":1,"body":` BODY `,"sig":"` HMAC-SHA256(secret, BODY) in hex `"}`, as the one
//! encoder (`sign`, called by Python's `GestureCommand.encode`) writes it. The signature covers the body's bytes as sent, so it
//! is checked before any JSON is read (a forgery costs one HMAC), and the body is then read by serde_json:
//! no parser here has to reproduce the encoder's.
//!
//! The parts: this module holds the envelope (`verify`, `decode`); `body` the typed command (`parse_body`).

mod body;

use hmac::{Hmac, Mac};
use serde_json::Value;
use sha2::Sha256;

pub use crate::fill::Zone;
pub use body::{parse_body, Fill, GestureCommand, ParticleClass, Waypoint};

pub const MAX_BYTES: usize = 64 * 1024;
pub const MAX_CLASSES: usize = 64;
pub const MAX_ROUTE: usize = 32;
pub const MAX_COORD: f64 = 1e6;
pub const MAX_RINGS: usize = 32;
/// Over all rings of a fill shape: the crossing check is O(V^2) in every agent.
pub const MAX_VERTICES: usize = 512;
/// Material zones of a fill shape (fingers, arms).
pub const MAX_ZONES: usize = 16;
/// Nested arrays/objects, the body counting 1 (agent/protocol/command.py MAX_DEPTH): a command nests 5 deep,
/// its annotations a few more. serde_json alone would allow 127, Python's json about 990.
pub const MAX_DEPTH: usize = 32;

pub const MALFORMED: &str = "malformed";
pub const REJECT_VERSION: &str = "version";
pub const SIGNATURE: &str = "signature";

const HEAD: &[u8] = b"{\"v\":";
const V1: &[u8] = b"{\"v\":1,\"body\":";
const SIG_KEY: &[u8] = b",\"sig\":\"";
const TAIL_END: &[u8] = b"\"}";
const TAIL_LEN: usize = 8 + 64 + 2;

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

/// The body bytes of an envelope, once their HMAC matches: Err("malformed" | "version" | "signature"), no
/// JSON read. Another version is named by the digits after `{"v":`.
pub fn verify<'a>(data: &'a [u8], secret: &[u8]) -> Result<&'a [u8], &'static str> {
    if data.len() > MAX_BYTES {
        return Err(MALFORMED);
    }
    if !data.starts_with(V1) {
        let rest = data.strip_prefix(HEAD).unwrap_or_default();
        let v = &rest[..rest.iter().position(|&c| c == b',').unwrap_or(0)];
        if !v.is_empty() && v.iter().all(u8::is_ascii_digit) && v != b"1" {
            return Err(REJECT_VERSION);
        }
        return Err(MALFORMED);
    }
    let n = data.len();
    if n < V1.len() + TAIL_LEN || &data[n - TAIL_LEN..n - 66] != SIG_KEY || !data.ends_with(TAIL_END) {
        return Err(SIGNATURE); // unsigned, or not a hex HMAC-SHA256
    }
    let body = &data[V1.len()..n - TAIL_LEN];
    if !same(&hmac_hex(secret, body), &data[n - 66..n - 2]) {
        return Err(SIGNATURE);
    }
    Ok(body)
}

/// Containers nested at most `MAX_DEPTH` deep (`v` itself at `depth`).
fn shallow(v: &Value, depth: usize) -> bool {
    match v {
        Value::Array(items) => depth <= MAX_DEPTH && items.iter().all(|x| shallow(x, depth + 1)),
        Value::Object(map) => depth <= MAX_DEPTH && map.values().all(|x| shallow(x, depth + 1)),
        _ => true,
    }
}

/// Verify and parse an envelope from the network: Err("malformed" | "version" | "signature").
pub fn decode(data: &[u8], secret: &[u8]) -> Result<GestureCommand, &'static str> {
    parse_value(&read_body(verify(data, secret)?)?)
}

/// A verified body's JSON (serde_json, RFC 8259 in UTF-8: no NaN, no number beyond binary64, no lone
/// surrogate), at most MAX_DEPTH deep; Err("malformed").
pub fn read_body(body: &[u8]) -> Result<Value, &'static str> {
    let value: Value = serde_json::from_slice(body).map_err(|_| MALFORMED)?;
    if !shallow(&value, 1) {
        return Err(MALFORMED);
    }
    Ok(value)
}

/// The typed command of a body's JSON, however it was read (an envelope, or the coordinator's commands file
/// through the Python side): at most MAX_DEPTH deep, then `parse_body`.
pub fn parse_value(body: &Value) -> Result<GestureCommand, &'static str> {
    if !shallow(body, 1) {
        return Err(MALFORMED);
    }
    parse_body(body)
}

/// The envelope of a body, the one writer (the coordinator's, through agent/protocol/command.py):
/// `{"v":1,"body":` BODY `,"sig":"` HMAC-SHA256(secret, BODY) in hex `"}`.
pub fn sign(body: &[u8], secret: &[u8]) -> Vec<u8> {
    [V1, body, SIG_KEY, &hmac_hex(secret, body), TAIL_END].concat()
}

#[cfg(test)]
mod tests {
    use super::*;

    const SECRET: &[u8] = b"0123456789abcdef";

    fn sign(body: &str) -> Vec<u8> {
        super::sign(body.as_bytes(), SECRET)
    }

    const BODY: &str = r#"{"beta":2.0,"classes":[{"name":"a","route":[{"alpha":1.0,"mu":0.5,"r":1.0,"s":2.0,"x":3.0,"y":4.0}],"share":1.0}],"extra":{},"gesture":"v","mu":0.0,"n_agents":10,"seq":1}"#;

    #[test]
    fn accepts_a_signed_command() {
        let cmd = decode(&sign(BODY), SECRET).unwrap();
        assert_eq!((cmd.seq, cmd.n_agents, cmd.gesture.as_str(), cmd.beta, cmd.mu), (1, 10, "v", 2.0, 0.0));
        let w = &cmd.classes[0].route[0];
        assert_eq!((w.x, w.y, w.r, w.s, w.alpha, w.beta, w.mu), (3.0, 4.0, 1.0, 2.0, 1.0, None, Some(0.5)));
        assert_eq!(verify(&sign(BODY), SECRET), Ok(BODY.as_bytes()));
    }

    #[test]
    fn rejects() {
        let mut forged = sign(BODY);
        forged[30] ^= 1;
        assert_eq!(decode(&forged, SECRET), Err(SIGNATURE));
        assert_eq!(decode(&sign(BODY), b"other"), Err(SIGNATURE));
        // the signature is checked before the body is read: a forged non-JSON body is a forgery
        let mut junk = sign("not json");
        junk[16] ^= 1;
        assert_eq!(decode(&junk, SECRET), Err(SIGNATURE));
        assert_eq!(decode(&sign("not json"), SECRET), Err(MALFORMED));
        // the same body with other whitespace under the original signature: a forgery, not the same command
        let spaced = BODY.replace(',', ", ");
        let forged = [V1, spaced.as_bytes(), SIG_KEY, &hmac_hex(SECRET, BODY.as_bytes()), TAIL_END].concat();
        assert_eq!(decode(&forged, SECRET), Err(SIGNATURE));
        assert!(decode(&sign(&spaced), SECRET).is_ok());
        assert_eq!(decode(b"{\"v\":2,\"body\":{},\"sig\":\"\"}", SECRET), Err(REJECT_VERSION));
        assert_eq!(decode(b"{\"v\":\"1\",\"body\":{}}", SECRET), Err(MALFORMED));
        assert_eq!(decode(b"{\"v\":1,\"body\":{}}", SECRET), Err(SIGNATURE));
        assert_eq!(decode(b"[", SECRET), Err(MALFORMED));
        assert_eq!(decode(&vec![b' '; MAX_BYTES + 1], SECRET), Err(MALFORMED));
        let deep = format!("{}{}", "[".repeat(10000), "]".repeat(10000));
        assert_eq!(decode(&sign(&deep), SECRET), Err(MALFORMED));
        // the body, extra, then d arrays: MAX_DEPTH deep at d = MAX_DEPTH - 2
        let at = |d: usize| {
            BODY.replacen("\"extra\":{}", &format!("\"extra\":{{\"d\":{}{}}}", "[".repeat(d), "]".repeat(d)), 1)
        };
        assert!(decode(&sign(&at(MAX_DEPTH - 2)), SECRET).is_ok());
        assert_eq!(decode(&sign(&at(MAX_DEPTH - 1)), SECRET), Err(MALFORMED));
    }

    #[test]
    fn fill_shape() {
        let with = |fill: &str| BODY.replacen("\"extra\":{}", &format!("\"extra\":{{}},\"fill\":{fill}"), 1);
        let body = with(r#"{"alpha":80,"rings":[[[0,0],[10.5,0.0],[12.3456,-1e-05]]],"s":0.2}"#);
        let cmd = decode(&sign(&body), SECRET).unwrap();
        let fill = cmd.fill.as_ref().unwrap();
        assert_eq!(fill.rings, vec![vec![(0.0, 0.0), (10.5, 0.0), (12.3456, -1e-05)]]);
        assert_eq!((fill.alpha, fill.s), (80.0, 0.2));
        assert!(decode(&sign(BODY), SECRET).unwrap().fill.is_none());
        for bad in [
            r#"{"alpha":80,"rings":[[[0,0],[1,1],[1,0],[0,1]]],"s":0.2}"#, // bow-tie
            r#"{"alpha":80,"rings":[[[0,0],[1,1]]],"s":0.2}"#,
            r#"{"alpha":80,"rings":[[[0,0],[1,1],[true,0]]],"s":0.2}"#,
            r#"{"alpha":80,"rings":[[[0,0],[1,1],[0,1,2]]],"s":0.2}"#,
            r#"{"alpha":80,"r":1,"rings":[[[0,0],[1,0],[0,1]]],"s":0.2}"#,
        ] {
            assert_eq!(decode(&sign(&with(bad)), SECRET), Err(MALFORMED), "{bad}");
        }
    }
}
