//! An imitation's plan and its coordinator's notes against the shared vectors (tests/vectors/imitation.json, made
//! by tests/vectors/make/imitation.py): the crate decodes each payload as the vectors say, and encodes each valid
//! record to that JSON again.

use crate::common::{load, unhex};
use fluidswarm_agent::imitation::{decode_note, decode_plan};
use serde_json::Value;

fn cases(which: &str) -> Vec<Value> {
    load("imitation.json")[which].as_array().expect("a list").clone()
}

#[test]
fn plans_decode_and_encode_as_the_vectors_say() {
    let cases = cases("plans");
    assert!(cases.iter().filter(|c| c["expect"].is_null()).count() >= 15);
    for case in &cases {
        let got = decode_plan(&unhex(case["payload_hex"].as_str().unwrap()));
        match got {
            None => assert!(case["expect"].is_null(), "{}: dropped, the vector decodes it", case["name"]),
            Some(plan) => {
                assert_eq!(plan.to_json(), case["expect"], "{}", case["name"]);
                assert_eq!(decode_plan(plan.encode().as_bytes()), Some(plan), "{}: encoded differently", case["name"]);
            }
        }
    }
}

#[test]
fn notes_decode_and_encode_as_the_vectors_say() {
    let cases = cases("notes");
    assert!(cases.iter().filter(|c| !c["expect"].is_null()).count() >= 8);
    assert!(cases.iter().filter(|c| c["expect"].is_null()).count() >= 20);
    for case in &cases {
        let got = decode_note(&unhex(case["payload_hex"].as_str().unwrap()));
        match got {
            None => assert!(case["expect"].is_null(), "{}: dropped, the vector decodes it", case["name"]),
            Some(note) => {
                assert_eq!(note.to_json(), case["expect"], "{}", case["name"]);
                assert_eq!(decode_note(note.encode().as_bytes()), Some(note), "{}: encoded differently", case["name"]);
            }
        }
    }
}
