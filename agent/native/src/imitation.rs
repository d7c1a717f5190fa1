//! The records of an imitation between its launcher and its coordinator (docs/protocol.md "Imitation"),
//! encoded and decoded (validated) only here; agent/protocol/imitation.py calls them through agent._native.
//!
//! `plan` (launcher -> coordinator, `fluidswarm/<run>/imitation/plan`): the commands the launcher planned for
//! a file, each a signed command envelope (command.rs; the coordinator verifies it with the run's key), and
//! from which frame each holds:
//!   {"v": 1, "record": "plan", "frame_steps": <swarm steps a frame is shown; 0: one command>,
//!    "commands": [[<first frame>, "<envelope, hex>"], ...]}
//!
//! `note` (coordinator -> launcher, recorder, `fluidswarm/<run>/imitation/note`): what a camera's coordinator
//! saw, one note a message: {"v": 1, "record": "note", "note": <kind>, ...the kind's fields}
//!   subject      {"subject": "hand" | "person", "how": "given" | "auto", "frames": <with auto: frames read>}
//!   observation  the first command's observation, which the launcher places the swarm from: {"seq", "observed"
//!                (hand | body), "label", "index", "mask", "parts": {torso | left_arm | right_arm: mask},
//!                "picture": "<the frame as JPEG, hex>"}
//!   command      {"seq", "gesture", "why": "first" | "gesture" | "silhouette", "mask": its silhouette}
//!   missing      {"what": why nothing was commanded}
//!   end          {"frames": frames a video file had}
//! A mask is {"rows", "cols", "runs": [lengths of alternating runs, row-major, the first one of false pixels]}.

use serde_json::{json, Map, Value};

pub const VERSION: u64 = 1;
/// A note with a camera's picture and silhouettes is far below this (a 640 x 480 frame: ~0.1 MB of hex).
pub const MAX_BYTES: usize = 32 * 1024 * 1024;
pub const MAX_COMMANDS: usize = 4096;
pub const MAX_STEP: u64 = u32::MAX as u64;
pub const MAX_SIDE: u64 = 20_000;
pub const MAX_PIXELS: u64 = 1 << 26;
pub const MAX_TEXT: usize = 2048;
/// The JPEG of one frame, at most.
pub const MAX_PICTURE: usize = 8 * 1024 * 1024;
pub const PARTS: [&str; 3] = ["torso", "left_arm", "right_arm"];

#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    pub rows: u32,
    pub cols: u32,
    pub runs: Vec<u32>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub frame_steps: u32,
    pub commands: Vec<(u32, Vec<u8>)>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Note {
    Subject {
        subject: String,
        how: String,
        frames: Option<u32>,
    },
    Observation {
        seq: u32,
        observed: String,
        label: String,
        index: u32,
        mask: Mask,
        parts: Vec<(String, Mask)>,
        picture: Vec<u8>,
    },
    Command {
        seq: u32,
        gesture: String,
        why: String,
        mask: Mask,
    },
    Missing {
        what: String,
    },
    End {
        frames: u32,
    },
}

fn hex(data: &[u8]) -> String {
    data.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(text: &str, max: usize) -> Option<Vec<u8>> {
    let b = text.as_bytes();
    if !b.len().is_multiple_of(2) || b.len() / 2 > max {
        return None;
    }
    let digit = |c: u8| match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'a'..=b'f' => Some(c - b'a' + 10),
        _ => None,
    };
    b.chunks(2).map(|p| Some(digit(p[0])? << 4 | digit(p[1])?)).collect()
}

/// An integer (not a bool, not written as a float) in [lo, hi].
fn integer(v: &Value, lo: u64, hi: u64) -> Option<u32> {
    v.as_u64().filter(|x| (lo..=hi).contains(x)).map(|x| x as u32)
}

/// A string of at most MAX_TEXT bytes (a label or gesture may be empty: perception names what it can).
fn text(v: &Value) -> Option<String> {
    v.as_str().filter(|s| s.len() <= MAX_TEXT).map(str::to_owned)
}

fn one_of(v: &Value, names: &[&str]) -> Option<String> {
    v.as_str().filter(|s| names.contains(s)).map(str::to_owned)
}

impl Mask {
    fn to_json(&self) -> Value {
        json!({"rows": self.rows, "cols": self.cols, "runs": self.runs})
    }

    fn decode(v: &Value) -> Option<Mask> {
        let m = v.as_object()?;
        if m.len() != 3 {
            return None;
        }
        let rows = integer(m.get("rows")?, 1, MAX_SIDE)?;
        let cols = integer(m.get("cols")?, 1, MAX_SIDE)?;
        let pixels = rows as u64 * cols as u64;
        let items = m.get("runs")?.as_array().filter(|r| (r.len() as u64) <= pixels + 1 && pixels <= MAX_PIXELS)?;
        let runs: Vec<u32> = items.iter().map(|r| integer(r, 0, pixels)).collect::<Option<_>>()?;
        // every pixel once; a run of length 0 only first (an image that starts with a true pixel)
        let whole = runs.iter().map(|&r| r as u64).sum::<u64>() == pixels;
        (whole && runs.iter().skip(1).all(|&r| r > 0)).then_some(Mask { rows, cols, runs })
    }
}

/// The JSON object in `data`, of version 1 and record `record` (its other fields unchecked).
fn checked(data: &[u8], record: &str) -> Option<Map<String, Value>> {
    if data.len() > MAX_BYTES {
        return None;
    }
    let msg: Map<String, Value> = serde_json::from_slice(data).ok()?;
    if msg.get("v").and_then(Value::as_u64) != Some(VERSION) || msg.get("record")?.as_str()? != record {
        return None;
    }
    Some(msg)
}

/// Every key of `msg` known (v, record, note, `fields`, `optional`) and every one of `fields` there.
fn exact_keys(msg: &Map<String, Value>, fields: &[&str], optional: &[&str]) -> bool {
    let base = ["v", "record", "note"];
    msg.keys().all(|k| base.contains(&k.as_str()) || fields.contains(&k.as_str()) || optional.contains(&k.as_str()))
        && fields.iter().all(|k| msg.contains_key(*k))
}

impl Plan {
    pub fn to_json(&self) -> Value {
        let commands: Vec<Value> = self.commands.iter().map(|(first, env)| json!([first, hex(env)])).collect();
        json!({"v": VERSION, "record": "plan", "frame_steps": self.frame_steps, "commands": commands})
    }

    pub fn encode(&self) -> String {
        self.to_json().to_string()
    }
}

/// The plan in `data` (JSON in UTF-8), None if anything in it is malformed: another version, an unknown or
/// missing field, no command or more than MAX_COMMANDS, first frames not 0 and then rising, more than one
/// command with frame_steps 0, an envelope that is not lowercase hex of at most command::MAX_BYTES bytes.
/// (The envelopes' signatures and bodies are the coordinator's to check, with the run's key: command.rs.)
pub fn decode_plan(data: &[u8]) -> Option<Plan> {
    let msg = checked(data, "plan")?;
    if !msg.keys().all(|k| ["v", "record", "frame_steps", "commands"].contains(&k.as_str())) {
        return None;
    }
    let frame_steps = integer(msg.get("frame_steps")?, 0, MAX_STEP)?;
    let items = msg.get("commands")?.as_array().filter(|c| !c.is_empty() && c.len() <= MAX_COMMANDS)?;
    let mut commands = Vec::with_capacity(items.len());
    for item in items {
        match item.as_array()?.as_slice() {
            [first, env] => {
                let first = integer(first, 0, MAX_STEP)?;
                let rising = commands.last().map_or(first == 0, |(prev, _): &(u32, Vec<u8>)| first > *prev);
                let env = unhex(env.as_str()?, crate::command::MAX_BYTES).filter(|e| !e.is_empty())?;
                if !rising {
                    return None;
                }
                commands.push((first, env));
            }
            _ => return None,
        }
    }
    (frame_steps > 0 || commands.len() == 1).then_some(Plan { frame_steps, commands })
}

impl Note {
    pub fn name(&self) -> &'static str {
        match self {
            Note::Subject { .. } => "subject",
            Note::Observation { .. } => "observation",
            Note::Command { .. } => "command",
            Note::Missing { .. } => "missing",
            Note::End { .. } => "end",
        }
    }

    pub fn to_json(&self) -> Value {
        let mut m = Map::new();
        m.insert("v".into(), json!(VERSION));
        m.insert("record".into(), json!("note"));
        m.insert("note".into(), json!(self.name()));
        match self {
            Note::Subject { subject, how, frames } => {
                m.insert("subject".into(), json!(subject));
                m.insert("how".into(), json!(how));
                if let Some(f) = frames {
                    m.insert("frames".into(), json!(f));
                }
            }
            Note::Observation { seq, observed, label, index, mask, parts, picture } => {
                m.insert("seq".into(), json!(seq));
                m.insert("observed".into(), json!(observed));
                m.insert("label".into(), json!(label));
                m.insert("index".into(), json!(index));
                m.insert("mask".into(), mask.to_json());
                let p: Map<String, Value> = parts.iter().map(|(k, v)| (k.clone(), v.to_json())).collect();
                m.insert("parts".into(), Value::Object(p));
                m.insert("picture".into(), json!(hex(picture)));
            }
            Note::Command { seq, gesture, why, mask } => {
                m.insert("seq".into(), json!(seq));
                m.insert("gesture".into(), json!(gesture));
                m.insert("why".into(), json!(why));
                m.insert("mask".into(), mask.to_json());
            }
            Note::Missing { what } => {
                m.insert("what".into(), json!(what));
            }
            Note::End { frames } => {
                m.insert("frames".into(), json!(frames));
            }
        }
        Value::Object(m)
    }

    pub fn encode(&self) -> String {
        self.to_json().to_string()
    }
}

fn parts_of(v: &Value, rows: u32, cols: u32) -> Option<Vec<(String, Mask)>> {
    let m = v.as_object()?;
    let mut out = Vec::with_capacity(m.len());
    for (name, mask) in m {
        let mask = Mask::decode(mask).filter(|p| p.rows == rows && p.cols == cols)?;
        if !PARTS.contains(&name.as_str()) {
            return None;
        }
        out.push((name.clone(), mask));
    }
    Some(out)
}

/// The note in `data` (JSON in UTF-8), None if anything in it is malformed: another version or record, an
/// unknown kind or field, a missing one, a value of the wrong type or out of range, a mask whose runs do not
/// cover its pixels exactly, a part of another size than its silhouette, a picture that is not a JPEG's hex.
pub fn decode_note(data: &[u8]) -> Option<Note> {
    let msg = checked(data, "note")?;
    let kind = msg.get("note")?.as_str()?;
    let (fields, optional): (&[&str], &[&str]) = match kind {
        "subject" => (&["subject", "how"], &["frames"]),
        "observation" => (&["seq", "observed", "label", "index", "mask", "parts", "picture"], &[]),
        "command" => (&["seq", "gesture", "why", "mask"], &[]),
        "missing" => (&["what"], &[]),
        "end" => (&["frames"], &[]),
        _ => return None,
    };
    if !exact_keys(&msg, fields, optional) {
        return None;
    }
    let f = |k: &str| &msg[k];
    Some(match kind {
        "subject" => {
            let how = one_of(f("how"), &["given", "auto"])?;
            let frames = msg.get("frames").map(|v| integer(v, 1, MAX_STEP)).map_or(Some(None), |x| x.map(Some))?;
            if frames.is_some() != (how == "auto") {
                return None;
            }
            Note::Subject { subject: one_of(f("subject"), &["hand", "person"])?, how, frames }
        }
        "observation" => {
            let mask = Mask::decode(f("mask"))?;
            let picture = unhex(f("picture").as_str()?, MAX_PICTURE).filter(|p| p.starts_with(&[0xff, 0xd8]))?;
            Note::Observation {
                seq: integer(f("seq"), 1, MAX_STEP)?,
                observed: one_of(f("observed"), &["hand", "body"])?,
                label: text(f("label"))?,
                index: integer(f("index"), 0, MAX_STEP)?,
                parts: parts_of(f("parts"), mask.rows, mask.cols)?,
                mask,
                picture,
            }
        }
        "command" => Note::Command {
            seq: integer(f("seq"), 1, MAX_STEP)?,
            gesture: text(f("gesture"))?,
            why: one_of(f("why"), &["first", "gesture", "silhouette"])?,
            mask: Mask::decode(f("mask"))?,
        },
        "missing" => Note::Missing { what: text(f("what")).filter(|w| !w.is_empty())? },
        _ => Note::End { frames: integer(f("frames"), 0, MAX_STEP)? },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mask_covers_its_pixels_exactly() {
        let ok = json!({"rows": 2, "cols": 2, "runs": [0, 3, 1]});
        assert!(Mask::decode(&ok).is_some());
        for bad in [
            json!({"rows": 2, "cols": 2, "runs": [1, 2]}),
            json!({"rows": 2, "cols": 2, "runs": [1, 0, 3]}),
            json!({"rows": 0, "cols": 2, "runs": []}),
            json!({"rows": 2, "cols": 2, "runs": [4], "x": 1}),
        ] {
            assert!(Mask::decode(&bad).is_none(), "{bad}");
        }
    }

    #[test]
    fn hex_round_trips_and_refuses_upper_case() {
        assert_eq!(unhex(&hex(&[0, 1, 0xab, 0xff]), 4), Some(vec![0, 1, 0xab, 0xff]));
        assert_eq!(unhex("AB", 4), None);
        assert_eq!(unhex("abc", 4), None);
        assert_eq!(unhex("abcd", 1), None);
    }
}
