//! The launcher's control messages (`ctl/<what>`, docs/protocol.md "Control messages"): the same records as
//! agent/protocol/ctl.py, decoded (and, for the shared vectors, encoded) only here.
//!
//! Payload: version (u8, 1), kind (u8: start 1, stop 2, clock 3, end 4, gone 5), then little-endian the
//! kind's body: clock and end a step (u64), gone an agent id (u32), start and stop nothing. The kind in the
//! payload must be the key's.

pub const VERSION: u8 = 1;
/// Steps are u32 in the state record; an agent id is below 2^31 (spec, report).
pub const MAX_STEP: u64 = u32::MAX as u64;
pub const MAX_AGENT: u32 = (1u32 << 31) - 1;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ctl {
    /// every waiting agent steps from now
    Start,
    /// every agent stops and reports `stopped`
    Stop,
    /// the pacing clock: the slowest live agent's step
    Clock(u64),
    /// every agent finishes at this step (or its own last one, if earlier)
    End(u64),
    /// this agent lost its liveliness
    Gone(u32),
}

impl Ctl {
    fn code(&self) -> u8 {
        match self {
            Ctl::Start => 1,
            Ctl::Stop => 2,
            Ctl::Clock(_) => 3,
            Ctl::End(_) => 4,
            Ctl::Gone(_) => 5,
        }
    }

    /// The key's last chunk: `ctl/<what>`.
    pub fn what(&self) -> &'static str {
        match self {
            Ctl::Start => "start",
            Ctl::Stop => "stop",
            Ctl::Clock(_) => "clock",
            Ctl::End(_) => "end",
            Ctl::Gone(_) => "gone",
        }
    }
}

pub fn encode(msg: &Ctl) -> Vec<u8> {
    let mut out = vec![VERSION, msg.code()];
    match *msg {
        Ctl::Clock(step) | Ctl::End(step) => out.extend_from_slice(&step.to_le_bytes()),
        Ctl::Gone(id) => out.extend_from_slice(&id.to_le_bytes()),
        Ctl::Start | Ctl::Stop => {}
    }
    out
}

/// The message of `payload` received on `ctl/<what>`, None if anything in it is malformed (another version,
/// a kind that is not the key's, a wrong length, a value out of range).
pub fn decode(what: Option<&str>, payload: &[u8]) -> Option<Ctl> {
    if payload.len() < 2 || payload[0] != VERSION {
        return None;
    }
    let (code, body) = (payload[1], &payload[2..]);
    let msg = match (code, body.len()) {
        (1, 0) => Ctl::Start,
        (2, 0) => Ctl::Stop,
        (3 | 4, 8) => {
            let step = u64::from_le_bytes(body.try_into().ok()?);
            if step > MAX_STEP {
                return None;
            }
            if code == 3 {
                Ctl::Clock(step)
            } else {
                Ctl::End(step)
            }
        }
        (5, 4) => {
            let id = u32::from_le_bytes(body.try_into().ok()?);
            if id > MAX_AGENT {
                return None;
            }
            Ctl::Gone(id)
        }
        _ => return None,
    };
    (what == Some(msg.what())).then_some(msg)
}
