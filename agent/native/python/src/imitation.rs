//! An imitation's plan and its coordinator's notes (agent crate: imitation.rs) for agent/protocol/imitation.py.

use fluidswarm_agent::imitation;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::json::{to_py, to_value};

/// The plan in `data` as its JSON object (Python objects), or None if anything in it is malformed.
#[pyfunction]
fn imitation_plan_decode<'py>(py: Python<'py>, data: &[u8]) -> PyResult<Option<Bound<'py, PyAny>>> {
    imitation::decode_plan(data).map(|p| to_py(py, &p.to_json())).transpose()
}

/// The bytes of a plan given as its JSON object, checked as a receiver checks it (ValueError if not).
#[pyfunction]
fn imitation_plan_encode(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<Py<PyBytes>> {
    let text = serde_json::to_vec(&to_value(obj)?).expect("a Value always serialises");
    let p = imitation::decode_plan(&text).ok_or_else(|| PyValueError::new_err("not a valid imitation plan"))?;
    Ok(PyBytes::new(py, p.encode().as_bytes()).unbind())
}

/// The note in `data` as its JSON object (Python objects), or None if anything in it is malformed.
#[pyfunction]
fn imitation_note_decode<'py>(py: Python<'py>, data: &[u8]) -> PyResult<Option<Bound<'py, PyAny>>> {
    imitation::decode_note(data).map(|n| to_py(py, &n.to_json())).transpose()
}

/// The bytes of a note given as its JSON object, checked as a receiver checks it (ValueError if not).
#[pyfunction]
fn imitation_note_encode(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<Py<PyBytes>> {
    let text = serde_json::to_vec(&to_value(obj)?).expect("a Value always serialises");
    let n = imitation::decode_note(&text).ok_or_else(|| PyValueError::new_err("not a valid coordinator note"))?;
    Ok(PyBytes::new(py, n.encode().as_bytes()).unbind())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("IMITATION_VERSION", imitation::VERSION)?;
    m.add("IMITATION_MAX_BYTES", imitation::MAX_BYTES)?;
    m.add("IMITATION_MAX_COMMANDS", imitation::MAX_COMMANDS)?;
    m.add("IMITATION_MAX_PIXELS", imitation::MAX_PIXELS)?;
    m.add("IMITATION_MAX_TEXT", imitation::MAX_TEXT)?;
    m.add_function(wrap_pyfunction!(imitation_plan_decode, m)?)?;
    m.add_function(wrap_pyfunction!(imitation_plan_encode, m)?)?;
    m.add_function(wrap_pyfunction!(imitation_note_decode, m)?)?;
    m.add_function(wrap_pyfunction!(imitation_note_encode, m)?)?;
    Ok(())
}
