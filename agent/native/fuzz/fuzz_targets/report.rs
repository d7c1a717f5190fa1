//! The agents' final reports (final_report.rs `decode`) as the launcher and the recorder read them: any
//! bytes. An accepted report has every field the reader keeps, each within its bounds, and decodes again to
//! itself once re-encoded; nothing panics.
#![no_main]

use fluidswarm_agent::final_report::{self, MAX_ABS, MAX_COUNT, MIN_STATE};
use fluidswarm_agent::sph::NFIELDS;
use libfuzzer_sys::fuzz_target;

/// Every field the reader keeps (absent ones filled in), in key order: a field added to the report shows here.
const KEPT: [&str; 25] = [
    "agent",
    "command_seq",
    "commands_accepted",
    "cpu_seconds",
    "cpu_seconds_at_start",
    "deaths_seen",
    "dropped_out",
    "first_command_at",
    "id",
    "lost",
    "msgs_received",
    "neighbours",
    "particle_class",
    "pss_mb",
    "rejected",
    "rss_mb",
    "session_opened_at",
    "stale",
    "state",
    "status",
    "steps",
    "t_end",
    "t_start",
    "timeouts",
    "waypoint_index",
];

fuzz_target!(|data: &[u8]| {
    let Some(m) = final_report::decode(data) else { return };
    let mut keys: Vec<&str> = m.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(keys, KEPT, "{m:?}");
    for name in ["rss_mb", "pss_mb", "cpu_seconds"] {
        assert!(m[name].as_f64().is_some_and(|x| x.abs() <= MAX_ABS), "{name}: {m:?}");
    }
    let state = m["state"].as_array().unwrap();
    assert!((MIN_STATE..=NFIELDS).contains(&state.len()));
    assert!(state.iter().all(|v| v.as_f64().is_some_and(|x| x.abs() <= MAX_ABS)));
    assert!(m["id"].as_i64().is_some_and(|i| (0..1 << 31).contains(&i)));
    for name in ["steps", "msgs_received", "lost", "stale", "timeouts"] {
        assert!(m[name].as_i64().is_some_and(|n| (0..=MAX_COUNT).contains(&n)), "{name}");
    }
    assert!(m["rejected"].as_object().unwrap().len() <= final_report::MAX_REASONS);
    assert!(m["agent"].as_str().unwrap().chars().count() <= 32);
    let again = serde_json::to_vec(&serde_json::Value::Object(m.clone())).unwrap();
    assert_eq!(final_report::decode(&again).as_ref(), Some(&m), "re-encode -> decode changed the report");
});
