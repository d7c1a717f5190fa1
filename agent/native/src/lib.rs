//! The fluidswarm agent as a compiled program: one SPH particle per OS process, its neighbours over Zenoh.
//! Modules mirror the Python oracle: sph and robot (agent/sph), wire (agent/protocol/wire.py), keys (agent/protocol/keys.py),
//! command (agent/protocol/command.py decoding), fill (agent/fill.py and the command's crossing check),
//! route (coordinator/control/route.py), spec (agent/protocol/spec.py), ctl, event and final_report
//! (agent/protocol/ctl.py, events.py, report.py).

pub mod agent;
pub mod command;
pub mod ctl;
pub mod event;
pub mod fill;
pub mod final_report;
pub mod keys;
pub mod radio;
pub mod relay;
pub mod robot;
pub mod route;
#[cfg(feature = "net")]
pub mod session;
#[cfg(feature = "net")]
pub mod shell;
pub mod spec;
pub mod sph;
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
