//! The fluidswarm agent as a compiled program: one SPH particle per OS process, its neighbours over Zenoh.
//! Modules mirror the Python oracle: sph (agent/sph), wire (agent/wire.py), keys (agent/keys.py),
//! command (coordinator/command.py decoding), fill (agent/fill.py and the command's crossing check),
//! route (agent/route.py), spec (agent/spec.py).

pub mod agent;
pub mod command;
pub mod fill;
pub mod keys;
pub mod route;
pub mod session;
pub mod spec;
pub mod sph;
pub mod wire;
