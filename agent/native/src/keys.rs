//! Zenoh key expressions of a run (protocol v1): the same strings as agent/protocol/keys.py, documented in
//! docs/protocol.md.

pub const PREFIX: &str = "fluidswarm";
/// An id in a key is ID_BITS letters, bit k as one of two letters of position k only ('a'/'b' bit 0, 'c'/'d'
/// bit 1, ... 'y'/'z' bit 12), so the router's access control forbids an agent every other id's keys with
/// ID_BITS patterns (agent/protocol/keys.py, docs/security.md).
pub const ID_BITS: u32 = 13;
pub const MAX_AGENTS: u32 = 1 << ID_BITS;

/// The key chunk of agent `id` (agent/protocol/keys.py: id_chunk). An id from MAX_AGENTS up has no key: it
/// is written in decimal, which no receiver takes for an id (the launcher starts no such agent).
pub fn id_chunk(id: u32) -> String {
    if id >= MAX_AGENTS {
        return id.to_string();
    }
    (0..ID_BITS).map(|k| (b'a' + 2 * k as u8 + ((id >> k) & 1) as u8) as char).collect()
}

/// The id an id chunk writes, None for anything else (a wildcard, a partial or foreign chunk).
pub fn id_of_chunk(chunk: &str) -> Option<u32> {
    let bytes = chunk.as_bytes();
    if bytes.len() != ID_BITS as usize {
        return None;
    }
    let mut id = 0u32;
    for (k, &b) in bytes.iter().enumerate() {
        let bit = b.wrapping_sub(b'a').wrapping_sub(2 * k as u8);
        if bit > 1 {
            return None;
        }
        id |= (bit as u32) << k;
    }
    Some(id)
}

pub fn cell_of(x: f64, y: f64, cell: f64) -> (i64, i64) {
    ((x / cell).floor() as i64, (y / cell).floor() as i64)
}

/// The key of a state published in cell `c`. With `Some(id)` (access level `acl`) the agent's id is the last
/// chunk, so the router's access control lets each agent publish only its own states (docs/security.md);
/// with None one exact key per cell, id only in the record, which zenoh dispatches by a table look-up
/// (docs/benchmarks/native.md, security.md: the id in the key costs 31-42 % of the steps/s).
pub fn state_key(run: &str, c: (i64, i64), id: Option<u32>) -> String {
    match id {
        Some(id) => format!("{PREFIX}/{run}/state/{}/{}/{}", c.0, c.1, id_chunk(id)),
        None => format!("{PREFIX}/{run}/state/{}/{}", c.0, c.1),
    }
}

/// What an agent subscribes to for each cell it watches: every agent's key in it, or the cell's one key.
pub fn cell_expr(run: &str, c: (i64, i64), ids: bool) -> String {
    if ids {
        format!("{PREFIX}/{run}/state/{}/{}/*", c.0, c.1)
    } else {
        state_key(run, c, None)
    }
}

/// The sender id of a state key (`…/state/<cx>/<cy>/<id>`), None for a cell key (`…/state/<cx>/<cy>`)
/// or anything else.
pub fn state_sender(key: &str) -> Option<u32> {
    // On every received state: no allocation, one pass over the chunks.
    let (mut n, mut state) = (0, false);
    for (k, chunk) in key.split('/').enumerate() {
        n = k + 1;
        state |= k == 2 && chunk == "state";
    }
    if n == 6 && state {
        id_from_key(key)
    } else {
        None
    }
}

pub fn alive_key(run: &str, id: u32) -> String {
    format!("{PREFIX}/{run}/alive/{}", id_chunk(id))
}

pub fn ctl_expr(run: &str) -> String {
    format!("{PREFIX}/{run}/ctl/*")
}

/// `start`, `stop`, ... for exactly `fluidswarm/<run>/ctl/<what>`, else None: a wildcard key (`fluidswarm/**`)
/// reaches the ctl subscriber too, and only the launcher may put the exact keys (docs/security.md).
pub fn ctl_what<'a>(run: &str, key: &'a str) -> Option<&'a str> {
    let rest = key.strip_prefix(PREFIX)?.strip_prefix('/')?.strip_prefix(run)?.strip_prefix("/ctl/")?;
    (!rest.is_empty() && rest.len() <= 16 && rest.bytes().all(|b| b.is_ascii_lowercase())).then_some(rest)
}

pub fn final_key(run: &str, id: u32) -> String {
    format!("{PREFIX}/{run}/final/{}", id_chunk(id))
}

pub fn event_key(run: &str, id: u32) -> String {
    format!("{PREFIX}/{run}/event/{}", id_chunk(id))
}

pub fn command_key(run: &str) -> String {
    format!("{PREFIX}/{run}/command")
}

/// The agent id the last chunk of a key writes (agent/protocol/keys.py: id_from_key), or None.
pub fn id_from_key(key: &str) -> Option<u32> {
    id_of_chunk(key.rsplit('/').next()?)
}

/// Cells of side `cell` that intersect the disc of `radius` around (x, y) (agent/process.py:
/// covering_cells): the cells an agent subscribes to.
pub fn covering_cells(x: f64, y: f64, radius: f64, cell: f64) -> Vec<(i64, i64)> {
    let cx0 = ((x - radius) / cell).floor() as i64;
    let cx1 = ((x + radius) / cell).floor() as i64;
    let cy0 = ((y - radius) / cell).floor() as i64;
    let cy1 = ((y + radius) / cell).floor() as i64;
    let mut out = Vec::new();
    for cx in cx0..=cx1 {
        let dx = (cx as f64 * cell - x).max(0.0).max(x - (cx + 1) as f64 * cell);
        for cy in cy0..=cy1 {
            let dy = (cy as f64 * cell - y).max(0.0).max(y - (cy + 1) as f64 * cell);
            if dx * dx + dy * dy <= radius * radius {
                out.push((cx, cy));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_match_the_python_ones() {
        assert_eq!(id_chunk(0), "acegikmoqsuwy");
        assert_eq!(id_chunk(5), "bcfgikmoqsuwy");
        assert_eq!(state_key("r", (-1, 2), Some(7)), "fluidswarm/r/state/-1/2/bdfgikmoqsuwy");
        assert_eq!(state_key("r", (-1, 2), None), "fluidswarm/r/state/-1/2");
        assert_eq!(alive_key("r", 12), "fluidswarm/r/alive/acfhikmoqsuwy");
        assert_eq!(cell_expr("r", (-1, 2), true), "fluidswarm/r/state/-1/2/*");
        assert_eq!(cell_expr("r", (-1, 2), false), "fluidswarm/r/state/-1/2");
        assert_eq!(state_sender(&state_key("r", (-1, 2), Some(7))), Some(7));
        assert_eq!(state_sender(&state_key("r", (-1, 2), None)), None);
        assert_eq!(state_sender("fluidswarm/r/state/-1/2/*"), None);
        assert_eq!(state_sender(&final_key("r", 7)), None);
        assert_eq!(id_from_key(&alive_key("r", 12)), Some(12));
        assert_eq!(id_from_key("fluidswarm/r/alive/12"), None);
        assert_eq!(id_from_key("fluidswarm/r/alive/acegikmoqsuwz"), Some(4096));
        assert_eq!(id_from_key("fluidswarm/r/alive/acegikmoqsuwa"), None);
        assert_eq!(id_from_key("fluidswarm/r/alive/acegikmoqsuw*"), None);
        assert!((0..MAX_AGENTS).all(|i| id_of_chunk(&id_chunk(i)) == Some(i)));
        assert_eq!(id_from_key(&event_key("r", MAX_AGENTS)), None);
        assert_eq!(ctl_what("r", "fluidswarm/r/ctl/stop"), Some("stop"));
        assert_eq!(ctl_what("r", "fluidswarm/r/ctl/*"), None);
        assert_eq!(ctl_what("r", "fluidswarm/**"), None);
        assert_eq!(ctl_what("r", "fluidswarm/rr/ctl/stop"), None);
        assert_eq!(cell_of(-0.5, 1.5, 1.0), (-1, 1));
    }

    #[test]
    fn covering_cells_is_a_disc() {
        let cells = covering_cells(0.5, 0.5, 1.0, 1.0);
        assert_eq!(cells.len(), 9);
    }
}
