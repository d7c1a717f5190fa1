//! Python objects <-> serde_json values: the JSON records (command body, ctl, events, report, spec) cross the
//! boundary as Python's json types (dict, list, str, int, float, bool, None), read and written by serde_json.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::{Map, Number, Value};

/// Deeper Python objects are refused before they are walked (a record nests a few levels; the command's
/// limit, MAX_DEPTH = 32, is checked on the value).
const MAX_NESTING: usize = 128;

fn refuse(what: &str) -> PyErr {
    PyValueError::new_err(format!("not JSON: {what}"))
}

/// A value of Python's json types (a tuple as a list; dict keys str; floats finite; ints within 64 bits).
/// Object keys are inserted sorted, so the encoding is canonical whatever the Map's order.
pub fn to_value(obj: &Bound<'_, PyAny>) -> PyResult<Value> {
    value_at(obj, 0)
}

fn value_at(obj: &Bound<'_, PyAny>, depth: usize) -> PyResult<Value> {
    if depth > MAX_NESTING {
        return Err(refuse("nested too deep"));
    }
    if obj.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if let Ok(i) = obj.cast::<PyInt>() {
        if let Ok(v) = i.extract::<i64>() {
            return Ok(Value::from(v));
        }
        return i.extract::<u64>().map(Value::from).map_err(|_| refuse("an integer beyond 64 bits"));
    }
    if let Ok(f) = obj.cast::<PyFloat>() {
        return Number::from_f64(f.value()).map(Value::Number).ok_or_else(|| refuse("a float that is not finite"));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Value::String(s.to_str()?.to_owned()));
    }
    if let Ok(items) = obj.cast::<PyList>() {
        return items.iter().map(|x| value_at(&x, depth + 1)).collect::<PyResult<_>>().map(Value::Array);
    }
    if let Ok(items) = obj.cast::<PyTuple>() {
        return items.iter().map(|x| value_at(&x, depth + 1)).collect::<PyResult<_>>().map(Value::Array);
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut entries = Vec::with_capacity(d.len());
        for (k, v) in d.iter() {
            let k = k.cast::<PyString>().map_err(|_| refuse("a key that is not a str"))?.to_str()?.to_owned();
            entries.push((k, value_at(&v, depth + 1)?));
        }
        entries.sort_by(|a, b| a.0.cmp(&b.0));
        return Ok(Value::Object(entries.into_iter().collect::<Map<_, _>>()));
    }
    Err(refuse(&format!("a {}", obj.get_type().name()?)))
}

/// The Python object of a value: an integer as int, any other number as float.
pub fn to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(u)) => u.into_pyobject(py)?.into_any(),
            _ => PyFloat::new(py, n.as_f64().unwrap_or(f64::NAN)).into_any(),
        },
        Value::String(s) => PyString::new(py, s).into_any(),
        Value::Array(items) => {
            PyList::new(py, items.iter().map(|x| to_py(py, x)).collect::<PyResult<Vec<_>>>()?)?.into_any()
        }
        Value::Object(map) => {
            let d = PyDict::new(py);
            for (k, x) in map {
                d.set_item(k, to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}
