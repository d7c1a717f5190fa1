"""Each default of a run is declared once (issue 52 item 1).

The agent's crate (agent/native/src/spec.rs, sph.rs) fills the fields a spec leaves out with its own defaults;
the Python side's (agent/sph/params.py SPHParams, agent/sph/particle.py Control, agent/protocol/spec.py
AgentSpec) must be the same numbers, or a launcher's idea of a run and the agents' differ silently. Read from
the crate's own decoder: a spec with every optional field left out, as the agent would read it."""

from __future__ import annotations

import json
from dataclasses import asdict, fields

from agent.protocol.spec import AgentSpec
from agent.records import native
from agent.sph.params import SPHParams
from agent.sph.particle import Control


def decoded_with_defaults() -> dict:
    required = {"run": "r", "id": 0, "connect": ["tcp/127.0.0.1:7447"], "steps": 1, "initial": [0.0, 0.0, 0.0, 0.0]}
    return native.spec_decode(json.dumps(required))


def test_the_crates_sph_parameters_left_out_are_the_python_defaults():
    rust = decoded_with_defaults()["params"]
    python = {k: (list(v) if k == "domain" else str(v) if k == "border" else v) for k, v in asdict(SPHParams()).items()}
    assert rust == python  # beta, mu, rho0, dt, ... each in agent/native/src/sph.rs Params::default


def test_the_crates_control_left_out_is_the_python_default():
    assert decoded_with_defaults()["control"] == asdict(Control())  # sph.rs Control::default: beta 2, mu 0


def test_the_crates_spec_fields_left_out_are_the_python_defaults():
    rust = decoded_with_defaults()
    python = {f.name: getattr(AgentSpec("r", 0, [], 1, []), f.name) for f in fields(AgentSpec)}
    for name in ("timeout", "start_timeout", "drop_out", "secret", "join", "state_key_ids", "mode", "rate", "max_age"):
        assert rust[name] == python[name], name
