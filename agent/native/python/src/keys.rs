//! Key expressions of a run (agent crate: keys.rs) for agent/protocol/keys.py.

use fluidswarm_agent::keys;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// An id from 0 to MAX_AGENTS - 1, else ValueError (only those have a key).
fn keyed(agent_id: i64) -> PyResult<u32> {
    u32::try_from(agent_id).ok().filter(|&i| i < keys::MAX_AGENTS).ok_or_else(|| {
        PyValueError::new_err(format!(
            "agent id {agent_id}: ids 0..{} only (keys write the id in {} bits)",
            keys::MAX_AGENTS - 1,
            keys::ID_BITS
        ))
    })
}

#[pyfunction]
fn keys_id_chunk(agent_id: i64) -> PyResult<String> {
    Ok(keys::id_chunk(keyed(agent_id)?))
}

#[pyfunction]
fn keys_id_of_chunk(chunk: &str) -> Option<u32> {
    keys::id_of_chunk(chunk)
}

#[pyfunction]
fn keys_id_from_key(key: &str) -> Option<u32> {
    keys::id_from_key(key)
}

#[pyfunction]
fn keys_valid_run_name(run: &str) -> bool {
    keys::valid_run_name(run)
}

#[pyfunction]
fn keys_cell_of(x: f64, y: f64, cell: f64) -> (i64, i64) {
    keys::cell_of(x, y, cell)
}

#[pyfunction]
fn keys_cell_key(run: &str, cx: i64, cy: i64) -> String {
    keys::cell_key(run, (cx, cy))
}

#[pyfunction]
fn keys_state_key(run: &str, agent_id: i64) -> PyResult<String> {
    Ok(keys::state_key(run, keyed(agent_id)?))
}

#[pyfunction]
fn keys_alive_key(run: &str, agent_id: i64) -> PyResult<String> {
    Ok(keys::alive_key(run, keyed(agent_id)?))
}

#[pyfunction]
fn keys_final_key(run: &str, agent_id: i64) -> PyResult<String> {
    Ok(keys::final_key(run, keyed(agent_id)?))
}

#[pyfunction]
fn keys_event_key(run: &str, agent_id: i64) -> PyResult<String> {
    Ok(keys::event_key(run, keyed(agent_id)?))
}

#[pyfunction]
fn keys_command_key(run: &str) -> String {
    keys::command_key(run)
}

#[pyfunction]
fn keys_ctl_expr(run: &str) -> String {
    keys::ctl_expr(run)
}

#[pyfunction]
fn keys_ctl_what(run: &str, key: &str) -> Option<String> {
    keys::ctl_what(run, key).map(str::to_owned)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("KEYS_PREFIX", keys::PREFIX)?;
    m.add("KEYS_ID_BITS", keys::ID_BITS)?;
    m.add("KEYS_MAX_AGENTS", keys::MAX_AGENTS)?;
    m.add_function(wrap_pyfunction!(keys_id_chunk, m)?)?;
    m.add_function(wrap_pyfunction!(keys_id_of_chunk, m)?)?;
    m.add_function(wrap_pyfunction!(keys_id_from_key, m)?)?;
    m.add_function(wrap_pyfunction!(keys_valid_run_name, m)?)?;
    m.add_function(wrap_pyfunction!(keys_cell_of, m)?)?;
    m.add_function(wrap_pyfunction!(keys_cell_key, m)?)?;
    m.add_function(wrap_pyfunction!(keys_state_key, m)?)?;
    m.add_function(wrap_pyfunction!(keys_alive_key, m)?)?;
    m.add_function(wrap_pyfunction!(keys_final_key, m)?)?;
    m.add_function(wrap_pyfunction!(keys_event_key, m)?)?;
    m.add_function(wrap_pyfunction!(keys_command_key, m)?)?;
    m.add_function(wrap_pyfunction!(keys_ctl_expr, m)?)?;
    m.add_function(wrap_pyfunction!(keys_ctl_what, m)?)?;
    Ok(())
}
