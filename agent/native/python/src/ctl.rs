//! The launcher's control messages (agent crate: ctl.rs) for agent/protocol/ctl.py.

use fluidswarm_agent::ctl::{self, Ctl};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// The payload of the message named `what` (start, stop, clock, end, gone) with `value` (the step of clock
/// and end, the agent of gone; ignored otherwise); ValueError for another name or a value out of range.
#[pyfunction]
fn ctl_encode(py: Python<'_>, what: &str, value: i64) -> PyResult<Py<PyBytes>> {
    let out_of =
        |name: &str, max: u64| PyValueError::new_err(format!("ctl/{what}: {name} must be in [0, {max}], got {value}"));
    let msg = match what {
        "start" => Ctl::Start,
        "stop" => Ctl::Stop,
        "clock" | "end" => {
            let step = u64::try_from(value)
                .ok()
                .filter(|&s| s <= ctl::MAX_STEP)
                .ok_or_else(|| out_of("step", ctl::MAX_STEP))?;
            if what == "clock" {
                Ctl::Clock(step)
            } else {
                Ctl::End(step)
            }
        }
        "gone" => Ctl::Gone(
            u32::try_from(value)
                .ok()
                .filter(|&a| a <= ctl::MAX_AGENT)
                .ok_or_else(|| out_of("agent", u64::from(ctl::MAX_AGENT)))?,
        ),
        _ => return Err(PyValueError::new_err(format!("ctl/{what}: no such control message"))),
    };
    Ok(PyBytes::new(py, &ctl::encode(&msg)).unbind())
}

/// (what, value) of the payload received on `ctl/<what>` (value: the step or agent, None for start and
/// stop), or None if anything in it is malformed.
#[pyfunction]
#[pyo3(signature = (what, data))]
fn ctl_decode(what: Option<&str>, data: &[u8]) -> Option<(&'static str, Option<u64>)> {
    let msg = ctl::decode(what, data)?;
    let value = match msg {
        Ctl::Start | Ctl::Stop => None,
        Ctl::Clock(step) | Ctl::End(step) => Some(step),
        Ctl::Gone(agent) => Some(u64::from(agent)),
    };
    Some((msg.what(), value))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CTL_VERSION", ctl::VERSION)?;
    m.add("CTL_MAX_STEP", ctl::MAX_STEP)?;
    m.add("CTL_MAX_AGENT", ctl::MAX_AGENT)?;
    m.add_function(wrap_pyfunction!(ctl_encode, m)?)?;
    m.add_function(wrap_pyfunction!(ctl_decode, m)?)?;
    Ok(())
}
