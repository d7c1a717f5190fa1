"""What one `fluidswarm bench` measured, typed once: `BenchRecord`.

`bench --json` prints it as one JSON object on stdout, and docs/benchmarks/results.json is the same object
(indented); `fluidswarm reproduce`, the tests and ../shared/tools/acceptance read that. `BenchRecord.from_dict`
checks every field (a file can be stale or edited by hand), so a reader gets one error naming the key, not a
KeyError deep inside. Times in s unless the name says ms; memory in MB.
"""

from __future__ import annotations

import json
import types
import typing
from dataclasses import asdict, dataclass, fields
from pathlib import Path

from fluidswarm.run import json_finite


class BenchRecordError(ValueError):
    """A results file or record that is not a BenchRecord; the message names the key and the problem."""


@dataclass(frozen=True)
class Machine:
    """Where the bench ran: CPU cores, memory [MB], Python version, platform string."""

    cores: int
    memory_mb: int
    python: str
    platform: str


@dataclass(frozen=True)
class LockstepRun:
    """One lockstep run of `n` agent processes for `steps` steps (fluidswarm.block.Block), and the same set-up
    through the reference drivers.

    steps_per_second / wall_seconds / startup_seconds: the swarm's rate, stepping time and start-up [s];
    msgs_per_agent_step, neighbours_per_agent: state messages received and neighbours per agent and step;
    cpu_seconds: CPU of all child processes; cpu_ms/us_per_agent_step: the stepping alone (start-up left out);
    rss_mb_per_agent / rss_mb_total: the agents' own peak RSS (VmHWM), mean and sum;
    centralised / vectorised_steps_per_second: the per-particle and vectorised reference drivers on one core;
    decentralisation_ratio(_vectorised): those rates over the swarm's (the cost of decentralisation)."""

    n: int
    steps: int
    agents_finished: int
    steps_per_second: float
    wall_seconds: float | None
    startup_seconds: float
    msgs_per_agent_step: float
    neighbours_per_agent: float
    cpu_seconds: float
    cpu_ms_per_agent_step: float | None
    cpu_us_per_agent_step: float | None
    rss_mb_per_agent: float | None
    rss_mb_total: float
    centralised_steps_per_second: float
    vectorised_steps_per_second: float
    decentralisation_ratio: float | None
    decentralisation_ratio_vectorised: float | None


@dataclass(frozen=True)
class FailedRun:
    """A lockstep run that did not come up or finish: recorded with why, not hidden."""

    n: int
    steps: int
    error: str


@dataclass(frozen=True)
class Formation:
    """When a gesture imitation's formation settled: `seconds` simulated; `settled` false when the step cap ended it."""

    seconds: float
    settled: bool


@dataclass(frozen=True)
class BenchRecord:
    """One bench run. `runs`: one per N (FIT_MAX_N and below enter `step_time_exponent`, the log-log slope of
    step time against N); gesture_*: per gesture (scissor, cylindrical, pinching) the wall time of
    `fluidswarm imitate` with `gesture_agents` agents [s], its fidelity (IoU) and its formation (None when
    it failed); eigen_*: eigen-image training [s] and inference [ms/image] on the shared hand set;
    region_controller_*: the region controller's cost [ms] per video frame and per hand photograph;
    perception_error: why the perception timings are missing (None when measured)."""

    date: str
    quick: bool
    machine: Machine
    runs: tuple[LockstepRun | FailedRun, ...]
    step_time_exponent: float | None
    gesture_agents: int
    gesture_imitation_seconds: dict[str, float | None]
    gesture_imitation_fidelity_iou: dict[str, float | None]
    gesture_imitation_formation: dict[str, Formation | None]
    eigen_training_seconds: float | None
    eigen_inference_ms: float | None
    region_controller_ms_per_video_frame: float | None
    region_controller_ms_per_hand_photo: float | None
    perception_error: str | None = None

    def as_dict(self) -> dict:
        """The JSON object (results.json's layout: perception_error only when there is one)."""
        d = asdict(self)
        d["runs"] = list(d["runs"])
        if d["perception_error"] is None:
            del d["perception_error"]
        return d

    def to_json(self, indent: int | None = None) -> str:
        """JSON text; non-finite numbers as null (JSON has no NaN)."""
        return json.dumps(json_finite(self.as_dict()), indent=indent, separators=None if indent else (",", ":"))

    @classmethod
    def from_dict(cls, d: object) -> "BenchRecord":
        if not isinstance(d, dict):
            raise BenchRecordError("expected a JSON object")
        runs = d.get("runs")
        if not isinstance(runs, list):
            raise BenchRecordError("key 'runs': expected a list")
        kw = _typed_fields(cls, d, "", skip={"machine", "runs", "gesture_imitation_formation"})
        kw["machine"] = Machine(**_typed_fields(Machine, d.get("machine"), "machine."))
        kw["runs"] = tuple(FailedRun(**_typed_fields(FailedRun, r, f"runs[{k}]."))
                           if isinstance(r, dict) and "error" in r
                           else LockstepRun(**_typed_fields(LockstepRun, r, f"runs[{k}]."))
                           for k, r in enumerate(runs))
        formation = d.get("gesture_imitation_formation")
        if not isinstance(formation, dict):
            raise BenchRecordError("key 'gesture_imitation_formation': expected an object")
        kw["gesture_imitation_formation"] = {
            str(g): None if v is None else Formation(**_typed_fields(Formation, v, f"gesture_imitation_formation.{g}."))
            for g, v in formation.items()}
        return cls(**kw)

    @classmethod
    def load(cls, path: str | Path) -> "BenchRecord":
        """Read a results.json; OSError when unreadable, BenchRecordError (naming the file) when not a record."""
        try:
            return cls.from_dict(json.loads(Path(path).read_text()))
        except json.JSONDecodeError as exc:
            raise BenchRecordError(f"{path}: not JSON ({exc})") from None
        except BenchRecordError as exc:
            raise BenchRecordError(f"{path}: {exc}") from None



def _value(value, hint, key: str):
    """`value` checked against a field's type hint (int, float, str, bool, X | None, dict[str, X])."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        args = typing.get_args(hint)
        if value is None and type(None) in args:
            return None
        hint = next(a for a in args if a is not type(None))
    if typing.get_origin(hint) is dict:
        if not isinstance(value, dict):
            raise BenchRecordError(f"key '{key}': expected an object, got {value!r}")
        inner = typing.get_args(hint)[1]
        return {str(k): _value(v, inner, f"{key}.{k}") for k, v in value.items()}
    ok = {
        int: isinstance(value, int) and not isinstance(value, bool),
        float: isinstance(value, (int, float)) and not isinstance(value, bool),
        str: isinstance(value, str),
        bool: isinstance(value, bool),
    }[hint]
    if not ok:
        raise BenchRecordError(f"key '{key}': expected {hint.__name__}, got {value!r}")
    return float(value) if hint is float else value


def _typed_fields(cls, d: object, where: str, skip: set[str] = frozenset()) -> dict:
    """The fields of dataclass `cls` read from `d`, each checked; a missing optional field is None."""
    if not isinstance(d, dict):
        raise BenchRecordError(f"key '{where.rstrip('.') or '.'}': expected an object, got {d!r}")
    hints = typing.get_type_hints(cls)
    out = {}
    for f in fields(cls):
        if f.name in skip:
            continue
        hint = hints[f.name]
        if f.name not in d:
            if type(None) in typing.get_args(hint):
                out[f.name] = None
                continue
            raise BenchRecordError(f"key '{where}{f.name}': missing")
        out[f.name] = _value(d[f.name], hint, where + f.name)
    return out
