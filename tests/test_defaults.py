"""Each default of a run is declared once (issue 52 item 1).

The agent's crate (agent/native/src/spec.rs, sph.rs) fills the fields a spec leaves out with its own defaults;
the Python side's (agent/sph/params.py SPHParams, agent/sph/particle.py Control, agent/protocol/spec.py
AgentSpec) must be the same numbers, or a launcher's idea of a run and the agents' differ silently. Read from
the crate's own decoder: a spec with every optional field left out, as the agent would read it."""

from __future__ import annotations

import ast
import json
from dataclasses import asdict, fields
from pathlib import Path

from agent.protocol.spec import AgentSpec
from agent.records import native
from agent.sph.params import SPHParams
from agent.sph.particle import Control
from agent.sph.radio import RadioModel
from agent.sph.robot import RobotModel


def decoded_with_defaults(**given) -> dict:
    """The spec the agent reads from the required fields (and `given`), every other field its crate's default."""
    required = {"run": "r", "id": 0, "connect": ["tcp/127.0.0.1:7447"], "steps": 1, "initial": [0.0, 0.0, 0.0, 0.0]}
    return native.spec_decode(json.dumps({**required, **given}))


def test_the_crates_sph_parameters_left_out_are_the_python_defaults():
    rust = decoded_with_defaults()["params"]
    python = {k: (list(v) if k == "domain" else str(v) if k == "border" else v) for k, v in asdict(SPHParams()).items()}
    assert rust == python  # beta, mu, rho0, dt, ... each in agent/native/src/sph.rs Params::default


def test_the_crates_control_left_out_is_the_python_default():
    assert decoded_with_defaults()["control"] == asdict(Control())  # sph.rs Control::default: beta 2, mu 0


def test_the_crates_robot_and_radio_fields_left_out_are_the_python_defaults():
    for kind in ("holonomic", "unicycle"):
        rust = decoded_with_defaults(robot={"kind": kind})["robot"]
        assert rust == RobotModel(kind=kind).as_dict(), kind  # radius, v_max, a_max, omega_max, offset
    assert decoded_with_defaults(radio={"loss": 0.1})["radio"] == RadioModel(loss=0.1).as_dict()


def test_the_crates_spec_fields_left_out_are_the_python_defaults():
    rust = decoded_with_defaults()
    python = {f.name: getattr(AgentSpec("r", 0, [], 1, []), f.name) for f in fields(AgentSpec)}
    for name in ("timeout", "start_timeout", "drop_out", "secret", "join", "state_key_ids", "mode", "rate", "max_age"):
        assert rust[name] == python[name], name


# --- no default written twice -----------------------------------------------------------------------------------

PACKAGES = ("agent", "swarmhost", "coordinator", "perception", "ros2link", "fluidswarm", "research")
ROOT = Path(__file__).resolve().parent.parent

# (what, value) -> the one module that writes it as a literal (None: no Python module does, the crate declares it
# and agent/protocol/spec.py reads it from there). `what` is a parameter, field, keyword, option or constant
# named so (`agents`, `n_agents`, `--agents`, `AGENTS`, `LAUNCH_AGENTS`, ...).
DECLARED: dict[tuple[str, float | str], str | None] = {
    ("agents", 60): "fluidswarm/orchestration/run_config.py",  # an imitation's swarm
    ("agents", 16): "fluidswarm/orchestration/run_config.py",  # launch's
    ("agents", 64): "fluidswarm/orchestration/run_config.py",  # verify's
    ("beta", 2.0): "agent/sph/params.py",  # the fluid's stiffness (sph.rs: checked equal above)
    ("mu", 0.2): "coordinator/control/material.py",  # the imitation's viscosity
    ("rate", 12.0): None,  # an async agent's rate: spec.rs DEFAULT_RATE
    ("max_age", 1.0): None,  # an async agent's max_age: spec.rs DEFAULT_MAX_AGE
    ("fps", 5.0): "perception/stream.py",  # a camera's pace (StreamParams)
    ("stall_seconds", 5.0): "perception/stream.py",
    ("controller", "fill"): None,  # an imitation's controller: imitation_setup.py DEFAULT_CONTROLLER (an enum's)
}
ALIASES = {"n_agents": "agents", "async_rate": "rate", "async_max_age": "max_age"}


def _what(name: str) -> str | None:
    """The watched default a name stands for: `--max-age` -> max_age, `LAUNCH_AGENTS` -> agents, ..."""
    n = name.lstrip("-").replace("-", "_").lower()
    n = ALIASES.get(n, n)
    for what, _value in DECLARED:
        if n == what or n.endswith("_" + what) or n.startswith(what + "_"):  # `beta_edge`: a fluid's beta too
            return what
    return None


def _number(node: ast.expr) -> float | str | None:
    """A number or string literal (a watched default's value), else None."""
    if (
        isinstance(node, ast.Constant)
        and isinstance(node.value, int | float | str)
        and not isinstance(node.value, bool)
    ):
        return node.value
    return None


def literal_defaults(source: str) -> list[tuple[str, float | str, int]]:
    """(what, value, line) of each watched name given a number literal in `source`: a parameter's default, a
    (dataclass) field or constant, a keyword argument, an argparse option's `default=`."""
    found = []
    for node in ast.walk(ast.parse(source)):
        pairs: list[tuple[str, ast.expr]] = []
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            a = node.args
            positional = a.posonlyargs + a.args
            pairs += [(p.arg, d) for p, d in zip(positional[len(positional) - len(a.defaults) :], a.defaults)]
            pairs += [(p.arg, d) for p, d in zip(a.kwonlyargs, a.kw_defaults) if d is not None]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.value is not None:
            pairs.append((node.target.id, node.value))
        elif isinstance(node, ast.Assign):
            pairs += [(t.id, node.value) for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.Call):
            for kw in node.keywords:
                if kw.arg is None:
                    continue
                pairs.append((kw.arg, kw.value))
                if kw.arg == "default":  # add_argument("-n", "--agents", default=...)
                    pairs += [
                        (a.value, kw.value)
                        for a in node.args
                        if isinstance(a, ast.Constant) and isinstance(a.value, str)
                    ]
        for name, value in pairs:
            what, number = _what(name), _number(value)
            if what is not None and number is not None and (what, number) in DECLARED:
                found.append((what, number, node.lineno))
    return found


def test_the_scan_finds_a_default_written_again():
    again = "def imitate(agents: int = 60, beta=2.0):\n    p.add_argument('--max-age', type=float, default=1.0)\n"
    again += "p.add_argument('--controller', default='fill')\np.add_argument('--beta-edge', default=2.0)\n"
    assert sorted(literal_defaults(again), key=str) == [
        ("agents", 60, 1),
        ("beta", 2.0, 1),
        ("beta", 2.0, 4),
        ("controller", "fill", 3),
        ("max_age", 1.0, 2),
    ]
    assert literal_defaults("def f(agents=AGENTS, steps=60):\n    g(beta=20.0)\n") == []


def test_each_default_is_written_once_in_its_module():
    where: dict[tuple[str, float | str], list[str]] = {key: [] for key in DECLARED}
    for package in (*PACKAGES, "scripts"):  # the developer's tools too: they measure the same runs
        for path in sorted((ROOT / package).rglob("*.py")):
            for what, value, line in literal_defaults(path.read_text()):
                where[(what, value)].append(f"{path.relative_to(ROOT)}:{line}")
    for key, home in DECLARED.items():
        expected = [] if home is None else [home]
        assert [w.rsplit(":", 1)[0] for w in where[key]] == expected, f"{key} written at {where[key]}"
