"""The launcher's ctl messages and the agents' events (agent/protocol/ctl.py, events.py) against the shared
vectors tests/vectors/ctl.json and events.json, which agent/native/tests/all/records.rs checks the Rust side on."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from agent.protocol.ctl import MAX_STEP, Clock, End, Gone, Start, Stop, decode_ctl, encode_ctl, kind_of
from agent.protocol.events import MAX_BYTES, AgentEvent, EventKind, Sighting, decode_event, encode_event

VECTORS = Path(__file__).resolve().parent / "vectors"
sys.path.insert(0, str(VECTORS))

from make.ctl import ctl_vectors, expected
from make.events import event_vectors

CTL = json.loads((VECTORS / "ctl.json").read_text())
EVENTS = json.loads((VECTORS / "events.json").read_text())


def test_the_vector_files_are_what_the_codecs_make_today():
    assert ctl_vectors() == CTL
    assert event_vectors() == EVENTS


@pytest.mark.parametrize("case", CTL, ids=[c["name"] for c in CTL])
def test_ctl_payloads_decode_as_the_vectors_say(case):
    data = bytes.fromhex(case["payload_hex"])
    msg = decode_ctl(case["what"], data)
    assert expected(msg) == case["expect"]
    if msg is not None:
        assert encode_ctl(msg) == data and kind_of(msg).what == case["what"]
    assert decode_ctl(None, data) is None  # a key that is no exact ctl key (a wildcard put)


def test_every_ctl_kind_round_trips_and_has_valid_and_malformed_vectors():
    for msg in (Start(), Stop(), Clock(5), End(MAX_STEP), Gone(7)):
        assert decode_ctl(kind_of(msg).what, encode_ctl(msg)) == msg
    kinds = {c["expect"]["kind"] for c in CTL if c["expect"]}
    assert kinds == {"start", "stop", "clock", "end", "gone"}
    assert sum(c["expect"] is None for c in CTL) >= 20


def test_ctl_encoder_refuses_values_it_cannot_carry():
    with pytest.raises(ValueError, match="ctl/clock: step must be in"):
        encode_ctl(Clock(MAX_STEP + 1))
    with pytest.raises(ValueError, match="ctl/gone: agent must be in"):
        encode_ctl(Gone(-1))


@pytest.mark.parametrize("case", EVENTS, ids=[c["name"] for c in EVENTS])
def test_events_decode_as_the_vectors_say(case):
    ev = decode_event(bytes.fromhex(case["payload_hex"]))
    assert (None if ev is None else ev.as_json()) == case["expect"]
    if ev is not None:
        assert decode_event(encode_event(ev)) == ev


def test_events_round_trip_and_oversized_ones_are_dropped():
    ev = AgentEvent(
        3, 17, EventKind.NEIGHBOUR_TIMEOUT, (4, 9), (Sighting(4, 15, 0.5, True), Sighting(9, -1, None, False))
    )
    assert decode_event(encode_event(ev)) == ev
    started = encode_event(AgentEvent(3, 0, EventKind.STARTED))
    assert decode_event(started) == AgentEvent(3, 0, EventKind.STARTED)
    assert decode_event(started[:-1] + b" " * MAX_BYTES + b"}") is None
    kinds = {c["expect"]["event"] for c in EVENTS if c["expect"]}
    assert kinds == {k.value for k in EventKind}
