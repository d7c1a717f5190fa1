"""`fluidswarm run SCENARIO` and `fluidswarm demo`: the whole system on a scenario file."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from agent.protocol.errors import UserError
from fluidswarm.recording.live import add_live_argument, live_from_args
from fluidswarm.scenario import SYNC_MODES, Failure, PassCriteria, Scenario, load_scenario

REPO = Path(__file__).resolve().parent.parent
DEMO_SCENARIO = REPO / "scenarios" / "demo_v_sign.toml"


def register(sub) -> None:
    p = sub.add_parser("run", help="run a scenario file: router, agents, coordinator, recorder, failures, summary")
    p.add_argument("scenario", help="scenarios/NAME.toml")
    p.add_argument("--agents", type=int, help="override the scenario's number of agents")
    p.add_argument("--out", help="output folder (default: out/<scenario name>)")
    p.add_argument("--sync", choices=SYNC_MODES, help="override the scenario's synchronisation mode")
    g = p.add_argument_group("failure injection (added to the scenario's own)")
    g.add_argument("--kill", action="append", default=[], metavar="K@STEP", help="SIGKILL K agents at STEP")
    g.add_argument("--freeze", action="append", default=[], metavar="K@STEP:SECONDS",
                   help="SIGSTOP K agents at STEP for SECONDS, then SIGCONT")
    g.add_argument("--drop", action="append", default=[], metavar="AGENT:FRACTION",
                   help="agent AGENT drops FRACTION of its outgoing states")
    g.add_argument("--kill-coordinator", action="append", default=[], type=int, metavar="STEP",
                   help="SIGKILL the coordinator at STEP (agents keep the last command)")
    g.add_argument("--late-join", action="append", default=[], metavar="K@STEP", help="start K extra agents at STEP")
    g.add_argument("--compare", action="store_true",
                   help="also run without failures (same seed) and print fidelity_ratio")
    add_live_argument(p)
    p.set_defaults(func=_run)
    p = sub.add_parser("demo", help="the main job: a real V-sign photograph imitated by ~60 agent processes")
    p.add_argument("--out", default="out/demo")
    add_live_argument(p)
    p.set_defaults(func=_demo)


def _count_at(opt: str, text: str) -> tuple[int, int]:
    try:
        k, at = text.split("@")
        k, at = int(k), int(at)
    except ValueError:
        raise UserError(f"--{opt} {text}: expected K@STEP with whole numbers, e.g. 4@100") from None
    if k < 1 or at < 0:
        raise UserError(f"--{opt} {text}: K must be >= 1 and STEP >= 0")
    return k, at


def failures_from_args(args) -> list[Failure]:
    """The `run` command's failure options as Failure records (validated here, at the edge)."""
    out = []
    for text in args.kill:
        k, at = _count_at("kill", text)
        out.append(Failure("kill", at_step=at, count=k))
    for text in args.late_join:
        k, at = _count_at("late-join", text)
        out.append(Failure("late_join", at_step=at, count=k))
    for text in args.freeze:
        head, _, secs = text.partition(":")
        k, at = _count_at("freeze", head)
        try:
            seconds = float(secs)
        except ValueError:
            raise UserError(f"--freeze {text}: expected K@STEP:SECONDS, e.g. 2@100:3") from None
        if not 0 < seconds < 3600:
            raise UserError(f"--freeze {text}: SECONDS must be in (0, 3600)")
        out.append(Failure("freeze", at_step=at, count=k, seconds=seconds))
    for text in args.drop:
        try:
            agent, fraction = text.split(":")
            agent, fraction = int(agent), float(fraction)
        except ValueError:
            raise UserError(f"--drop {text}: expected AGENT:FRACTION, e.g. 3:0.3") from None
        if agent < 0 or not 0 <= fraction < 1:
            raise UserError(f"--drop {text}: AGENT must be >= 0 and FRACTION in [0, 1)")
        out.append(Failure("drop", agent=agent, fraction=fraction))
    for at in args.kill_coordinator:
        if at < 0:
            raise UserError(f"--kill-coordinator {at}: STEP must be >= 0")
        out.append(Failure("kill_coordinator", at_step=at))
    return out


@dataclass
class RunSummary:
    scenario: str
    agents: int
    steps: int
    steps_per_second: float
    finished: int
    mcap: Path
    sync: str = "lockstep"
    figures: dict = field(default_factory=dict)
    failures: list = field(default_factory=list)
    pictures: list = field(default_factory=list)
    passed: bool = True
    why: list = field(default_factory=list)
    fidelity_iou: float | None = None


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


def longest_stall(step_times: dict[int, float]) -> float:
    """Longest wall-clock gap between the first sightings of consecutive steps (s): how long the swarm as
    a whole made no progress, e.g. while it waited for frozen agents."""
    if len(step_times) < 2:
        return 0.0
    steps = sorted(step_times)
    t = np.maximum.accumulate(np.array([step_times[k] for k in steps]))
    return float(np.max(np.diff(t)))


def experiment_setup(sc: Scenario, agents: int):
    from agent.sph import setups

    base = {"branching": setups.branching, "drag": setups.drag}[sc.experiment]
    default = base(agents)
    if sc.sph or sc.dt:
        return base(agents, params=default.params.with_overrides(sc.sph, sc.dt))
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


def _sync_extra(sc: Scenario) -> dict:
    return {"mode": sc.sync, "rate": sc.async_rate, "max_age": sc.async_max_age}


def run_experiment(sc: Scenario, agents: int, out: Path, watch: dict, live: str = "") -> RunSummary:
    """A physics experiment (branching, drag) through agent processes, recorded, with failures."""
    from agent.launcher import Launcher, run_swarm
    from fluidswarm.failures import FailureInjector

    setup = experiment_setup(sc, agents)
    steps = sc.steps or 400
    out.mkdir(parents=True, exist_ok=True)
    mcap = out / f"{sc.name}.mcap"
    drop = {f.agent: f.fraction for f in sc.failures if f.kind == "drop"}
    meta = {"scenario": sc.name, "scenario_file": str(sc.path), "experiment": sc.experiment, "agents": agents,
            "steps": steps, "seed": sc.seed, "sync": sc.sync, "params": setup.params.as_dict(),
            "agent_ids": [int(i) for i in setup.ids], "failures": [f.__dict__ for f in sc.failures]}
    extra = _sync_extra(sc)
    with Launcher(agent_timeout=sc.neighbour_timeout or 2.0) as launcher:
        def spawn_late(count: int) -> list[int]:
            # Joiners start at the block's initial centre and adopt the swarm's step (docs/protocol.md).
            centre = setup.states[:, :2].mean(axis=0)
            return launcher.spawn_joiners(count, centre, setup.controls[0], setup.params, steps, **extra)

        watch["launcher"] = launcher
        launcher.start_recorder(str(mcap), meta, setup.params.dt, live=live)
        launcher.track_progress()
        injector = FailureInjector(launcher, sc.failures, setup.ids, sc.seed, spawn_late=spawn_late)
        watch["injector"] = injector
        bar = ProgressLine(launcher, steps, injector)
        try:
            res = run_swarm(setup, steps, launcher=launcher, on_started=lambda la: injector.start(), progress=bar,
                            per_agent={i: {"drop_out": f} for i, f in drop.items()}, **extra)
        finally:
            injector.stop()
            bar.done()
    done = {i: r for i, r in res.finals.items() if r.get("status") == "done"}
    ids = sorted(done)
    pos = np.array([done[i]["state"][:2] for i in ids]) if ids else np.empty((0, 2))
    # late joiners take the class of particle 0 (they were given its control)
    index = {int(i): k for k, i in enumerate(setup.ids)}
    classes = np.array([setup.classes[index.get(i, 0)] for i in ids], dtype=int)
    summary = RunSummary(sc.name, agents, steps, res.steps_per_second(), len(done), mcap, sync=sc.sync,
                         failures=injector.log.injected)
    if sc.experiment == "branching":
        summary.figures["branch_gap"] = branch_gap(pos, classes)
    if sc.experiment == "drag":
        summary.figures["mean_vx"] = float(np.mean([done[i]["state"][2] for i in ids])) if ids else 0.0
    return summary


def _finish(sc: Scenario, summary: RunSummary, out: Path, watch: dict, baseline: RunSummary | None) -> RunSummary:
    """Robustness figures, replay pictures and the pass criteria (shared by every kind of scenario)."""
    from fluidswarm.recording.reader import check
    from fluidswarm.recording.replay import replay

    launcher, injector = watch.get("launcher"), watch.get("injector")
    if launcher is not None:
        summary.figures["longest_stall_seconds"] = longest_stall(launcher.step_times)
        summary.figures["neighbour_timeout_seconds"] = launcher.agent_timeout
    log = injector.log if injector else None
    spared = summary.agents + (len(log.joined) - len(log.killed) - len(log.frozen) if log else 0)
    summary.figures["finished_share"] = min(1.0, summary.finished / max(spared, 1))
    complete, _steps, missing = check(summary.mcap)
    summary.figures["mcap_complete"] = "true" if complete else "false"
    summary.figures["mcap_missing_states"] = missing
    if baseline is not None and baseline.fidelity_iou is not None and summary.fidelity_iou is not None:
        summary.figures["baseline_fidelity_iou"] = baseline.fidelity_iou
        summary.figures["fidelity_ratio"] = summary.fidelity_iou / max(baseline.fidelity_iou, 1e-9)
    rep = replay(summary.mcap, out)
    summary.pictures += [str(p) for p in rep.paths]
    crit, f = sc.passing, summary.figures

    def need(ok: bool, why: str) -> None:
        if not ok:
            summary.passed = False
            summary.why.append(why)

    if crit.min_fidelity_iou:
        need(f.get("fidelity_iou", 0.0) >= crit.min_fidelity_iou, f"fidelity_iou {f.get('fidelity_iou', 0.0):.3f} < {crit.min_fidelity_iou}")
    if crit.max_nn_cv:
        need(f.get("nn_cv", 1e9) <= crit.max_nn_cv, f"nn_cv {f.get('nn_cv', float('nan')):.3f} > {crit.max_nn_cv}")
    if crit.min_fidelity_inside:
        need(f.get("fidelity_inside", 0.0) >= crit.min_fidelity_inside, f"fidelity_inside {f.get('fidelity_inside', 0.0):.3f} < {crit.min_fidelity_inside}")
    if crit.min_branch_gap:
        need(f.get("branch_gap", 0.0) >= crit.min_branch_gap, f"branch_gap {f.get('branch_gap', 0.0):.2f} < {crit.min_branch_gap}")
    if crit.min_fidelity_ratio:
        ratio = f.get("fidelity_ratio")
        need(ratio is not None and ratio >= crit.min_fidelity_ratio, f"fidelity_ratio {ratio} < {crit.min_fidelity_ratio}")
    if crit.max_stall_seconds:
        need(f.get("longest_stall_seconds", 0.0) <= crit.max_stall_seconds,
             f"longest_stall_seconds {f.get('longest_stall_seconds', 0.0):.2f} > {crit.max_stall_seconds}")
    if crit.min_finished:
        need(f["finished_share"] >= crit.min_finished, f"finished_share {f['finished_share']:.2f} < {crit.min_finished}")
    if crit.complete_mcap:
        need(complete, f"MCAP incomplete ({missing} missing states)")
    return summary


def print_summary(s: RunSummary) -> None:
    print(f"scenario={s.scenario}")
    print(f"sync={s.sync}")
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


def _execute_once(sc: Scenario, agents: int, out: Path, watch: dict, live: str = "") -> RunSummary:
    if sc.experiment == "imitate":
        from coordinator.scenario_run import run_imitation_scenario

        return run_imitation_scenario(sc, agents, out, watch, live)
    return run_experiment(sc, agents, out, watch, live)


def execute(sc: Scenario, agents: int | None, out: Path, compare: bool = False, live: str = "") -> RunSummary:
    """Run a scenario; with failures and a fidelity-ratio criterion (or `compare`), first the same scenario
    without failures (same seed, out/baseline) so the two fidelities are measured side by side."""
    agents = agents or sc.agents
    baseline = None
    if sc.failures and (compare or sc.passing.min_fidelity_ratio) and sc.experiment == "imitate":
        clean = replace(sc, failures=(), passing=PassCriteria())
        print(f"baseline: {sc.name} without failures (same seed) -> {out / 'baseline'}", file=sys.stderr)
        baseline = _execute_once(clean, agents, out / "baseline", {})
    watch: dict = {}
    summary = _execute_once(sc, agents, out, watch, live)  # the baseline is not streamed
    return _finish(sc, summary, out, watch, baseline)


def _run(args) -> int:
    sc = load_scenario(args.scenario)
    if args.agents is not None and not 1 <= args.agents <= 2000:
        raise UserError(f"--agents: must be in 1..2000, got {args.agents}")
    extra = failures_from_args(args)
    if extra or args.sync:
        sc = replace(sc, failures=sc.failures + tuple(extra), sync=args.sync or sc.sync)
    out = Path(args.out or f"out/{sc.name}")
    summary = execute(sc, args.agents, out, compare=args.compare, live=live_from_args(args))
    print_summary(summary)
    return 0 if summary.passed else 1


def _demo(args) -> int:
    sc = load_scenario(DEMO_SCENARIO)
    summary = execute(sc, None, Path(args.out), live=live_from_args(args))
    print_summary(summary)
    return 0 if summary.passed else 1
