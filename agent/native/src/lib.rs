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
