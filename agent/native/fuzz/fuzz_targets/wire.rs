//! The state record (wire.rs) as every agent and the router's relay read it off the network: a record that
//! decodes re-encodes to the same bytes (the reserved u16 aside) and holds only values a state may have; the
//! relay's cheap peek agrees with the full decode; the relay routes only a record its key's owner sent.
#![no_main]

use fluidswarm_agent::keys;
use fluidswarm_agent::relay::RelayTable;
use fluidswarm_agent::sph::{FROZEN, NFIELDS, RHO};
use fluidswarm_agent::wire::{self, decode_state, encode_state, peek_id_position, peek_id_step, MAX_ABS, STATE_SIZE};
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

const RUN: &str = "fuzz";
const OWNER: u32 = 7;

fn table() -> &'static RelayTable {
    static TABLE: OnceLock<RelayTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        let t = RelayTable::new(RUN);
        t.add(OWNER, 0.5).expect("a valid agent and cell");
        t
    })
}

fuzz_target!(|data: &[u8]| {
    let decoded = decode_state(data);
    match decoded {
        Ok(rec) => {
            let mut expected = [0u8; STATE_SIZE];
            expected.copy_from_slice(data);
            expected[14..16].fill(0); // reserved: not read, written as 0
            assert_eq!(encode_state(rec.id, rec.step, &rec.values, rec.class), expected, "re-encode");
            assert!(rec.id <= wire::MAX_ID);
            assert!(rec.values[..FROZEN].iter().all(|v| v.is_finite() && v.abs() <= MAX_ABS), "{rec:?}");
            assert!(rec.values[RHO] > 0.0);
            assert!(rec.values[FROZEN] == 0.0 || rec.values[FROZEN] == 1.0);
            assert_eq!(rec.values.len(), NFIELDS);
            assert_eq!(peek_id_step(data), Some((rec.id, rec.step)));
            assert_eq!(peek_id_position(data), Ok((rec.id, rec.values[0], rec.values[1])));
        }
        Err(reason) => {
            assert!([wire::REJECT_LENGTH, wire::REJECT_VERSION, wire::REJECT_VALUE].contains(&reason));
            // the header checks are the same in the peek: only a value it does not read may differ
            if reason != wire::REJECT_VALUE {
                assert_eq!(peek_id_position(data), Err(reason));
            }
        }
    }
    assert_eq!(peek_id_step(data).is_some(), data.len() == STATE_SIZE);
    // The relay: on the owner's key only a record naming the owner with a valid position is routed.
    let t = table();
    let routed = t.route(&keys::state_key(RUN, OWNER), data);
    match peek_id_position(data) {
        Ok((id, x, y)) if id == OWNER => assert_eq!(routed, Some(keys::cell_of(x, y, 0.5))),
        _ => assert_eq!(routed, None),
    }
    assert_eq!(t.route(&keys::state_key(RUN, OWNER + 1), data), None); // nobody's key
    assert_eq!(t.route("fluidswarm/fuzz/state/*", data), None);
});
