//! The agents' events (agent crate: event.rs) for agent/protocol/events.py.

use fluidswarm_agent::event;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::json::{to_py, to_value};

/// The event in `data` as its JSON object (Python objects), or None if anything in it is malformed.
#[pyfunction]
fn events_decode<'py>(py: Python<'py>, data: &[u8]) -> PyResult<Option<Bound<'py, PyAny>>> {
    event::decode(data).map(|e| to_py(py, &e.to_json())).transpose()
}

/// The bytes of an event given as its JSON object, checked as a receiver checks it (ValueError if not).
#[pyfunction]
fn events_encode(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<Py<PyBytes>> {
    let text = serde_json::to_vec(&to_value(obj)?).expect("a Value always serialises");
    let e = event::decode(&text).ok_or_else(|| PyValueError::new_err("not a valid event"))?;
    Ok(PyBytes::new(py, e.encode().as_bytes()).unbind())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("EVENTS_VERSION", event::VERSION)?;
    m.add("EVENTS_MAX_BYTES", event::MAX_BYTES)?;
    m.add("EVENTS_MAX_AGENT", event::MAX_AGENT)?;
    m.add("EVENTS_MAX_STEP", event::MAX_STEP)?;
    m.add("EVENTS_MAX_LISTED", event::MAX_LISTED)?;
    m.add("EVENTS_MAX_SECONDS", event::MAX_SECONDS)?;
    m.add_function(wrap_pyfunction!(events_decode, m)?)?;
    m.add_function(wrap_pyfunction!(events_encode, m)?)?;
    Ok(())
}
