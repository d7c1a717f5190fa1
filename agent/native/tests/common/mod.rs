//! What the vector tests share: reading a file of tests/vectors/ (with the crate's own JSON reader, which
//! reads floats correctly rounded, unlike serde_json's default) as serde_json values, and hex.

use std::path::PathBuf;

use fluidswarm_agent::command::{self, Json};
use serde_json::Value;

pub fn load(name: &str) -> Value {
    let path: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", "tests", "vectors", name].iter().collect();
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    to_value(&command::parse(&bytes).unwrap_or_else(|| panic!("{name} is not JSON")))
}

fn to_value(v: &Json) -> Value {
    match v {
        Json::Null => Value::Null,
        Json::Bool(b) => Value::Bool(*b),
        Json::Int(n) => {
            let i: i64 = n.digits.parse().expect("vector ints fit i64");
            Value::from(if n.negative { -i } else { i })
        }
        Json::Float(f) => Value::from(*f),
        Json::Str(s) => Value::String(s.iter().map(|&c| char::from_u32(c).expect("no lone surrogates")).collect()),
        Json::Array(items) => Value::Array(items.iter().map(to_value).collect()),
        Json::Object(map) => Value::Object(
            map.iter().map(|(k, v)| (k.iter().map(|&c| char::from_u32(c).unwrap()).collect(), to_value(v))).collect(),
        ),
    }
}

pub fn unhex(s: &str) -> Vec<u8> {
    assert!(s.len().is_multiple_of(2), "odd hex");
    (0..s.len()).step_by(2).map(|k| u8::from_str_radix(&s[k..k + 2], 16).expect("hex")).collect()
}
