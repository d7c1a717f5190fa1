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

/// Run names become one key chunk: letters, digits, '-' and '_' only (agent/protocol/keys.py: valid_run_name).
pub fn valid_run_name(run: &str) -> bool {
    (1..=64).contains(&run.len()) && run.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
}

pub fn cell_of(x: f64, y: f64, cell: f64) -> (i64, i64) {
    ((x / cell).floor() as i64, (y / cell).floor() as i64)
}

/// The key an agent puts its states on under per-process rights: one exact key for its whole life, carrying
/// its id, so the router's access control lets each agent publish only its own states (the launcher's relay
/// puts them again on their cell's key: relay.rs).
pub fn state_key(run: &str, id: u32) -> String {
    format!("{PREFIX}/{run}/state/{}", id_chunk(id))
}

/// The key of the states of the agents in cell `c`, the id only in the record: what every agent hears on.
/// Put by the agents themselves without per-process rights, by the launcher's relay under them.
/// Where router `zid`'s relay sends its batches of the run's states for the observers (docs/protocol.md).
pub fn batch_key(run: &str, zid: &str) -> String {
    format!("{PREFIX}/{run}/batch/{zid}")
}

/// Where the relay hands agent `id` its neighbours' states, one message per step (relay/inboxes.rs): only the
/// router's session puts there (docs/security.md).
pub fn inbox_key(run: &str, id: u32) -> String {
    format!("{PREFIX}/{run}/inbox/{}", id_chunk(id))
}

/// Where agent `id` tells the relay the cells it hears (watch.rs), its own key like `state/<id>`.
pub fn watch_key(run: &str, id: u32) -> String {
    format!("{PREFIX}/{run}/watch/{}", id_chunk(id))
}

pub fn cell_key(run: &str, c: (i64, i64)) -> String {
    format!("{PREFIX}/{run}/state/{}/{}", c.0, c.1)
}

/// What follows `fluidswarm/<run>/<kind>/` in `key`, None for a key of another run or kind (the exact
/// parsers below take their chunks from it; no allocation: they run on every received message).
fn after_kind<'a>(run: &str, kind: &str, key: &'a str) -> Option<&'a str> {
    key.strip_prefix(PREFIX)?
        .strip_prefix('/')?
        .strip_prefix(run)?
        .strip_prefix('/')?
        .strip_prefix(kind)?
        .strip_prefix('/')
}

pub fn alive_key(run: &str, id: u32) -> String {
    format!("{PREFIX}/{run}/alive/{}", id_chunk(id))
}

pub fn ctl_expr(run: &str) -> String {
    format!("{PREFIX}/{run}/ctl/*")
}

/// The exact key of ctl message `what` (`clock`, `start`, ...)
pub fn ctl_key(run: &str, what: &str) -> String {
    format!("{PREFIX}/{run}/ctl/{what}")
}

/// `start`, `stop`, ... for exactly `fluidswarm/<run>/ctl/<what>`, else None: a wildcard key (`fluidswarm/**`)
/// reaches the ctl subscriber too, and only the launcher may put the exact keys (docs/security.md).
pub fn ctl_what<'a>(run: &str, key: &'a str) -> Option<&'a str> {
    let rest = after_kind(run, "ctl", key)?;
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

/// Squared distance from (x, y) to the closest point of cell `c` (0 inside it): compared with a squared
/// radius on every step, no square root.
pub fn cell_distance2(x: f64, y: f64, c: (i64, i64), cell: f64) -> f64 {
    let dx = (c.0 as f64 * cell - x).max(0.0).max(x - (c.0 + 1) as f64 * cell);
    let dy = (c.1 as f64 * cell - y).max(0.0).max(y - (c.1 + 1) as f64 * cell);
    dx * dx + dy * dy
}

/// Distance from (x, y) to the closest point of cell `c` (0 inside it).
pub fn cell_distance(x: f64, y: f64, c: (i64, i64), cell: f64) -> f64 {
    cell_distance2(x, y, c, cell).sqrt()
}

/// Cells of side `cell` that intersect the disc of `radius` around (x, y).
pub fn covering_cells(x: f64, y: f64, radius: f64, cell: f64) -> Vec<(i64, i64)> {
    let cx0 = ((x - radius) / cell).floor() as i64;
    let cx1 = ((x + radius) / cell).floor() as i64;
    let cy0 = ((y - radius) / cell).floor() as i64;
    let cy1 = ((y + radius) / cell).floor() as i64;
    let mut out = Vec::new();
    for cx in cx0..=cx1 {
        for cy in cy0..=cy1 {
            if cell_distance2(x, y, (cx, cy), cell) <= radius * radius {
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
        assert_eq!(state_key("r", 7), "fluidswarm/r/state/bdfgikmoqsuwy");
        assert_eq!(alive_key("r", 12), "fluidswarm/r/alive/acfhikmoqsuwy");
        assert_eq!(cell_key("r", (-1, 2)), "fluidswarm/r/state/-1/2");
        assert_eq!(inbox_key("r", 7), "fluidswarm/r/inbox/bdfgikmoqsuwy");
        assert_eq!(watch_key("r", 7), "fluidswarm/r/watch/bdfgikmoqsuwy");
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
