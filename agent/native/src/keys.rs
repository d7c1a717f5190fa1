//! Zenoh key expressions of a run (protocol v1): the same strings as agent/protocol/keys.py, documented in
//! docs/protocol.md.

pub const PREFIX: &str = "fluidswarm";

pub fn cell_of(x: f64, y: f64, cell: f64) -> (i64, i64) {
    ((x / cell).floor() as i64, (y / cell).floor() as i64)
}

/// The key of a state published in cell `c`. With `Some(id)` (access level `acl`) the agent's id is the last
/// chunk, so the router's access control lets each agent publish only its own states (docs/security.md);
/// with None one exact key per cell, id only in the record, which zenoh dispatches by a table look-up
/// (docs/benchmarks/native.md, security.md: the id in the key costs 31-42 % of the steps/s).
pub fn state_key(run: &str, c: (i64, i64), id: Option<u32>) -> String {
    match id {
        Some(id) => format!("{PREFIX}/{run}/state/{}/{}/{id}", c.0, c.1),
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
    format!("{PREFIX}/{run}/alive/{id}")
}

pub fn ctl_expr(run: &str) -> String {
    format!("{PREFIX}/{run}/ctl/*")
}

pub fn final_key(run: &str, id: u32) -> String {
    format!("{PREFIX}/{run}/final/{id}")
}

pub fn event_key(run: &str, id: u32) -> String {
    format!("{PREFIX}/{run}/event/{id}")
}

pub fn command_key(run: &str) -> String {
    format!("{PREFIX}/{run}/command")
}

/// The agent id in the last chunk of a key (agent/protocol/keys.py: id_from_key): decimal digits, fewer than 10.
pub fn id_from_key(key: &str) -> Option<u32> {
    let last = key.rsplit('/').next()?;
    if !last.is_empty() && last.len() < 10 && last.bytes().all(|b| b.is_ascii_digit()) {
        last.parse().ok()
    } else {
        None
    }
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
        assert_eq!(state_key("r", (-1, 2), Some(7)), "fluidswarm/r/state/-1/2/7");
        assert_eq!(state_key("r", (-1, 2), None), "fluidswarm/r/state/-1/2");
        assert_eq!(cell_expr("r", (-1, 2), true), "fluidswarm/r/state/-1/2/*");
        assert_eq!(cell_expr("r", (-1, 2), false), "fluidswarm/r/state/-1/2");
        assert_eq!(state_sender(&state_key("r", (-1, 2), Some(7))), Some(7));
        assert_eq!(state_sender(&state_key("r", (-1, 2), None)), None);
        assert_eq!(state_sender("fluidswarm/r/final/7"), None);
        assert_eq!(id_from_key("fluidswarm/r/alive/12"), Some(12));
        assert_eq!(id_from_key("fluidswarm/r/alive/x1"), None);
        assert_eq!(id_from_key("fluidswarm/r/alive/1234567890"), None);
        assert_eq!(cell_of(-0.5, 1.5, 1.0), (-1, 1));
    }

    #[test]
    fn covering_cells_is_a_disc() {
        let cells = covering_cells(0.5, 0.5, 1.0, 1.0);
        assert_eq!(cells.len(), 9);
    }
}
