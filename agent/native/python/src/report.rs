//! The agents' final reports (agent crate: final_report.rs) for agent/protocol/report.py.

use fluidswarm_agent::final_report;
use pyo3::prelude::*;

use crate::json::to_py;

/// The report in `data` as the object of FinalReport's fields (Python objects, every field present), or None
/// if any field it carries is malformed.
#[pyfunction]
fn report_decode<'py>(py: Python<'py>, data: &[u8]) -> PyResult<Option<Bound<'py, PyAny>>> {
    final_report::decode(data).map(|m| to_py(py, &serde_json::Value::Object(m))).transpose()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("REPORT_VERSION", final_report::VERSION)?;
    m.add("REPORT_MAX_BYTES", final_report::MAX_BYTES)?;
    m.add("REPORT_MAX_COUNT", final_report::MAX_COUNT)?;
    m.add("REPORT_MAX_ABS", final_report::MAX_ABS)?;
    m.add_function(wrap_pyfunction!(report_decode, m)?)?;
    Ok(())
}
