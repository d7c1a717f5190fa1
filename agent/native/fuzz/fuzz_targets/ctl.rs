//! The launcher's control messages (ctl.rs) as an agent reads them: the first byte picks the key's kind
//! (or none, or a foreign one), the rest is the payload. An accepted message is the key's kind and
//! re-encodes to the very payload; nothing else is accepted.
#![no_main]

use fluidswarm_agent::ctl::{self, Ctl};
use libfuzzer_sys::fuzz_target;

const WHATS: [Option<&str>; 8] =
    [None, Some("start"), Some("stop"), Some("clock"), Some("end"), Some("gone"), Some(""), Some("clocks")];

fuzz_target!(|data: &[u8]| {
    let Some((&pick, payload)) = data.split_first() else { return };
    let what = WHATS[usize::from(pick) % WHATS.len()];
    if let Some(msg) = ctl::decode(what, payload) {
        assert_eq!(Some(msg.what()), what);
        assert_eq!(ctl::encode(&msg), payload, "{msg:?}");
        match msg {
            Ctl::Clock(s) | Ctl::End(s) => assert!(s <= ctl::MAX_STEP),
            Ctl::Gone(id) => assert!(id <= ctl::MAX_AGENT),
            Ctl::Start | Ctl::Stop => {}
        }
    }
});
