"""command_sequences.json: coordinator.control.route.CommandFollower, offers in order with each answer, and
controls."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from agent.protocol.command import Fill, GestureCommand, ParticleClass, Waypoint
from agent.sph.particle import NFIELDS, Control
from coordinator.control.route import CommandFollower

from .common import SECRET, control_list, framed, reserialised, sign


def spec(agent_id: int):
    return SimpleNamespace(
        secret=SECRET.hex(), id=agent_id, static_control=lambda: Control(1.0, 2.0, 0.5, 1.0, 0.0, 2.0, 0.0, 0.0, 0.0)
    )


def follower_sequences(commands: dict) -> list:
    def cmd(seq, n=10, shares=(1.0, 1.0, 1.0), gesture="g"):
        classes = tuple(
            ParticleClass(
                f"c{k}",
                s,
                (
                    Waypoint(5.0 * k, 1.0, 0.5, 2.0, 3.0, beta=4.0 + k),
                    Waypoint(5.0 * k + 10.0, 2.0, 0.5, 2.0, 3.0, mu=0.5),
                ),
            )
            for k, s in enumerate(shares)
        )
        return GestureCommand(seq, gesture, n, classes, beta=2.0, mu=0.0, extra={"n": 1})

    c1 = cmd(1).encode(SECRET)
    c2 = cmd(2).encode(SECRET)
    c2_reserialised = framed(reserialised(cmd(2).body(), indent=1), c2[-66:-2])  # a forgery: other bytes
    # The same values for Python (share 1 == 1.0, extra {"n": True} == {"n": 1}), signed: other bytes with
    # the same seq, so a replay, not a republication
    b = cmd(2).body()
    b["classes"][0]["share"] = 1
    b["extra"] = {"n": True}
    c2_equal = sign(b)
    c2_other = cmd(2, gesture="other").encode(SECRET)
    c3 = cmd(3, n=4, shares=(0.0, 1.0, 3.0)).encode(SECRET)
    c4 = cmd(4).encode(SECRET)
    c5 = cmd(5, n=6, shares=(2.0, 0.0, 1.0)).encode(SECRET)
    # A shape (a square with a square hole): every agent follows it, whatever its class; then routes again.
    shape = (((0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0)), ((8.0, 8.0), (12.0, 8.0), (12.0, 12.0), (8.0, 12.0)))
    c6_cmd = GestureCommand(6, "fill", 10, cmd(6).classes, 3.0, 0.5, {"controller": "fill"}, Fill(shape, 80.0, 0.2))
    c6 = c6_cmd.encode(SECRET)
    c6_reserialised = framed(reserialised(c6_cmd.body(), separators=(",", ":")), c6[-66:-2])
    b = c6_cmd.body()
    b["fill"]["rings"][0] = [[int(x), int(y)] for x, y in b["fill"]["rings"][0]]  # equal for Python: 20 == 20.0
    c6_equal = sign(b)
    b["fill"]["alpha"] = 81.0
    c6_other = sign(b)
    c7 = cmd(7).encode(SECRET)
    forged = bytearray(c4)
    forged[20] ^= 1
    steps = [
        ("offer", c1),
        ("offer", c1),
        ("control", (0.0, 0.0)),
        ("offer", c2),
        ("offer", c1),
        ("offer", c1),
        ("offer", c2_reserialised),
        ("offer", c2_equal),
        ("offer", c2_other),
        ("offer", c2),
        ("control", (10.0, 1.0)),
        ("control", (10.0, 1.0)),
        ("offer", bytes(forged)),
        ("offer", b"{}"),
        ("offer", commands["v_2"]),
        ("offer", c3),
        ("control", (5.0, 1.0)),
        ("offer", c4),
        ("offer", c5),
        ("offer", c4),
        ("offer", c3),
        ("control", (10.1, 1.0)),
        ("offer", c5),
        ("offer", c3),
        ("control", (15.0, 1.0)),
        ("control", (100.0, 100.0)),
        ("offer", c6),
        ("offer", c6_reserialised),
        ("offer", c6_equal),
        ("offer", c6_other),
        ("control", (5.0, 5.0)),
        ("control", (25.0, 10.0)),
        ("control", (10.0, 9.0)),
        ("control", (20.0, 20.0)),
        ("offer", c5),
        ("offer", c7),
        ("control", (0.0, 1.0)),
    ]
    out = []
    for agent_id in (0, 4, 9, 12):
        f = CommandFollower(spec(agent_id))
        seq = []
        for kind, arg in steps:
            if kind == "offer":
                seq.append({"offer_hex": arg.hex(), "expect": f.offer(arg), "has_command": f.has_command})
            else:
                state = np.zeros(NFIELDS)
                state[0], state[1] = arg
                c = f.control(state, 0)
                report = f.report()
                assert (report.pop("first_command_at") is None) == (f.accepted == 0)
                seq.append(
                    {
                        "control": list(arg),
                        "expect": control_list(c),
                        "particle_class": f.particle_class,
                        "report": report,
                    }
                )
        out.append({"agent_id": agent_id, "steps": seq})
    return out
