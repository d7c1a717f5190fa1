"""The Python codecs against the shared test vectors in tests/vectors/ (made by tests/vectors/make_vectors.py).

agent/native/tests/all/vectors.rs checks the compiled agent against the same files, so the two agree on every
record and command there: what is accepted, the reason for what is not, and the values decoded. Expected
values are compared through json.dumps, which tells 1 from 1.0 and 0.0 from -0.0.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from agent.fill import inside, nearest_point
from agent.protocol.command import CommandRejected, Fill, Waypoint, Zone, decode, edges_cross
from agent.protocol.wire import decode_state, encode_state
from agent.sph.particle import NFIELDS, Control
from coordinator.control.route import CommandFollower, FillFollower, RouteFollower, class_counts, class_of

VECTORS = Path(__file__).resolve().parent / "vectors"


def load(name: str):
    return json.loads((VECTORS / name).read_text())


def same(a, b) -> bool:
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def close(a, b, rel: float = 1e-12) -> bool:
    """Equal structures whose floats agree to `rel` (absolute near 0), the tolerance sph_vectors.rs holds the
    Rust step to. For what numpy's reductions compute: np.sum's SIMD loops are chosen by the CPU (AVX-512 here,
    AVX2 elsewhere) and add in a different order, so the generator's last digit differs from machine to
    machine (viscous_controlled_1: 0.33780355640880816 on this machine, ...082 where the file was written)."""
    if isinstance(a, float) or isinstance(b, float):
        return isinstance(a, (int, float)) and isinstance(b, (int, float)) and abs(a - b) <= rel * max(abs(b), 1.0)
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(close(a[k], b[k], rel) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(close(x, y, rel) for x, y in zip(a, b))
    return a == b


@pytest.mark.parametrize("v", load("state_records.json"), ids=lambda v: v["name"])
def test_state_record(v):
    data = bytes.fromhex(v["hex"])
    res, reason = decode_state(data)
    if "reject" in v["expect"]:
        assert res is None and reason == v["expect"]["reject"]
        return
    agent_id, step, cls, values = res
    assert same({"id": agent_id, "step": step, "class": cls, "values": list(values)}, v["expect"])
    if data[14:16] == b"\0\0":  # reserved is written as 0
        assert encode_state(agent_id, step, values, cls) == data


COMMANDS = load("commands.json")


@pytest.mark.parametrize("v", COMMANDS["vectors"], ids=lambda v: v["name"])
def test_command(v):
    secret = bytes.fromhex(COMMANDS["secret_hex"])
    try:
        cmd = decode(bytes.fromhex(v["payload_hex"]), secret)
    except CommandRejected as exc:
        assert v["expect"] == {"reject": exc.reason}
        return
    got = {
        "accept": True,
        "seq": cmd.seq,
        "gesture": cmd.gesture,
        "n_agents": cmd.n_agents,
        "classes": [
            [c.name, c.share, [[w.x, w.y, w.r, w.s, w.alpha, w.beta, w.mu] for w in c.route]] for c in cmd.classes
        ],
        "beta": cmd.beta,
        "mu": cmd.mu,
    }
    if cmd.fill is not None:
        got["fill"] = {
            "rings": [[list(p) for p in ring] for ring in cmd.fill.rings],
            "alpha": cmd.fill.alpha,
            "s": cmd.fill.s,
            "zones": [[z.x, z.y, z.ux, z.uy, z.a, z.b, z.beta, z.mu] for z in cmd.fill.zones],
        }
    assert same(got, v["expect"])


def control_list(c: Control) -> list:
    return [c.wx, c.wy, c.r, c.s, c.alpha, c.beta, c.mu, c.push_x, c.push_y]


SEQUENCES = load("command_sequences.json")


@pytest.mark.parametrize("seq", SEQUENCES["sequences"], ids=lambda s: f"agent{s['agent_id']}")
def test_command_follower(seq):
    spec = SimpleNamespace(
        secret=SEQUENCES["secret_hex"],
        id=seq["agent_id"],
        static_control=lambda: Control(1.0, 2.0, 0.5, 1.0, 0.0, 2.0, 0.0, 0.0, 0.0),
    )
    f = CommandFollower(spec)
    for k, step in enumerate(seq["steps"]):
        if "offer_hex" in step:
            assert f.offer(bytes.fromhex(step["offer_hex"])) == step["expect"], k
            assert f.has_command == step["has_command"], k
        else:
            state = np.zeros(NFIELDS)
            state[0], state[1] = step["control"]
            assert same(control_list(f.control(state, 0)), step["expect"]), k
            assert f.particle_class == step["particle_class"]
            report = f.report()
            assert (report.pop("first_command_at") is None) == (report["commands_accepted"] == 0)
            assert report == step["report"], k


ROUTE = load("route.json")


@pytest.mark.parametrize("case", ROUTE["class_of"], ids=lambda c: f"n{c['n']}_k{len(c['shares'])}")
def test_class_of(case):
    assert class_counts(case["n"], case["shares"]) == case["counts"]
    assert [class_of(i, case["n"], case["shares"]) for i in case["ids"]] == case["classes"]


@pytest.mark.parametrize("case", ROUTE["route_follower"], ids=lambda c: f"route{len(c['route'])}")
def test_route_follower(case):
    f = RouteFollower([Waypoint(*w) for w in case["route"]], case["beta"], case["mu"])
    for step in case["steps"]:
        state = np.zeros(NFIELDS)
        state[0], state[1] = step["position"]
        assert same(control_list(f.control(state, 0)), step["control"])
        assert f.index == step["index"]


FILL = load("fill.json")


@pytest.mark.parametrize("case", FILL["followers"], ids=lambda c: c["name"])
def test_fill_follower(case):
    rings = tuple(tuple((x, y) for x, y in ring) for ring in case["rings"])
    zones = tuple(Zone(*z) for z in case["zones"])
    f = FillFollower(Fill(rings, case["alpha"], case["s"], zones), case["beta"], case["mu"])
    for step in case["steps"]:
        x, y = step["position"]
        assert inside(rings, x, y) == step["inside"], step
        assert same(list(nearest_point(rings, x, y)), step["nearest"]), step
        state = np.zeros(NFIELDS)
        state[0], state[1] = x, y
        assert same(control_list(f.control(state, 0)), step["control"]), step
        assert f.index == 0


def test_edges_cross():
    for case in FILL["edges_cross"]:
        assert edges_cross([[tuple(v) for v in ring] for ring in case["rings"]]) == case["cross"], case


def test_files_are_current():
    """The committed files are what the generator makes from today's codecs."""
    spec = importlib.util.spec_from_file_location("make_vectors", VECTORS / "make_vectors.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert same(gen.state_vectors(), load("state_records.json"))
    vectors = gen.command_vectors()
    assert same(vectors, COMMANDS["vectors"])
    payloads = {v["name"]: bytes.fromhex(v["payload_hex"]) for v in vectors}
    assert same(gen.follower_sequences(payloads), SEQUENCES["sequences"])
    assert same(gen.route_vectors(), ROUTE)
    assert same(gen.fill_vectors(), FILL)
    assert close(gen.sph_step_vectors(), load("sph_steps.json"))
    assert close(gen.radio_vectors(), load("radio.json"))
