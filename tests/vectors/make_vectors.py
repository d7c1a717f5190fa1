"""Generate the shared test vectors from the Python codecs (the oracle):
`.venv/bin/python tests/vectors/make_vectors.py`.

The files next to this script are committed; tests/test_vectors.py checks the Python codecs against them
and agent/native/tests/all/vectors.rs the Rust ones, so both implementations make the same decisions:

    state_records.json      wire.decode_state: 104-byte v2 records (and a refused v1 one), valid and rejected (reason)
    commands.json           agent.protocol.command.decode: envelopes (raw bytes in hex), accepted (parsed
                            fields, the fill shape when there is one) or rejected (reason)
    command_sequences.json  coordinator.control.route.CommandFollower (route.rs, through agent._native): offers in
                            order with each answer, and controls
    route.json              coordinator.control.route.class_counts/class_of and RouteFollower controls
    fill.json               agent.fill.inside/nearest_point and FillFollower controls, and
                            agent.protocol.command.edges_cross
    ctl.json                agent.protocol.ctl.decode_ctl: the launcher's ctl/<what> payloads, decoded or dropped
    events.json             agent.protocol.events.decode_event: agent events, decoded or dropped
    imitation.json          agent.protocol.imitation.decode_plan/decode_note: an imitation's plan and its
                            coordinator's notes, decoded or dropped
    radio.json              agent.sph.radio: the counter-based draws of the imperfect radio (loss, position error;
                            agent/native/tests/all/radio_vectors.rs checks radio.rs)
    sph_steps.json          agent.sph.particle.step_particle (numpy, the physics oracle): one particle's step,
                            neighbours in, next state out (agent/native/tests/all/sph_vectors.rs checks sph.rs)

One module per file in tests/vectors/make/ (the name of the file it makes), this script writes them all.

Deterministic: a fixed secret, fixed commands and seeded random numbers. Expected floats are written by
json (repr), so they read back exactly.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent.parent)]

from make.command_sequences import follower_sequences
from make.commands import command_vectors
from make.common import SECRET
from make.ctl import ctl_vectors
from make.events import event_vectors
from make.fill import fill_vectors
from make.imitation import imitation_vectors
from make.radio import radio_vectors
from make.route import route_vectors
from make.sph_steps import sph_step_vectors
from make.state_records import state_vectors

__all__ = [
    "command_vectors",
    "ctl_vectors",
    "event_vectors",
    "fill_vectors",
    "follower_sequences",
    "imitation_vectors",
    "radio_vectors",
    "route_vectors",
    "sph_step_vectors",
    "state_vectors",
]


def main() -> None:
    write("state_records.json", state_vectors())
    vectors = command_vectors()
    write("commands.json", {"secret_hex": SECRET.hex(), "vectors": vectors})
    payloads = {v["name"]: bytes.fromhex(v["payload_hex"]) for v in vectors}
    write("command_sequences.json", {"secret_hex": SECRET.hex(), "sequences": follower_sequences(payloads)})
    write("route.json", route_vectors())
    write("fill.json", fill_vectors())
    write("ctl.json", ctl_vectors())
    write("sph_steps.json", sph_step_vectors())
    write("radio.json", radio_vectors())
    write("events.json", event_vectors())
    write("imitation.json", imitation_vectors())


def write(name: str, obj) -> None:
    text = json.dumps(obj, indent=1, ensure_ascii=True, allow_nan=False) + "\n"
    (HERE / name).write_text(text)
    print(f"{name}: {len(text)} bytes")


if __name__ == "__main__":
    main()
