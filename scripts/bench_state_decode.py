"""CPU per state record decoded, before and after the state record moved to the compiled module (issue 34):
the recorder's `decode_state` (fluidswarm/recording/steps.py) and the launcher's `peek_id_step`
(swarmhost/pacing.py; its settle rule also calls `decode_state`).

"before" is the pure-Python wire.py of commit 56af093 (copied below, verbatim in what it computes); "after"
is agent/protocol/wire.py, the typed wrapper of agent._native. The two run alternately, ROUNDS rounds of
N/ROUNDS records each, on the same varied records, and the CPU time (process_time) of each is summed, so a
change of load hits both alike. Run it under the machine's lock:

    flock /tmp/fluidswarm-cpu.lock .venv/bin/python scripts/bench_state_decode.py [N]
"""

from __future__ import annotations

import math
import struct
import sys
import time

import numpy as np

from agent.protocol import wire

# --- before: agent/protocol/wire.py at 56af093 (decode_state, peek_id_step) ---
_RECORD = struct.Struct("<BBHIIHH11d")
_ID_STEP = struct.Struct("<II")
_FLAG_VALUE = (0.0, 1.0)
_VERSION_BYTE = bytes([2])


def old_peek_id_step(data: bytes):
    if len(data) != 104:
        return None
    return _ID_STEP.unpack_from(data, 4)


def old_decode_state(data: bytes):
    if data[:1] != _VERSION_BYTE:
        return None, "version"
    if len(data) != 104:
        return None, "length"
    record = _RECORD.unpack(data)
    version, kind, flags, agent_id, step, particle_class = record[:6]
    if version != 2 or kind != 1:
        return None, "version"
    if agent_id > 2**31 - 1 or flags > 1:
        return None, "value"
    values = record[7:]
    for v in values:
        if not -1e12 <= v <= 1e12:
            return None, "value"
    if values[4] <= 0.0:
        return None, "value"
    if not -math.pi <= values[9] <= math.pi:
        return None, "value"
    return (agent_id, step, particle_class, values[:9] + (_FLAG_VALUE[flags],) + values[9:]), None


def records(n: int) -> list[bytes]:
    rng = np.random.default_rng(0)
    out = []
    for k in range(n):
        s = rng.normal(size=12)
        s[4], s[9], s[10] = 1.0 + abs(s[4]), 0.0, math.atan2(s[10], s[11])
        out.append(wire.encode_state(k, k, s, k % 3))
    return out


def timed(fn, data: list[bytes]) -> float:
    t = time.process_time()
    for d in data:
        fn(d)
    return time.process_time() - t


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    data = records(10_000)
    assert all(old_decode_state(d) == wire.decode_state(d) for d in data)  # the same answers
    rounds = max(1, n // len(data))
    pairs = {
        "decode_state (recorder, settle)": (old_decode_state, wire.decode_state),
        "peek_id_step (launcher's pacing)": (old_peek_id_step, wire.peek_id_step),
    }
    print(f"{rounds * len(data)} records each, {rounds} alternating rounds; CPU per record")
    for name, (old, new) in pairs.items():
        before = after = 0.0
        for _ in range(rounds):
            before += timed(old, data)
            after += timed(new, data)
        total = rounds * len(data)
        print(f"  {name:34s} before {1e9 * before / total:6.0f} ns   after {1e9 * after / total:6.0f} ns")


if __name__ == "__main__":
    main()
