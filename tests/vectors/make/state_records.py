"""state_records.json: wire.decode_state on 104-byte v2 records (and refused v1 ones), valid and rejected (reason)."""

from __future__ import annotations

import math
import struct

from agent.protocol.wire import decode_state, encode_state

POSE = [0.5, 0.25]  # heading [rad], forward speed [m/s]


def record(version=2, kind=1, flags=0, agent_id=5, step=17, cls=0, reserved=0, floats=None) -> bytes:
    floats = floats or [1.5, -2.25, 0.1, -0.3, 0.85, 12.5, 0.001, -1e-7, 3.0]
    floats = floats + POSE if len(floats) == 9 else floats
    return struct.pack(f"<BBHIIHH{len(floats)}d", version, kind, flags, agent_id, step, cls, reserved, *floats)


def v1_record() -> bytes:
    """The 88-byte record of wire v1 (no pose): refused by its version byte."""
    return struct.pack("<BBHIIHH9d", 1, 1, 0, 5, 17, 0, 0, 1.5, -2.25, 0.1, -0.3, 0.85, 12.5, 0.001, -1e-7, 3.0)


def state_vectors() -> list:
    s = [10.0, 20.5, -0.75, 1.25, 0.9, 3.3, 0.01, 0.02, -0.03, 0.0, -2.5, 0.75]
    frozen = list(s)
    frozen[9] = 1.0
    extreme = [
        1e12,
        -1e12,
        5e-324,
        -0.0,
        1e12,
        -1e12,
        0.30000000000000004,
        1.7976931348623157e-300,
        2.5,
        math.pi,
        -1e12,
    ]
    cases = [
        ("valid", encode_state(7, 42, s, 0)),
        ("valid_frozen_class3", encode_state(123456, 4294967295, frozen, 3)),
        ("valid_max_id_extreme_values", record(agent_id=2**31 - 1, cls=65535, floats=extreme)),
        ("valid_reserved_nonzero", record(reserved=0xBEEF)),  # reserved is not checked
        ("valid_heading_minus_pi", record(floats=[1.0] * 9 + [-math.pi, 0.0])),
        ("length_103", record()[:103]),
        ("length_105", record() + b"\0"),
        ("length_0", b""),
        ("v1_record_refused", v1_record()),  # the old version, by its version byte, before its length
        ("version_3", record(version=3)),
        ("kind_2", record(kind=2)),
        ("version_3_and_bad_value", record(version=3, flags=2)),  # version is checked first
        ("heading_above_pi", record(floats=[1.0] * 9 + [math.nextafter(math.pi, 4.0), 0.0])),
        ("heading_nan", record(floats=[1.0] * 9 + [float("nan"), 0.0])),
        ("speed_inf", record(floats=[1.0] * 9 + [0.0, float("inf")])),
        ("nan", record(floats=[float("nan")] + [1.0] * 8)),
        ("inf", record(floats=[1.0, float("inf")] + [1.0] * 7)),
        ("minus_inf_in_stress", record(floats=[1.0] * 8 + [float("-inf")])),
        ("value_1e13", record(floats=[1.0] * 3 + [1e13] + [1.0] * 5)),
        ("value_just_above_1e12", record(floats=[math.nextafter(1e12, math.inf)] + [1.0] * 8)),
        ("rho_zero", record(floats=[1.0] * 4 + [0.0] + [1.0] * 4)),
        ("rho_minus_zero", record(floats=[1.0] * 4 + [-0.0] + [1.0] * 4)),
        ("rho_negative", record(floats=[1.0] * 4 + [-0.5] + [1.0] * 4)),
        ("flags_2", record(flags=2)),
        ("flags_3", record(flags=3)),
        ("id_2_31", record(agent_id=2**31)),
    ]
    out = []
    for name, data in cases:
        res, reason = decode_state(data)
        if res is None:
            expect = {"reject": reason}
        else:
            agent_id, step, cls, values = res
            expect = {"id": agent_id, "step": step, "class": cls, "values": list(values)}
        out.append({"name": name, "hex": data.hex(), "expect": expect})
    return out
