//! agent._native: the agent crate's boundary records for the Python side (agent/records.py imports it, with
//! one line saying how to build it when it is missing). Each function is a thin conversion around the one
//! implementation in the agent crate; the types the Python side sees are in agent/_native.pyi.

use pyo3::prelude::*;

mod command;
mod ctl;
mod events;
mod imitation;
mod json;
mod keys;
mod report;
mod route;
mod spec;
mod wire;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    wire::register(m)?;
    command::register(m)?;
    ctl::register(m)?;
    events::register(m)?;
    imitation::register(m)?;
    keys::register(m)?;
    report::register(m)?;
    route::register(m)?;
    spec::register(m)?;
    Ok(())
}
