//! The gesture command (agent crate: command.rs) for agent/protocol/command.py: the envelope written, verified
//! and read here; Python builds its dataclasses from a body this module has accepted.

use fluidswarm_agent::{command, fill};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyString};

use crate::json::{to_py, to_value};

/// The one encoding of a body: keys sorted, no spaces, serde_json's numbers (shortest round trip), UTF-8.
/// ValueError for what JSON cannot hold (NaN, infinities, a key that is not a str).
#[pyfunction]
fn command_canonical(py: Python<'_>, body: &Bound<'_, PyAny>) -> PyResult<Py<PyBytes>> {
    let bytes = serde_json::to_vec(&to_value(body)?).expect("a Value always serialises");
    Ok(PyBytes::new(py, &bytes).unbind())
}

/// The envelope of body bytes, signed with HMAC-SHA256(secret, body).
#[pyfunction]
fn command_sign(py: Python<'_>, body: &[u8], secret: &[u8]) -> Py<PyBytes> {
    PyBytes::new(py, &command::sign(body, secret)).unbind()
}

/// The body bytes once their HMAC matches, no JSON read; or the reason (a str: "malformed" | "version" |
/// "signature").
#[pyfunction]
fn command_verify<'py>(py: Python<'py>, data: &[u8], secret: &[u8]) -> Bound<'py, PyAny> {
    match command::verify(data, secret) {
        Ok(body) => PyBytes::new(py, body).into_any(),
        Err(reason) => PyString::new(py, reason).into_any(),
    }
}

/// The accepted command's body as Python objects (a dict); or the reason (a str).
#[pyfunction]
fn command_decode<'py>(py: Python<'py>, data: &[u8], secret: &[u8]) -> PyResult<Bound<'py, PyAny>> {
    let accepted = command::verify(data, secret).and_then(|body| {
        let value = command::read_body(body)?;
        command::parse_value(&value).map(|_| value)
    });
    match accepted {
        Ok(value) => to_py(py, &value),
        Err(reason) => Ok(PyString::new(py, reason).into_any()),
    }
}

/// None if a body (Python objects, e.g. from the coordinator's commands file) is a valid command, else the
/// reason ("malformed").
#[pyfunction]
fn command_check_body(body: &Bound<'_, PyAny>) -> Option<&'static str> {
    match to_value(body) {
        Ok(value) => command::parse_value(&value).err(),
        Err(_) => Some(command::MALFORMED),
    }
}

/// Do two edges of the rings cross properly (agent crate: fill.rs edges_cross)?
#[pyfunction]
fn fill_edges_cross(rings: Vec<Vec<(f64, f64)>>) -> bool {
    fill::edges_cross(&rings)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("COMMAND_MAX_BYTES", command::MAX_BYTES)?;
    m.add("COMMAND_MAX_CLASSES", command::MAX_CLASSES)?;
    m.add("COMMAND_MAX_ROUTE", command::MAX_ROUTE)?;
    m.add("COMMAND_MAX_COORD", command::MAX_COORD)?;
    m.add("COMMAND_MAX_RINGS", command::MAX_RINGS)?;
    m.add("COMMAND_MAX_VERTICES", command::MAX_VERTICES)?;
    m.add("COMMAND_MAX_ZONES", command::MAX_ZONES)?;
    m.add("COMMAND_MAX_DEPTH", command::MAX_DEPTH)?;
    m.add_function(wrap_pyfunction!(command_canonical, m)?)?;
    m.add_function(wrap_pyfunction!(command_sign, m)?)?;
    m.add_function(wrap_pyfunction!(command_verify, m)?)?;
    m.add_function(wrap_pyfunction!(command_decode, m)?)?;
    m.add_function(wrap_pyfunction!(command_check_body, m)?)?;
    m.add_function(wrap_pyfunction!(fill_edges_cross, m)?)?;
    Ok(())
}
