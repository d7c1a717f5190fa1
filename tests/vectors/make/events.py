"""events.json: agent.protocol.events.decode_event on event payloads: the record (as JSON), or null (dropped
and counted). The Rust agent's encoder writes each valid record's JSON from the same typed fields."""

from __future__ import annotations

import json

from agent.protocol.events import MAX_AGENT, MAX_LISTED, MAX_STEP, decode_event


def _text(obj) -> bytes:
    return json.dumps(obj).encode()


def event_vectors() -> list:
    timeout = {
        "v": 1,
        "id": 7,
        "step": 42,
        "event": "neighbour_timeout",
        "neighbours": [3, 11],
        "last_seen": [[3, 40, 0.25, True], [11, -1, None, False]],
    }
    cases = [
        ("started", {"v": 1, "id": 0, "step": 0, "event": "started"}),
        ("fell_behind", {"v": 1, "id": 12, "step": 88, "event": "fell_behind"}),
        ("rejoined", {"v": 1, "id": 12, "step": 130, "event": "rejoined", "from_step": 88}),
        (
            "command_received",
            {"v": 1, "id": 5, "step": 0, "event": "command_received", "seconds_since_session_open": 1.5},
        ),
        (
            "command_received_int_seconds",
            {"v": 1, "id": 5, "step": 0, "event": "command_received", "seconds_since_session_open": 2},
        ),
        ("neighbour_timeout_lockstep", timeout),
        ("neighbour_timeout_async", {"v": 1, "id": 7, "step": 42, "event": "neighbour_timeout", "neighbours": [2]}),
        (
            "neighbour_timeout_none_listed",
            {"v": 1, "id": 7, "step": 42, "event": "neighbour_timeout", "neighbours": [], "last_seen": []},
        ),
        (
            "largest_ids_and_steps",
            {
                "v": 1,
                "id": MAX_AGENT,
                "step": MAX_STEP,
                "event": "neighbour_timeout",
                "neighbours": [MAX_AGENT],
                "last_seen": [[MAX_AGENT, MAX_STEP, 1e9, True]],
            },
        ),
        # rejected
        ("unversioned", {"id": 0, "step": 0, "event": "started"}),
        ("version_2", {"v": 2, "id": 0, "step": 0, "event": "started"}),
        ("version_true", {"v": True, "id": 0, "step": 0, "event": "started"}),
        ("version_1_0", {"v": 1.0, "id": 0, "step": 0, "event": "started"}),
        ("unknown_kind", {"v": 1, "id": 0, "step": 0, "event": "exploded"}),
        ("unknown_field", {"v": 1, "id": 0, "step": 0, "event": "started", "note": "x"}),
        ("field_of_another_kind", {"v": 1, "id": 0, "step": 0, "event": "started", "neighbours": [1]}),
        ("id_missing", {"v": 1, "step": 0, "event": "started"}),
        ("id_negative", {"v": 1, "id": -1, "step": 0, "event": "started"}),
        ("id_2_31", {"v": 1, "id": MAX_AGENT + 1, "step": 0, "event": "started"}),
        ("id_float", {"v": 1, "id": 1.0, "step": 0, "event": "started"}),
        ("id_bool", {"v": 1, "id": True, "step": 0, "event": "started"}),
        ("step_beyond_u32", {"v": 1, "id": 0, "step": MAX_STEP + 1, "event": "started"}),
        ("step_string", {"v": 1, "id": 0, "step": "3", "event": "started"}),
        ("seconds_missing", {"v": 1, "id": 5, "step": 0, "event": "command_received"}),
        (
            "seconds_negative",
            {"v": 1, "id": 5, "step": 0, "event": "command_received", "seconds_since_session_open": -0.5},
        ),
        ("seconds_bool", {"v": 1, "id": 5, "step": 0, "event": "command_received", "seconds_since_session_open": True}),
        ("neighbours_missing", {"v": 1, "id": 7, "step": 42, "event": "neighbour_timeout"}),
        ("rejoined_from_step_missing", {"v": 1, "id": 12, "step": 130, "event": "rejoined"}),
        ("rejoined_from_step_negative", {"v": 1, "id": 12, "step": 130, "event": "rejoined", "from_step": -1}),
        ("neighbours_not_list", {"v": 1, "id": 7, "step": 42, "event": "neighbour_timeout", "neighbours": 3}),
        (
            "neighbours_too_many",
            {"v": 1, "id": 7, "step": 42, "event": "neighbour_timeout", "neighbours": list(range(MAX_LISTED + 1))},
        ),
        ("neighbour_negative", {"v": 1, "id": 7, "step": 42, "event": "neighbour_timeout", "neighbours": [-3]}),
        ("sighting_short", dict(timeout, last_seen=[[3, 40, 0.25]])),
        ("sighting_step_below_minus_1", dict(timeout, last_seen=[[3, -2, 0.25, True]])),
        ("sighting_distance_negative", dict(timeout, last_seen=[[3, 40, -0.25, True]])),
        ("sighting_watched_int", dict(timeout, last_seen=[[3, 40, 0.25, 1]])),
        ("not_an_object", [1, 2]),
    ]
    out = [(name, _text(obj)) for name, obj in cases]
    out += [
        ("not_json", b"{"),
        ("nan_seconds", b'{"v":1,"id":5,"step":0,"event":"command_received","seconds_since_session_open":NaN}'),
        (
            "infinite_distance",
            b'{"v":1,"id":7,"step":42,"event":"neighbour_timeout","neighbours":[3],"last_seen":[[3,40,1e999,true]]}',
        ),
        ("not_utf8", b"\xff\xfe"),
    ]
    vectors = []
    for name, data in out:
        ev = decode_event(data)
        vectors.append({"name": name, "payload_hex": data.hex(), "expect": None if ev is None else ev.as_json()})
    return vectors
