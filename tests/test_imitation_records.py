"""An imitation's records (agent/protocol/imitation.py, imitation.rs through agent._native) against the shared
vectors tests/vectors/imitation.json, which agent/native/tests/all/imitation_vectors.rs checks the Rust side
on; and real silhouettes and pictures through them whole."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from agent.protocol.imitation import (
    Commanded,
    End,
    Missing,
    Plan,
    Seen,
    Subject,
    decode_note,
    decode_plan,
    encode_note,
    encode_plan,
    mask_of,
    mask_runs,
)
from coordinator.control.imitation_setup import imitation_of_input

VECTORS = Path(__file__).resolve().parent / "vectors"
sys.path.insert(0, str(VECTORS))

from make.imitation import imitation_vectors

CASES = json.loads((VECTORS / "imitation.json").read_text())
REPO = Path(__file__).resolve().parent.parent
WAVE2 = REPO / "scenarios" / "inputs" / "weizmann_wave2_person0.png"


def test_the_vector_file_is_what_the_codecs_make_today():
    assert imitation_vectors() == CASES


@pytest.mark.parametrize("case", CASES["plans"], ids=[c["name"] for c in CASES["plans"]])
def test_plans_decode_as_the_vectors_say(case):
    plan = decode_plan(bytes.fromhex(case["payload_hex"]))
    assert (None if plan is None else plan.as_json()) == case["expect"]
    if plan is not None:
        assert decode_plan(encode_plan(plan)) == plan


@pytest.mark.parametrize("case", CASES["notes"], ids=[c["name"] for c in CASES["notes"]])
def test_notes_decode_as_the_vectors_say(case):
    note = decode_note(bytes.fromhex(case["payload_hex"]))
    expect = case["expect"]
    assert (note is None) == (expect is None)
    if note is not None:
        again = decode_note(encode_note(note))
        assert type(again) is type(note) and encode_note(again) == encode_note(note)


@pytest.mark.parametrize("shape", [(1, 1), (3, 5), (64, 48)])
def test_a_silhouette_crosses_whole_whichever_pixel_it_starts_with(shape):
    rng = np.random.default_rng(7)
    for mask in (rng.random(shape) < 0.5, np.ones(shape, bool), np.zeros(shape, bool)):
        runs = mask_runs(mask)
        assert sum(runs["runs"]) == mask.size
        np.testing.assert_array_equal(mask_of(runs), mask)


def test_a_persons_observation_and_its_commands_cross_whole():
    im = imitation_of_input(WAVE2, 24, "region", 14)
    obs = im.observation
    assert obs.frame is not None  # observe() keeps the picture of every frame it read
    ok, jpeg = cv2.imencode(".jpg", obs.frame)
    assert ok
    seen = Seen(1, obs.kind, obs.label, obs.index, obs.mask, obs.parts, jpeg.tobytes())
    got = decode_note(encode_note(seen))
    assert isinstance(got, Seen) and (got.observed, got.label, got.index, got.picture) == (
        "body",
        obs.label,
        14,
        seen.picture,
    )
    np.testing.assert_array_equal(got.mask, obs.mask)
    assert got.parts.keys() == obs.parts.keys() and all(np.array_equal(got.parts[k], obs.parts[k]) for k in obs.parts)
    for note in (Subject("person", "auto", 3), Commanded(2, "hand_2", "gesture", obs.mask), Missing("x"), End(72)):
        assert repr(decode_note(encode_note(note))) == repr(note)
    plan = Plan(tuple((first, c.encode(b"k" * 32)) for first, c in im.commands), 40)
    assert decode_plan(encode_plan(plan)) == plan


def test_the_encoders_refuse_what_a_receiver_would_drop():
    with pytest.raises(ValueError, match="not a valid imitation plan"):
        encode_plan(Plan(((1, b"{}"),)))
    with pytest.raises(ValueError, match="not a valid coordinator note"):
        encode_note(Missing(""))
