//! The key parsers an agent applies to every received key (keys.rs): an id is read only from a chunk that
//! writes it exactly, a ctl kind only from an exact `fluidswarm/<run>/ctl/<what>` key.
#![no_main]

use fluidswarm_agent::keys;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(key) = std::str::from_utf8(data) else { return };
    if let Some(id) = keys::id_of_chunk(key) {
        assert!(id < keys::MAX_AGENTS);
        assert_eq!(keys::id_chunk(id), key);
    }
    if let Some(id) = keys::id_from_key(key) {
        assert!(key.ends_with(&keys::id_chunk(id)));
    }
    if let Some(what) = keys::ctl_what("r1", key) {
        assert_eq!(format!("fluidswarm/r1/ctl/{what}"), key);
        assert!(!what.contains(['*', '/', '$']));
    }
    if keys::valid_run_name(key) {
        let k = keys::state_key(key, 5);
        assert_eq!(keys::id_from_key(&k), Some(5));
        assert_eq!(keys::ctl_what(key, &format!("fluidswarm/{key}/ctl/stop")), Some("stop"));
    }
});
