//! Binary state record exchanged between agents (wire format v2): a port of agent/protocol/wire.py.
//!
//! Layout, little-endian, 104 bytes (docs/protocol.md):
//!
//! ```text
//! offset  type     field
//! 0       u8       version (= 2)
//! 1       u8       kind (= 1, state)
//! 2       u16      flags (bit 0: frozen, the particle left the domain)
//! 4       u32      agent id
//! 8       u32      step
//! 12      u16      particle class (from the gesture command; 0 if none)
//! 14      u16      reserved (0)
//! 16      9 x f64  x, y, vx, vy, rho, p, sxx, sxy, syy
//! 88      f64      heading [rad] in [-pi, pi] (a unicycle's; 0 otherwise)
//! 96      f64      forward speed [m/s] (a unicycle's; 0 otherwise)
//! ```
//!
//! Records come from the network and are untrusted: `decode_state` checks them in the order wire.py does,
//! so both implementations count the same rejection reason for the same bytes. The version byte first: a v1
//! record (88 bytes, no pose) is refused as "version", whatever its length.

use std::f64::consts::PI;

use crate::sph::{FROZEN, HEADING, NFIELDS, RHO, SPEED};

pub const VERSION: u8 = 2;
pub const KIND_STATE: u8 = 1;
pub const STATE_SIZE: usize = 104;
pub const MAX_ID: u32 = (1 << 31) - 1;
/// Larger magnitudes are garbage, not physics.
pub const MAX_ABS: f64 = 1e12;

pub const REJECT_LENGTH: &str = "length";
pub const REJECT_VERSION: &str = "version";
pub const REJECT_VALUE: &str = "value";

const FLOATS_AT: usize = 16;
/// Where the wire's 11 floats go in the state: the 9 SPH values, then heading and speed (FROZEN is in flags).
const WIRE_FIELDS: [usize; 11] = [0, 1, 2, 3, 4, 5, 6, 7, 8, HEADING, SPEED];

/// A decoded record: `values` is the full state, its FROZEN field 0.0/1.0 from flags bit 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StateRecord {
    pub id: u32,
    pub step: u32,
    pub class: u16,
    pub values: [f64; NFIELDS],
}

pub fn encode_state(id: u32, step: u32, state: &[f64; NFIELDS], class: u16) -> [u8; STATE_SIZE] {
    let mut out = [0u8; STATE_SIZE];
    let flags: u16 = if state[FROZEN] != 0.0 { 1 } else { 0 };
    out[0] = VERSION;
    out[1] = KIND_STATE;
    out[2..4].copy_from_slice(&flags.to_le_bytes());
    out[4..8].copy_from_slice(&id.to_le_bytes());
    out[8..12].copy_from_slice(&step.to_le_bytes());
    out[12..14].copy_from_slice(&class.to_le_bytes());
    // 14..16 reserved, left 0
    for (k, &field) in WIRE_FIELDS.iter().enumerate() {
        let at = FLOATS_AT + 8 * k;
        out[at..at + 8].copy_from_slice(&state[field].to_le_bytes());
    }
    out
}

fn u16_at(data: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([data[at], data[at + 1]])
}

fn u32_at(data: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([data[at], data[at + 1], data[at + 2], data[at + 3]])
}

fn f64_at(data: &[u8], at: usize) -> f64 {
    f64::from_le_bytes(data[at..at + 8].try_into().expect("8 bytes"))
}

/// The checks of a state record's header, in the order receivers name them: version, length, kind (a wrong kind
/// byte is rejected as `version`, as decode_state always did).
fn check_state_header(data: &[u8]) -> Result<(), &'static str> {
    if data.first() != Some(&VERSION) {
        return Err(REJECT_VERSION);
    }
    if data.len() != STATE_SIZE {
        return Err(REJECT_LENGTH);
    }
    if data[1] != KIND_STATE {
        return Err(REJECT_VERSION);
    }
    Ok(())
}

pub fn decode_state(data: &[u8]) -> Result<StateRecord, &'static str> {
    check_state_header(data)?;
    let flags = u16_at(data, 2);
    let id = u32_at(data, 4);
    if id > MAX_ID || flags > 1 {
        return Err(REJECT_VALUE);
    }
    let mut values = [0.0; NFIELDS];
    for (k, &field) in WIRE_FIELDS.iter().enumerate() {
        let v = f64_at(data, FLOATS_AT + 8 * k);
        // Written as a negated range test so NaN fails it too, as in Python.
        if !(-MAX_ABS..=MAX_ABS).contains(&v) {
            return Err(REJECT_VALUE);
        }
        values[field] = v;
    }
    if values[RHO] <= 0.0 {
        return Err(REJECT_VALUE); // a density must be positive
    }
    if !(-PI..=PI).contains(&values[HEADING]) {
        return Err(REJECT_VALUE); // a heading is an angle in [-pi, pi]
    }
    values[FROZEN] = f64::from(flags);
    Ok(StateRecord { id, step: u32_at(data, 8), class: u16_at(data, 12), values })
}

/// The sender's id and step, unvalidated: a cheap hint for a receiver before it decodes (the agent's inbox,
/// shell/inbox.rs; the launcher's pacing, swarmhost/pacing.py, through agent/protocol/wire.py).
pub fn peek_id_step(data: &[u8]) -> Option<(u32, u32)> {
    (data.len() == STATE_SIZE).then(|| (u32_at(data, 4), u32_at(data, 8)))
}

/// (id, x, y) of a state record for routing it by position (the router's relay), or the reason decode_state
/// gives for its header and position (agent/protocol/wire.py: peek_id_position). Receivers decode it in full.
pub fn peek_id_position(data: &[u8]) -> Result<(u32, f64, f64), &'static str> {
    check_state_header(data)?;
    let (x, y) = (f64_at(data, FLOATS_AT), f64_at(data, FLOATS_AT + 8));
    if !(-MAX_ABS..=MAX_ABS).contains(&x) || !(-MAX_ABS..=MAX_ABS).contains(&y) {
        return Err(REJECT_VALUE); // also NaN and infinities
    }
    Ok((u32_at(data, 4), x, y))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state() -> [f64; NFIELDS] {
        [1.5, -2.0, 0.25, 0.0, 0.85, 3.0, 0.1, -0.2, 0.3, 0.0, -1.25, 0.5]
    }

    #[test]
    fn round_trip() {
        let mut s = state();
        let rec = decode_state(&encode_state(7, 42, &s, 3)).unwrap();
        assert_eq!(rec, StateRecord { id: 7, step: 42, class: 3, values: s });
        s[FROZEN] = 1.0;
        assert_eq!(decode_state(&encode_state(7, 42, &s, 0)).unwrap().values[FROZEN], 1.0);
        assert_eq!(peek_id_step(&encode_state(7, 42, &s, 0)), Some((7, 42)));
        assert_eq!(peek_id_step(&[0; 103]), None);
    }

    #[test]
    fn rejects() {
        let good = encode_state(1, 2, &state(), 0);
        assert_eq!(decode_state(&good[..87]), Err("length"));
        let mut b = good;
        b[0] = 1;
        assert_eq!(decode_state(&b[..88]), Err("version")); // a v1 record
        assert_eq!(decode_state(&[]), Err("version"));
        let mut b = good;
        b[0] = 3;
        assert_eq!(decode_state(&b), Err("version"));
        let mut s = state();
        s[HEADING] = 3.2;
        assert_eq!(decode_state(&encode_state(1, 2, &s, 0)), Err("value"));
        let mut b = good;
        b[2] = 2;
        assert_eq!(decode_state(&b), Err("value"));
        let mut s = state();
        s[RHO] = 0.0;
        assert_eq!(decode_state(&encode_state(1, 2, &s, 0)), Err("value"));
        s[RHO] = f64::NAN;
        assert_eq!(decode_state(&encode_state(1, 2, &s, 0)), Err("value"));
        assert_eq!(decode_state(&encode_state(MAX_ID + 1, 2, &state(), 0)), Err("value"));
    }
}
