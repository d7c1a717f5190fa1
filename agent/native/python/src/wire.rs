//! The 104-byte state record (agent crate: wire.rs) for agent/protocol/wire.py.

use fluidswarm_agent::sph::NFIELDS;
use fluidswarm_agent::wire;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyTuple};

/// The record of one agent's state (NFIELDS floats, FROZEN nonzero for a frozen particle).
#[pyfunction]
fn state_encode(py: Python<'_>, agent_id: u32, step: u32, state: [f64; NFIELDS], particle_class: u16) -> Py<PyBytes> {
    PyBytes::new(py, &wire::encode_state(agent_id, step, &state, particle_class)).unbind()
}

/// ((agent_id, step, particle_class, values), None) with values a tuple of NFIELDS floats, or (None, reason).
#[pyfunction]
fn state_decode<'py>(py: Python<'py>, data: &[u8]) -> PyResult<Bound<'py, PyTuple>> {
    match wire::decode_state(data) {
        Ok(r) => ((r.id, r.step, r.class, PyTuple::new(py, r.values)?), py.None()).into_pyobject(py),
        Err(reason) => (py.None(), reason).into_pyobject(py),
    }
}

/// ((agent_id, x, y), None) for routing a record by position, or (None, reason) for its header and position.
#[pyfunction]
fn state_peek_id_position<'py>(py: Python<'py>, data: &[u8]) -> PyResult<Bound<'py, PyTuple>> {
    match wire::peek_id_position(data) {
        Ok(head) => (head, py.None()).into_pyobject(py),
        Err(reason) => (py.None(), reason).into_pyobject(py),
    }
}

/// (agent_id, step) of a record of the right length, unvalidated, else None.
#[pyfunction]
fn state_peek_id_step(data: &[u8]) -> Option<(u32, u32)> {
    wire::peek_id_step(data)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("STATE_VERSION", wire::VERSION)?;
    m.add("STATE_KIND", wire::KIND_STATE)?;
    m.add("STATE_SIZE", wire::STATE_SIZE)?;
    m.add("STATE_MAX_ID", wire::MAX_ID)?;
    m.add("STATE_MAX_ABS", wire::MAX_ABS)?;
    m.add_function(wrap_pyfunction!(state_encode, m)?)?;
    m.add_function(wrap_pyfunction!(state_decode, m)?)?;
    m.add_function(wrap_pyfunction!(state_peek_id_position, m)?)?;
    m.add_function(wrap_pyfunction!(state_peek_id_step, m)?)?;
    Ok(())
}
