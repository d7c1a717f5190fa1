//! The agent's start-up spec (agent crate: spec.rs) for agent/protocol/spec.py: the launcher's fields are
//! checked and written by the one implementation the agent reads them with.

use fluidswarm_agent::spec::{self, AgentSpec};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::json::{to_py, to_value};

/// The spec's JSON text for `fields` (AgentSpec's fields as Python's json types); ValueError naming the field
/// ("agent spec: ...") when one is malformed, exactly as the agent would refuse it.
#[pyfunction]
fn spec_encode(fields: &Bound<'_, PyAny>) -> PyResult<String> {
    let py = fields.py();
    let value = to_value(fields).map_err(|e| PyValueError::new_err(format!("agent spec: {}", e.value(py))))?;
    AgentSpec::from_value(value).map(|s| s.to_json()).map_err(PyValueError::new_err)
}

/// The fields of the spec in `text` as the agent reads them (every check of the agent's own decoder; the
/// optional ones written as `spec_encode` writes them); ValueError naming the field.
#[pyfunction]
fn spec_decode<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    let spec = AgentSpec::from_json(text).map_err(PyValueError::new_err)?;
    to_py(py, &spec.to_value())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SPEC_FIELDS", spec::FIELDS.to_vec())?;
    m.add("SPEC_DEFAULT_TIMEOUT", spec::DEFAULT_TIMEOUT)?;
    m.add("SPEC_DEFAULT_START_TIMEOUT", spec::DEFAULT_START_TIMEOUT)?;
    m.add("SPEC_DEFAULT_RATE", spec::DEFAULT_RATE)?;
    m.add("SPEC_DEFAULT_MAX_AGE", spec::DEFAULT_MAX_AGE)?;
    m.add_function(wrap_pyfunction!(spec_encode, m)?)?;
    m.add_function(wrap_pyfunction!(spec_decode, m)?)?;
    Ok(())
}
