"""Scenario files (`scenarios/*.toml`): read with tomllib into typed dataclasses, validated once.

An unknown key or a bad value is a `UserError` naming the file, the key and the problem.
"""

from __future__ import annotations

import io
import math
import tomllib
from dataclasses import dataclass, field, fields
from enum import StrEnum
from pathlib import Path
from typing import Any

from agent.protocol.errors import UserError
from agent.protocol.spec import MODES, SyncMode
from agent.sph.obstacles import Obstacle, obstacles_from
from agent.sph.params import SPHParams
from agent.sph.radio import PERFECT, RadioModel
from agent.sph.robot import POINT, RobotModel
from coordinator.control.imitation_setup import CONTROLLERS as IMITATION_CONTROLLERS
from coordinator.control.imitation_setup import DEFAULT_CONTROLLER
from fluidswarm.orchestration.run_config import AGENTS, Sync, agents_problem, check, positive_problem

CONTROLLERS = (*IMITATION_CONTROLLERS, "none")  # none: a physics experiment, no coordinator
SYNC_MODES = MODES
FAILURE_KINDS = ("kill", "freeze", "drop", "kill_coordinator", "late_join")
# The scenario files stay at the top level (scenarios/); a wheel carries them, their inputs with them, as the
# package data of this package (pyproject.toml: package-dir and package-data of "fluidswarm.scenarios").
PACKAGED_SCENARIOS = "fluidswarm.scenarios"


def scenarios_dir() -> Path:
    """The shipped scenario files: the installed package data (site-packages/fluidswarm/scenarios), else the
    source tree's top-level scenarios/ (a checkout or an editable install)."""
    here = Path(__file__).resolve().parent
    installed = here / PACKAGED_SCENARIOS.rpartition(".")[2]
    return installed if installed.is_dir() else here.parent / "scenarios"


def find_scenario(path: str | Path) -> Path:
    """`path` if it exists; else a shipped scenario of that name (`NAME`, `NAME.toml` or `scenarios/NAME.toml`,
    so the commands of docs/scenarios.md work from any folder once installed); else `path` itself."""
    path = Path(path)
    if path.exists() or path.is_absolute() or path.parent not in (Path("."), Path("scenarios")):
        return path
    shipped = scenarios_dir() / (path.name if path.suffix == ".toml" else path.name + ".toml")
    return shipped if shipped.is_file() else path


class Experiment(StrEnum):
    """What a scenario runs: an imitation of its input, or one of the thesis' physics experiments."""

    IMITATE = "imitate"
    BRANCHING = "branching"
    DRAG = "drag"


EXPERIMENTS = tuple(e.value for e in Experiment)


@dataclass(frozen=True)
class Failure:
    """One injected failure.

    kind      kill (SIGKILL `count` agents) | freeze (SIGSTOP `count` agents for `seconds`, then SIGCONT) |
              drop (agent `agent` drops `fraction` of its outgoing states from the start) |
              kill_coordinator | late_join (`count` extra agents start)
    at_step   step at which it happens (drop: ignored, active from the start)
    """

    kind: str
    at_step: int = 0
    count: int = 1
    seconds: float = 3.0
    fraction: float = 0.3
    agent: int = 0


@dataclass(frozen=True)
class PassCriteria:
    """The run fails (non-zero exit) when a figure misses its bound (0 / false: not checked).

    min_fidelity_iou     final formation vs target silhouette (coordinator/control/fidelity.py)
    min_fidelity_inside  share of particles inside the silhouette
    max_nn_cv            uniformity: coefficient of variation of nearest-neighbour distances (clumps: high)
    min_branch_gap       m, edge-branch separation of the branching experiment
    min_fidelity_ratio   fidelity_iou with the scenario's failures / without them (same seed): `run` then
                         also runs the scenario without failures first, side by side
    max_stall_seconds    longest wall-clock gap between two consecutive steps of the swarm
    min_finished         share of the agents not killed on purpose that finish every step
    complete_mcap        the MCAP holds every alive agent's state at every step (`replay --check`)
    no_collisions        no two bodies touched (collisions = 0, fluidswarm/recording/contacts.py)
    no_obstacle_penetrations  no body overlapped an obstacle (obstacle_penetrations = 0)
    """

    min_fidelity_iou: float = 0.0
    min_fidelity_inside: float = 0.0
    max_nn_cv: float = 0.0
    min_branch_gap: float = 0.0
    min_fidelity_ratio: float = 0.0
    max_stall_seconds: float = 0.0
    min_finished: float = 0.0
    complete_mcap: bool = False
    no_collisions: bool = False
    no_obstacle_penetrations: bool = False


@dataclass(frozen=True)
class Scenario:
    name: str
    path: Path
    experiment: str = "imitate"
    input: str = ""  # image, folder of frames or video; relative to the scenario file, its folder's parent or cwd
    frame: int = -1  # which frame of a clip/folder to imitate (-1: the first; see frame_steps)
    frame_steps: int = 0  # > 0: a gesture sequence, every frame shown for this many steps (thesis ch. 5)
    controller: str = DEFAULT_CONTROLLER
    agents: int = AGENTS
    steps: int = 0  # 0: the experiment's default
    dt: float = 0.0  # 0: the experiment's default
    seed: int = 0
    sync: str = SyncMode.LOCKSTEP
    async_rate: float = Sync.rate  # steps/s of each agent's own clock (sync = "async")
    async_max_age: float = Sync.max_age  # s: older neighbour states are not used (sync = "async")
    neighbour_timeout: float = 0.0  # s a silent expected neighbour is waited for (0: the experiment's default)
    sph: dict = field(default_factory=dict)
    robot: RobotModel = POINT  # [robot]: kind, radius, v_max, a_max, omega_max, offset (agent/sph/robot.py)
    radio: RadioModel = PERFECT  # [radio]: loss, latency, noise (agent/sph/radio.py), seeded from `seed`
    obstacles: tuple[Obstacle, ...] = ()  # [[obstacle]]: circles and polygons (agent/sph/obstacles.py), domain m
    start: tuple[float, float] | None = None  # the start layout's centre [m] (None: the experiment's own)
    failures: tuple[Failure, ...] = ()
    passing: PassCriteria = PassCriteria()
    description: str = ""

    def input_path(self) -> Path | None:
        if not self.input:
            return None
        p = Path(self.input)
        for base in (self.path.parent, self.path.parent.parent, Path.cwd()):
            if (base / p).exists():
                return (base / p).resolve()
        return p


def _typed(file: str, key: str, value, kind):
    ok = {
        int: isinstance(value, int) and not isinstance(value, bool),
        float: isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value),
        str: isinstance(value, str),
        bool: isinstance(value, bool),
        dict: isinstance(value, dict),
    }[kind]
    if not ok:
        raise UserError(f"{file}: key '{key}': expected {kind.__name__}, got {value!r}")
    return float(value) if kind is float else value


def _check_keys(file: str, where: str, table: dict, allowed) -> None:
    for k in table:
        if k not in allowed:
            raise UserError(f"{file}: key '{where}{k}': unknown key (allowed: {', '.join(sorted(allowed))})")


def read_toml(path: Path, name: str, missing: str) -> dict:
    """The TOML document in `path`; a file that cannot be read or parsed is one UserError "<name>: ..."
    (`missing`: what to say of a file that is not there)."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise UserError(f"{name}: {missing}") from None
    except OSError as exc:
        raise UserError(f"{name}: cannot read ({exc})") from None
    return parse_toml(data, name)


def parse_toml(data: bytes, name: str) -> dict:
    """The TOML document in the bytes of a file, decoded as `Path.read_text` does (the locale's encoding,
    universal newlines); what cannot be decoded or parsed is one UserError "<name>: ..."."""
    try:
        return tomllib.loads(io.TextIOWrapper(io.BytesIO(data)).read())
    except UnicodeDecodeError as exc:
        raise UserError(f"{name}: cannot read ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"{name}: not valid TOML ({exc})") from None
    except RecursionError:  # arrays or inline tables nested deeper than tomllib's stack
        raise UserError(f"{name}: not valid TOML (nested too deep)") from None


def load_scenario(path: str | Path) -> Scenario:
    path = find_scenario(path)
    raw = read_toml(path, str(path), f"no such scenario file (the shipped ones, run by name: {scenarios_dir()})")
    return _scenario(raw, path)


def parse_scenario(data: bytes, path: Path) -> Scenario:
    """`load_scenario` of the bytes of scenario file `path` (the fuzz target, fuzz/python_targets.py)."""
    return _scenario(parse_toml(data, str(path)), path)


def _scenario(raw: dict, path: Path) -> Scenario:
    file = str(path)
    top = {
        "name",
        "description",
        "experiment",
        "input",
        "frame",
        "frame_steps",
        "controller",
        "agents",
        "steps",
        "dt",
        "seed",
        "sync",
        "async_rate",
        "async_max_age",
        "neighbour_timeout",
        "sph",
        "robot",
        "radio",
        "obstacle",
        "start",
        "failures",
        "pass",
    }
    _check_keys(file, "", raw, top)
    kw: dict = {"name": _typed(file, "name", raw.get("name", path.stem), str), "path": path}
    for key, kind in (
        ("description", str),
        ("experiment", str),
        ("input", str),
        ("controller", str),
        ("agents", int),
        ("steps", int),
        ("dt", float),
        ("seed", int),
        ("sync", str),
        ("frame", int),
        ("frame_steps", int),
        ("async_rate", float),
        ("async_max_age", float),
        ("neighbour_timeout", float),
    ):
        if key in raw:
            kw[key] = _typed(file, key, raw[key], kind)
    if kw.get("experiment", Experiment.IMITATE) not in EXPERIMENTS:
        raise UserError(f"{file}: key 'experiment': must be one of {EXPERIMENTS}, got {kw['experiment']!r}")
    if kw.get("controller", DEFAULT_CONTROLLER) not in CONTROLLERS:
        raise UserError(f"{file}: key 'controller': must be one of {CONTROLLERS}, got {kw['controller']!r}")
    if kw.get("sync", SyncMode.LOCKSTEP) not in SYNC_MODES:
        raise UserError(f"{file}: key 'sync': must be one of {SYNC_MODES}, got {kw['sync']!r}")
    check(f"{file}: key 'agents'", agents_problem(kw.get("agents", AGENTS)))
    if kw.get("steps", 0) < 0:
        raise UserError(f"{file}: key 'steps': must be >= 0, got {kw['steps']}")
    if kw.get("dt", 0.0) < 0:
        raise UserError(f"{file}: key 'dt': must be > 0, got {kw['dt']}")
    if kw.get("frame", -1) < -1:
        raise UserError(f"{file}: key 'frame': must be >= 0 (or -1 for the first), got {kw['frame']}")
    if kw.get("frame_steps", 0) < 0:
        raise UserError(f"{file}: key 'frame_steps': must be >= 0, got {kw['frame_steps']}")
    if kw.get("frame_steps", 0) and kw.get("frame", -1) >= 0:
        raise UserError(f"{file}: key 'frame_steps': a gesture sequence shows every frame, drop 'frame'")
    for key in ("async_rate", "async_max_age"):
        if key in kw:
            check(f"{file}: key '{key}'", positive_problem(kw[key]))
    if kw.get("neighbour_timeout", 0.0) < 0:
        raise UserError(f"{file}: key 'neighbour_timeout': must be > 0, got {kw['neighbour_timeout']}")
    if kw.get("experiment", Experiment.IMITATE) == Experiment.IMITATE and not kw.get("input"):
        raise UserError(f"{file}: key 'input': an imitation scenario needs an input image, folder or video")
    sph = _typed(file, "sph", raw.get("sph", {}), dict)
    allowed_sph = {f.name for f in fields(SPHParams)}
    _check_keys(file, "sph.", sph, allowed_sph)
    try:
        sph_kw: dict[str, Any] = {k: (tuple(v) if k == "domain" else v) for k, v in sph.items()}
        SPHParams(**sph_kw)
    except (ValueError, TypeError) as exc:
        raise UserError(f"{file}: key 'sph': {exc}") from None
    for key in ("beta", "mu"):  # an accepted key must act: in an imitation the gesture command sets them
        if key in sph and kw.get("experiment", Experiment.IMITATE) == Experiment.IMITATE:
            raise UserError(
                f"{file}: key 'sph.{key}': an imitation's stiffness and viscosity are set per class "
                f"by the gesture command, not by [sph] (it acts in the branching and drag experiments)"
            )
    kw["sph"] = sph
    from fluidswarm.options import check_lockstep, radio_model, robot_model

    kw["robot"] = robot_model(None, _typed(file, "robot", raw.get("robot", {}), dict), where=file)

    kw["radio"] = radio_model(_typed(file, "radio", raw.get("radio", {}), dict), kw.get("seed", 0), where=file)
    check_lockstep(kw["radio"], kw.get("sync", "lockstep"), f"{file}: key 'radio'")
    kw["obstacles"] = scenario_obstacles(file, raw.get("obstacle", []))
    if "start" in raw:
        start = raw["start"]
        if (
            not isinstance(start, list)
            or len(start) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in start)
        ):
            raise UserError(f"{file}: key 'start': must be [x, y] finite numbers (m), got {start!r}")
        kw["start"] = (float(start[0]), float(start[1]))
    failures = []
    raw_f = raw.get("failures", [])
    if not isinstance(raw_f, list):
        raise UserError(f"{file}: key 'failures': expected an array of tables ([[failures]])")
    allowed_f = {f.name for f in fields(Failure)}
    for k, item in enumerate(raw_f):
        where = f"failures[{k}]."
        if not isinstance(item, dict):
            raise UserError(f"{file}: key 'failures[{k}]': expected a table")
        _check_keys(file, where, item, allowed_f)
        kind = _typed(file, where + "kind", item.get("kind", ""), str)
        if kind not in FAILURE_KINDS:
            raise UserError(f"{file}: key '{where}kind': must be one of {FAILURE_KINDS}, got {kind!r}")
        f = {"kind": kind}
        for key, t in (("at_step", int), ("count", int), ("seconds", float), ("fraction", float), ("agent", int)):
            if key in item:
                f[key] = _typed(file, where + key, item[key], t)
        if f.get("at_step", 0) < 0 or f.get("count", 1) < 0 or f.get("seconds", 1.0) <= 0 or f.get("agent", 0) < 0:
            raise UserError(f"{file}: key '{where}': at_step/count/agent must be >= 0 and seconds > 0")
        if not 0 <= f.get("fraction", 0.3) < 1:
            raise UserError(f"{file}: key '{where}fraction': must be in [0, 1), got {f['fraction']}")
        failures.append(Failure(**f))
    kw["failures"] = tuple(failures)
    passing = _typed(file, "pass", raw.get("pass", {}), dict)
    _check_keys(file, "pass.", passing, {f.name for f in fields(PassCriteria)})
    kinds = {f.name: (bool if f.type in (bool, "bool") else float) for f in fields(PassCriteria)}
    crit = {k: _typed(file, "pass." + k, v, kinds[k]) for k, v in passing.items()}
    for k, v in crit.items():
        if kinds[k] is float and v < 0:
            raise UserError(f"{file}: key 'pass.{k}': must be >= 0, got {v}")
    kw["passing"] = PassCriteria(**crit)
    return Scenario(**kw)


def scenario_obstacles(file: str, tables) -> tuple[Obstacle, ...]:
    """The [[obstacle]] tables as obstacles (agent/sph/obstacles.py); bad input names the key."""
    if not isinstance(tables, list):
        raise UserError(f"{file}: key 'obstacle': expected an array of tables ([[obstacle]])")
    try:
        return obstacles_from(tables, "obstacle")
    except ValueError as exc:
        key, _, problem = str(exc).partition(": ")
        raise UserError(f"{file}: key '{key}': {problem}") from None


def obstacles_file(path: str | None) -> tuple[Obstacle, ...]:
    """The obstacles of `--obstacles FILE` (None: none): its [[obstacle]] tables; bad input is one line naming
    the file and the key."""
    if path is None:
        return ()
    raw = read_toml(Path(path), f"--obstacles {path}", "no such file")
    if "obstacle" not in raw:
        raise UserError(f"--obstacles {path}: key 'obstacle': the file holds no [[obstacle]] table")
    return scenario_obstacles(path, raw["obstacle"])
