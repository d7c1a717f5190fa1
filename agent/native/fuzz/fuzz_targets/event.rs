//! The agents' events (event.rs `decode`) as the launcher and the recorder read them (`event/<id>`): any
//! bytes. An accepted event is within docs/protocol.md's bounds and decodes again to itself once encoded;
//! nothing panics. (python/event runs the same decoder through agent._native, without coverage of it.)
#![no_main]

use fluidswarm_agent::event::{self, EventKind, MAX_AGENT, MAX_LISTED, MAX_SECONDS, MAX_STEP};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some(e) = event::decode(data) else { return };
    assert!(i64::from(e.id) <= MAX_AGENT && i64::from(e.step) <= MAX_STEP, "{e:?}");
    match &e.kind {
        EventKind::CommandReceived { seconds_since_session_open: s } => {
            assert!(s.is_finite() && (0.0..=MAX_SECONDS).contains(s), "{e:?}");
        }
        EventKind::NeighbourTimeout { neighbours, last_seen } => {
            assert!(neighbours.len() <= MAX_LISTED && neighbours.iter().all(|&j| i64::from(j) <= MAX_AGENT));
            for s in last_seen.iter().flatten() {
                assert!(i64::from(s.agent) <= MAX_AGENT && (-1..=MAX_STEP).contains(&s.step), "{s:?}");
                assert!(s.distance.map_or(true, |d| d.is_finite() && (0.0..=MAX_SECONDS).contains(&d)), "{s:?}");
            }
            assert!(last_seen.as_ref().map_or(true, |v| v.len() <= MAX_LISTED));
        }
        EventKind::Rejoined { from_step } => assert!(i64::from(*from_step) <= MAX_STEP),
        EventKind::Started | EventKind::FellBehind => {}
    }
    let again = e.encode();
    assert_eq!(event::decode(again.as_bytes()).as_ref(), Some(&e), "encode -> decode changed the event: {again}");
});
