"""What one `fluidswarm bench` measured, typed once: `BenchRecord`.

`bench --json` prints it as one JSON object on stdout, and docs/benchmarks/results.json is the same object
(indented); the thesis reproduction (research/), the tests and ../shared/tools/acceptance read that.
`BenchRecord.from_dict` checks every field (a file can be stale or edited by hand), so a reader gets one error
naming the key, not a KeyError deep inside. Times in s unless the name says ms; memory in MB.

The README's benchmark figures are written from the record too (`readme_section`, `with_readme_section`;
`fluidswarm bench --readme`), and tests/test_docs.py fails when the README and results.json differ.
"""

from __future__ import annotations

import json
import types
import typing
from collections.abc import Set as AbstractSet
from dataclasses import asdict, dataclass, fields
from pathlib import Path

from agent.protocol.errors import UserError
from fluidswarm.orchestration.run import json_finite


class BenchRecordError(UserError, ValueError):
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
    pss_mb_per_agent: the agents' proportional set size at their end, mean: RSS counts the agent program's pages
    whole in every agent, Pss divides them among the agents (what one more agent costs; None in older records);
    all_cpu_us_per_agent_step: the CPU of every process of the run while it steps (agents, embedded router,
    recorder, launcher; from /proc) per agent-step, helpers_cpu_us_per_agent_step the helpers' share by process
    (the 2-core machine's real-time budget at N = 300 is 133 µs for all of them together; None in older records);
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
    pss_mb_per_agent: float | None = None
    all_cpu_us_per_agent_step: float | None = None
    helpers_cpu_us_per_agent_step: dict[str, float] | None = None


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
    def from_dict(cls, d: object) -> BenchRecord:
        if not isinstance(d, dict):
            raise BenchRecordError("expected a JSON object")
        runs = d.get("runs")
        if not isinstance(runs, list):
            raise BenchRecordError("key 'runs': expected a list")
        kw = _typed_fields(cls, d, "", skip={"machine", "runs", "gesture_imitation_formation"})
        kw["machine"] = Machine(**_typed_fields(Machine, d.get("machine"), "machine."))
        kw["runs"] = tuple(
            FailedRun(**_typed_fields(FailedRun, r, f"runs[{k}]."))
            if isinstance(r, dict) and "error" in r
            else LockstepRun(**_typed_fields(LockstepRun, r, f"runs[{k}]."))
            for k, r in enumerate(runs)
        )
        formation = d.get("gesture_imitation_formation")
        if not isinstance(formation, dict):
            raise BenchRecordError("key 'gesture_imitation_formation': expected an object")
        kw["gesture_imitation_formation"] = {
            str(g): None if v is None else Formation(**_typed_fields(Formation, v, f"gesture_imitation_formation.{g}."))
            for g, v in formation.items()
        }
        return cls(**kw)

    @classmethod
    def load(cls, path: str | Path) -> BenchRecord:
        """Read a results.json; OSError when unreadable, BenchRecordError (naming the file) when not a record."""
        try:
            return cls.from_dict(json.loads(Path(path).read_text()))
        except json.JSONDecodeError as exc:
            raise BenchRecordError(f"{path}: not JSON ({exc})") from None
        except BenchRecordError as exc:
            raise BenchRecordError(f"{path}: {exc}") from None


README_BEGIN = "<!-- benchmark figures: written by `fluidswarm bench --readme` from docs/benchmarks/results.json -->"
README_END = "<!-- end of the benchmark figures -->"
# issue 14's targets, the README's closing line: (what, bound); each is checked against the record
N300_STEPS_PER_SECOND, RSS_MB_PER_AGENT, N300_STARTUP_SECONDS, EXPONENT, GESTURE_SECONDS = 10, 15, 5, 1.1, 60


def _f(value: float | None, digits: int) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def _mark(ok: bool) -> str:
    return "met" if ok else "**missed**"


def readme_section(record: BenchRecord, fit_max_n: int) -> str:
    """The README's benchmark table and figures (the text between README_BEGIN and README_END)."""
    ok = {r.n: r for r in record.runs if isinstance(r, LockstepRun)}
    steps = sorted({r.steps for r in record.runs})
    lines = [
        (
            f"Measured {record.date[:10]} ({'quick' if record.quick else 'full'} run) on this "
            f"{record.machine.cores}-core, {round(record.machine.memory_mb / 1024)} GiB machine: lockstep runs of "
            f"{'/'.join(map(str, steps))} steps of the `verify` set-up (all SPH terms active), the compiled agent, "
            "side by side with the centralised drivers in the same run:"
        ),
        "",
        (
            "| N agents | steps/s | start-up s | msgs/agent/step | neighbours | CPU µs/agent-step | all processes' "
            "CPU µs/agent-step | RSS MB/agent "
            "| PSS MB/agent | per-particle central steps/s | vectorised steps/s | decentralised / per-particle time |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in record.runs:
        if isinstance(r, FailedRun):
            lines.append(f"| {r.n} | did not finish: {r.error} |" + " |" * 10)
            continue
        lines.append(
            f"| {r.n} | {_f(r.steps_per_second, 1)} | {_f(r.startup_seconds, 2)} | "
            f"{_f(r.msgs_per_agent_step, 1)} | {_f(r.neighbours_per_agent, 1)} | "
            f"{_f(r.cpu_us_per_agent_step, 0)} | {_f(r.all_cpu_us_per_agent_step, 0)} | "
            f"{_f(r.rss_mb_per_agent, 1)} | {_f(r.pss_mb_per_agent, 1)} | "
            f"{_f(r.centralised_steps_per_second, 0)} | {_f(r.vectorised_steps_per_second, 0)} | "
            f"{_f(r.decentralisation_ratio, 2)} |"
        )
    fitted = sorted(n for n in ok if n <= fit_max_n)
    lines.append("")
    if record.step_time_exponent is not None and fitted:
        lines += [
            f"Step time grows as N^{record.step_time_exponent} (log-log fit over N = {fitted[0]}…{fitted[-1]}).",
            "",
        ]
    gestures = []
    for g, seconds in record.gesture_imitation_seconds.items():
        if seconds is None:
            gestures.append(f"{g} failed")
            continue
        iou = record.gesture_imitation_fidelity_iou.get(g)
        formed = record.gesture_imitation_formation.get(g)
        how = (
            ""
            if formed is None
            else f", settled at {formed.seconds:.1f} s simulated"
            if formed.settled
            else f", not settled by the {formed.seconds:.0f} s cap"
        )
        gestures.append(f"{g} {seconds:.1f} s (IoU {_f(iou, 2)}{how})")
    lines.append(
        f"Hand-gesture imitation with {record.gesture_agents} agent processes (fill controller with finger "
        "zones, ends when settled; start-up, recorder and coordinator included): "
        + ", ".join(gestures)
        + " — thesis Table 6.1: 126–219 s per gesture."
    )
    lines.append("")
    perception = []
    if record.eigen_training_seconds is not None:
        perception.append(
            f"Eigen-image training ('best' pipeline, whole shared hand set): {record.eigen_training_seconds:.1f} s."
        )
    if record.region_controller_ms_per_video_frame is not None:
        perception.append(f"Region controller: {record.region_controller_ms_per_video_frame:.0f} ms per video frame.")
    if record.perception_error:
        perception.append(f"Perception timings missing: {record.perception_error}.")
    if perception:
        lines += [" ".join(perception), ""]
    lines.append(_targets(record, ok))
    return "\n".join(lines)


def _targets(record: BenchRecord, ok: dict[int, LockstepRun]) -> str:
    parts = []
    n300, n1000 = ok.get(300), ok.get(1000)
    if n300 is None:
        parts.append("N = 300 **did not run**")
    else:
        rss = n300.rss_mb_per_agent
        parts += [
            (
                f"N = 300 ≥ {N300_STEPS_PER_SECOND} steps/s ({n300.steps_per_second:.1f}, "
                f"{_mark(n300.steps_per_second >= N300_STEPS_PER_SECOND)})"
            ),
            (
                f"RSS ≤ {RSS_MB_PER_AGENT} MB per agent ({_f(rss, 1)}, "
                f"{_mark(rss is not None and rss <= RSS_MB_PER_AGENT)})"
            ),
            (
                f"start-up of 300 agents ≤ {N300_STARTUP_SECONDS} s ({n300.startup_seconds:.2f}, "
                f"{_mark(n300.startup_seconds <= N300_STARTUP_SECONDS)})"
            ),
        ]
    exp = record.step_time_exponent
    parts.append(f"exponent ≤ {EXPONENT} ({_f(exp, 3)}, {_mark(exp is not None and exp <= EXPONENT)})")
    if n1000 is None:
        parts.append("N = 1000 completes (**it did not**)")
    else:
        parts.append(
            f"N = 1000 completes ({n1000.agents_finished}/1000, {n1000.steps_per_second:.1f} steps/s, "
            f"start-up {n1000.startup_seconds:.1f} s, {_mark(n1000.agents_finished == 1000)})"
        )
    times = [v for v in record.gesture_imitation_seconds.values() if v is not None]
    done = len(times) == len(record.gesture_imitation_seconds) and times
    span = f"{min(times):.0f}–{max(times):.0f} s" if times else "none finished"
    parts.append(
        f"each {record.gesture_agents}-agent gesture imitation ≤ {GESTURE_SECONDS} s "
        f"({span}, {_mark(bool(done) and max(times) <= GESTURE_SECONDS)})"
    )
    return "**Targets (issue 14):** " + "; ".join(parts) + "."


def with_readme_section(readme: str, record: BenchRecord, fit_max_n: int) -> str:
    """`readme` with the text between its README_BEGIN and README_END lines replaced by `readme_section`;
    ValueError when it lacks them."""
    begin, end = readme.find(README_BEGIN), readme.find(README_END)
    if begin < 0 or end < begin:
        raise ValueError(f"no benchmark section: the lines {README_BEGIN!r} and {README_END!r} are missing")
    head = readme[: begin + len(README_BEGIN)]
    return f"{head}\n{readme_section(record, fit_max_n)}\n{readme[end:]}"


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


def _typed_fields(cls, d: object, where: str, skip: AbstractSet[str] = frozenset()) -> dict:
    """The fields of dataclass `cls` read from `d`, each checked; a missing optional field is None."""
    if not isinstance(d, dict):
        raise BenchRecordError(f"key '{where.rstrip('.') or '.'}': expected an object, got {d!r}")
    hints = typing.get_type_hints(cls)
    out: dict[str, typing.Any] = {}
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
