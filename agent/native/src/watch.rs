//! The watch record (v1): the cells an agent hears, sent by the agent to its router's relay on its own key
//! `watch/<id>` whenever the set changes, when the relay hands it its neighbours' states in one message per
//! step on `inbox/<id>` (relay/inboxes.rs, docs/protocol.md "Inboxes"). It replaces the agent's cell
//! subscriptions: the set is what the core's Subscribe/Unsubscribe actions say, so the agent still hears
//! exactly the states its cell subscriptions would give it. Agent and router are both this crate: one
//! implementation.
//!
//! Layout, little-endian:
//!
//! ```text
//! offset  type      field
//! 0       u8        version (= 1)
//! 1       u8        kind (= 2, watch)
//! 2       u16       n, the number of cells (at most MAX_CELLS)
//! 4       n x (i64, i64)   the cells (cx, cy), each once
//! ```

pub const VERSION: u8 = 1;
pub const KIND_WATCH: u8 = 2;
/// More cells than any R_keep covers (R_keep / h ~ 3 gives ~37); a longer list is garbage.
pub const MAX_CELLS: usize = 1024;
const HEADER: usize = 4;
const CELL_SIZE: usize = 16;

pub fn encode_watch(cells: &[(i64, i64)]) -> Vec<u8> {
    let n = cells.len().min(MAX_CELLS);
    let mut out = Vec::with_capacity(HEADER + CELL_SIZE * n);
    out.extend_from_slice(&[VERSION, KIND_WATCH]);
    out.extend_from_slice(&(n as u16).to_le_bytes());
    for &(cx, cy) in &cells[..n] {
        out.extend_from_slice(&cx.to_le_bytes());
        out.extend_from_slice(&cy.to_le_bytes());
    }
    out
}

/// The cells of a watch record from the network, or the reason it is refused (the names wire.rs uses).
pub fn decode_watch(data: &[u8]) -> Result<Vec<(i64, i64)>, &'static str> {
    if data.first() != Some(&VERSION) || data.get(1) != Some(&KIND_WATCH) {
        return Err(crate::wire::REJECT_VERSION);
    }
    if data.len() < HEADER {
        return Err(crate::wire::REJECT_LENGTH);
    }
    let n = u16::from_le_bytes([data[2], data[3]]) as usize;
    if n > MAX_CELLS || data.len() != HEADER + CELL_SIZE * n {
        return Err(crate::wire::REJECT_LENGTH);
    }
    let at = |k: usize| i64::from_le_bytes(data[k..k + 8].try_into().expect("8 bytes"));
    let mut cells: Vec<(i64, i64)> =
        (0..n).map(|k| (at(HEADER + CELL_SIZE * k), at(HEADER + CELL_SIZE * k + 8))).collect();
    cells.sort_unstable();
    cells.dedup();
    if cells.len() != n {
        return Err(crate::wire::REJECT_VALUE); // a cell twice
    }
    Ok(cells)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_rejects() {
        let cells = vec![(-1, 2), (0, 0), (i64::MAX, i64::MIN)];
        let rec = encode_watch(&cells);
        assert_eq!(rec.len(), 4 + 16 * 3);
        let mut back = decode_watch(&rec).unwrap();
        back.sort_unstable();
        let mut want = cells.clone();
        want.sort_unstable();
        assert_eq!(back, want);
        assert_eq!(decode_watch(&encode_watch(&[])).unwrap(), vec![]);
        assert_eq!(decode_watch(&rec[..rec.len() - 1]), Err("length"));
        assert_eq!(decode_watch(&[]), Err("version"));
        assert_eq!(decode_watch(&[1]), Err("version"));
        assert_eq!(decode_watch(&[1, 2, 0]), Err("length"));
        let mut b = rec.clone();
        b[0] = 2;
        assert_eq!(decode_watch(&b), Err("version"));
        let mut b = rec.clone();
        b[1] = 1; // a state's kind
        assert_eq!(decode_watch(&b), Err("version"));
        assert_eq!(decode_watch(&encode_watch(&[(1, 1), (1, 1)])), Err("value"));
        let mut big = vec![1u8, 2];
        big.extend_from_slice(&((MAX_CELLS + 1) as u16).to_le_bytes());
        big.resize(4 + 16 * (MAX_CELLS + 1), 0);
        assert_eq!(decode_watch(&big), Err("length"));
    }
}
