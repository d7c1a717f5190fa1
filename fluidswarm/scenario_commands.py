"""`fluidswarm run SCENARIO` and `fluidswarm demo`: the whole system on a scenario file."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fluidswarm.errors import UserError
from fluidswarm.scenario import Scenario, load_scenario

REPO = Path(__file__).resolve().parent.parent
DEMO_SCENARIO = REPO / "scenarios" / "demo_v_sign.toml"


def register(sub) -> None:
    p = sub.add_parser("run", help="run a scenario file: router, agents, coordinator, recorder, failures, summary")
    p.add_argument("scenario", help="scenarios/NAME.toml")
    p.add_argument("--agents", type=int, help="override the scenario's number of agents")
    p.add_argument("--out", help="output folder (default: out/<scenario name>)")
    p.set_defaults(func=_run)
    p = sub.add_parser("demo", help="the main job: a real V-sign photograph imitated by ~60 agent processes")
    p.add_argument("--out", default="out/demo")
    p.set_defaults(func=_demo)


@dataclass
class RunSummary:
    scenario: str
    agents: int
    steps: int
    steps_per_second: float
    finished: int
    mcap: Path
    figures: dict = field(default_factory=dict)
    failures: list = field(default_factory=list)
    pictures: list = field(default_factory=list)
    passed: bool = True
    why: list = field(default_factory=list)


class ProgressLine:
    """One live status line on stderr: step, agents alive, steps/s, failures injected."""

    def __init__(self, launcher, steps: int, injector=None):
        self.launcher, self.steps, self.injector = launcher, steps, injector
        self.t0 = time.monotonic()
        self.tty = sys.stderr.isatty()
        self.last = 0.0

    def __call__(self) -> None:
        now = time.monotonic()
        if now - self.last < (0.2 if self.tty else 5.0):
            return
        self.last = now
        step = max(self.launcher.max_step, 0)
        width = 30
        filled = width * min(step, self.steps) // max(self.steps, 1)
        rate = step / max(now - self.t0, 1e-9)
        injected = len(self.injector.log.injected) if self.injector else 0
        line = (f"[{'#' * filled}{' ' * (width - filled)}] step {step}/{self.steps}  alive {len(self.launcher.swarm.alive)}"
                f"  {rate:.1f} steps/s  failures {injected}")
        sys.stderr.write(("\r" + line) if self.tty else (line + "\n"))
        sys.stderr.flush()

    def done(self) -> None:
        if self.tty:
            sys.stderr.write("\n")


def experiment_setup(sc: Scenario, agents: int):
    from agent.sph.params import SPHParams
    from agent.sph import setups

    base = {"branching": setups.branching, "drag": setups.drag}[sc.experiment]
    default = base(agents)
    if sc.sph or sc.dt:
        fields = default.params.as_dict()
        fields.update(sc.sph)
        if sc.dt:
            fields["dt"] = sc.dt
        fields["domain"] = tuple(fields["domain"])
        return base(agents, params=SPHParams(**fields)) if sc.experiment == "drag" else setups.branching(agents, params=SPHParams(**fields))
    return default


def branch_gap(positions: np.ndarray, classes: np.ndarray) -> float:
    """Edge-branch separation in y in the central 40% of the flow (same measure as the physics tests)."""
    x = positions[:, 0]
    lo, hi = np.percentile(x, [30, 70])
    slab = (x >= lo) & (x <= hi)
    up, down = slab & (classes == 2), slab & (classes == 0)
    if not up.any() or not down.any():
        return 0.0
    return float(np.median(positions[up, 1]) - np.median(positions[down, 1]))


def run_experiment(sc: Scenario, agents: int, out: Path) -> RunSummary:
    from agent.launcher import Launcher, run_swarm
    from fluidswarm.failures import FailureInjector
    from fluidswarm.recording.replay import replay

    setup = experiment_setup(sc, agents)
    steps = sc.steps or 400
    out.mkdir(parents=True, exist_ok=True)
    mcap = out / f"{sc.name}.mcap"
    drop = {f.agent: f.fraction for f in sc.failures if f.kind == "drop"}
    meta = {"scenario": sc.name, "scenario_file": str(sc.path), "experiment": sc.experiment, "agents": agents,
            "steps": steps, "seed": sc.seed, "params": setup.params.as_dict(), "agent_ids": [int(i) for i in setup.ids],
            "failures": [f.__dict__ for f in sc.failures]}
    with Launcher(agent_timeout=2.0) as launcher:
        launcher.start_recorder(str(mcap), meta, setup.params.dt)
        launcher.track_progress()
        injector = FailureInjector(launcher, sc.failures, setup.ids, sc.seed)
        bar = ProgressLine(launcher, steps, injector)
        res = run_swarm(setup, steps, launcher=launcher, on_started=lambda la: injector.start(), progress=bar,
                        per_agent={i: {"drop_out": f} for i, f in drop.items()})
        injector.stop()
        bar.done()
    done = {i: r for i, r in res.finals.items() if r.get("status") == "done"}
    ids = sorted(done)
    pos = np.array([done[i]["state"][:2] for i in ids]) if ids else np.empty((0, 2))
    classes = setup.classes[np.searchsorted(setup.ids, ids)] if ids else np.empty(0, int)
    summary = RunSummary(sc.name, agents, steps, res.steps_per_second(), len(done), mcap, failures=injector.log.injected)
    if sc.experiment == "branching":
        summary.figures["branch_gap"] = branch_gap(pos, classes)
    if sc.experiment == "drag":
        summary.figures["mean_vx"] = float(np.mean([done[i]["state"][2] for i in ids])) if ids else 0.0
    rep = replay(mcap, out)
    summary.pictures = [str(p) for p in rep.paths]
    if summary.figures.get("branch_gap", np.inf) < sc.passing.min_branch_gap:
        summary.passed = False
        summary.why.append(f"branch_gap {summary.figures['branch_gap']:.2f} < {sc.passing.min_branch_gap}")
    return summary


def print_summary(s: RunSummary) -> None:
    print(f"scenario={s.scenario}")
    print(f"agents={s.agents}")
    print(f"finished={s.finished}")
    print(f"steps={s.steps}")
    print(f"steps_per_second={s.steps_per_second:.2f}")
    for k, v in s.figures.items():
        print(f"{k}={v:.4f}" if isinstance(v, float) else f"{k}={v}")
    print(f"failures_injected={len(s.failures)}")
    for f in s.failures:
        print(f"  {f}")
    print(f"failures_survived={'true' if s.finished > 0 else 'false'}")
    print(f"mcap={s.mcap}")
    for p in s.pictures:
        print(f"picture={p}")
    print(f"passed={'true' if s.passed else 'false'}" + ("" if s.passed else "  (" + "; ".join(s.why) + ")"))


def execute(sc: Scenario, agents: int | None, out: Path) -> RunSummary:
    agents = agents or sc.agents
    if sc.experiment == "imitate":
        try:
            from coordinator.scenario_run import run_imitation_scenario  # type: ignore[import-not-found]
        except ImportError:
            raise UserError(f"{sc.path}: imitation scenarios need the coordinator (not installed in this build)") from None
        return run_imitation_scenario(sc, agents, out)
    return run_experiment(sc, agents, out)


def _run(args) -> int:
    sc = load_scenario(args.scenario)
    if args.agents is not None and args.agents < 1:
        raise UserError(f"--agents: must be >= 1, got {args.agents}")
    out = Path(args.out or f"out/{sc.name}")
    summary = execute(sc, args.agents, out)
    print_summary(summary)
    return 0 if summary.passed else 1


def _demo(args) -> int:
    sc = load_scenario(DEMO_SCENARIO)
    summary = execute(sc, None, Path(args.out))
    print_summary(summary)
    return 0 if summary.passed else 1
