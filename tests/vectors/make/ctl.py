"""ctl.json: agent.protocol.ctl.decode_ctl on payloads received on ctl/<what>: the message, or null (dropped
and counted). Each valid payload is also what encode_ctl writes for that message."""

from __future__ import annotations

import struct

from agent.protocol.ctl import MAX_AGENT, MAX_STEP, Clock, End, Gone, Start, Stop, decode_ctl, encode_ctl, kind_of


def expected(msg) -> dict | None:
    if msg is None:
        return None
    out = {"kind": kind_of(msg).what}
    out.update(msg.__dict__)
    return out


def ctl_vectors() -> list:
    valid = [
        ("start", Start()),
        ("stop", Stop()),
        ("clock_0", Clock(0)),
        ("clock_77777", Clock(77777)),
        ("clock_max", Clock(MAX_STEP)),
        ("end_3", End(3)),
        ("gone_0", Gone(0)),
        ("gone_99", Gone(99)),
        ("gone_max", Gone(MAX_AGENT)),
    ]
    cases = [(name, kind_of(m).what, encode_ctl(m)) for name, m in valid]
    clock = encode_ctl(Clock(12))
    cases += [
        ("unversioned_start", "start", b"start"),  # the payloads before v1
        ("unversioned_stop", "stop", b"stop"),
        ("unversioned_clock", "clock", struct.pack("<Q", 12)),
        ("unversioned_gone", "gone", struct.pack("<I", 99)),
        ("empty", "start", b""),
        ("version_only", "start", b"\x01"),
        ("version_0", "start", b"\x00\x01"),
        ("version_2", "clock", b"\x02" + clock[1:]),
        ("kind_0", "start", b"\x01\x00"),
        ("kind_6", "start", b"\x01\x06"),
        ("clock_on_end_key", "end", clock),
        ("end_on_clock_key", "clock", encode_ctl(End(12))),
        ("start_on_stop_key", "stop", encode_ctl(Start())),
        ("unknown_key", "bogus", encode_ctl(Start())),
        ("wildcard_key", "*", encode_ctl(Stop())),
        ("start_with_body", "start", encode_ctl(Start()) + b"\x00"),
        ("clock_short", "clock", clock[:-1]),
        ("clock_long", "clock", clock + b"\x00"),
        ("clock_beyond_u32", "clock", b"\x01\x03" + struct.pack("<Q", MAX_STEP + 1)),
        ("end_u64_max", "end", b"\x01\x04" + struct.pack("<Q", 2**64 - 1)),
        ("gone_2_31", "gone", b"\x01\x05" + struct.pack("<I", MAX_AGENT + 1)),
        ("gone_short", "gone", encode_ctl(Gone(5))[:-1]),
        ("gone_as_u64", "gone", b"\x01\x05" + struct.pack("<Q", 5)),
    ]
    return [
        {"name": name, "what": what, "payload_hex": data.hex(), "expect": expected(decode_ctl(what, data))}
        for name, what, data in cases
    ]
