//! The fluidswarm agent as a compiled program: one SPH particle per OS process, its neighbours over Zenoh.
//! sph, robot and obstacle check against the numpy oracle (agent/sph, through tests/vectors); wire, keys, command,
//! fill, route, ctl, event, final_report, imitation and spec are the one implementation of those records, which the
//! Python side wraps (agent/protocol/wire.py, keys.py, command.py, ctl.py, events.py, imitation.py, report.py,
//! spec.py, agent/fill.py, coordinator/control/route.py through the extension module agent/native/python).

pub mod agent;
pub mod command;
pub mod ctl;
pub mod event;
pub mod fill;
pub mod final_report;
pub mod imitation;
pub mod keys;
pub mod obstacle;
pub mod radio;
pub mod relay;
pub mod robot;
pub mod route;
#[cfg(feature = "net")]
pub mod router_program;
#[cfg(feature = "net")]
pub mod session;
#[cfg(feature = "net")]
pub mod shell;
pub mod spec;
pub mod sph;
pub mod traffic;
pub mod watch;
pub mod wire;

/// Any panic ends the process at once (after the default message): a panicking zenoh callback thread would
/// otherwise leave the agent or router alive and silent, holding its neighbours until their timeouts. Called
/// first thing by both programs; the release profile unwinds so that tests can share its build (Cargo.toml).
pub fn abort_on_panic() {
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        report(info);
        std::process::abort();
    }));
}
