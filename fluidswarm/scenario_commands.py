"""`fluidswarm run SCENARIO` and `fluidswarm demo`: the whole system on a scenario file."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from agent.protocol.errors import UserError
from agent.protocol.spec import NEIGHBOUR_TIMEOUT
from agent.sph.robot import POINT
from fluidswarm.options import (
    add_json_argument,
    add_swarm_arguments,
    check_lockstep,
    print_json,
    radio_model,
    radio_options,
    robot_model,
)
from fluidswarm.orchestration.run_config import SYNC_OPTION, Access, Recording, RunConfig, check_agents
from fluidswarm.recording.live import live_from_args
from fluidswarm.ros2_options import ros2_bag_from_args, ros2_from_args, write_run_bag
from fluidswarm.scenario import (
    SYNC_MODES,
    Failure,
    PassCriteria,
    Scenario,
    load_scenario,
    scenarios_dir,
)
from fluidswarm.worker_command import add_workers_arguments, workers_options

if TYPE_CHECKING:
    from fluidswarm.orchestration.run import RunRecord

DEMO_SCENARIO = "demo_v_sign.toml"  # one of the shipped scenarios (scenario.scenarios_dir)


def register(sub) -> None:
    p = sub.add_parser("run", help="run a scenario file: router, agents, coordinator, recorder, failures, summary")
    p.add_argument("scenario", help="scenarios/NAME.toml (a file, or the name of a shipped scenario)")
    p.add_argument("--agents", type=int, help="override the scenario's number of agents")
    p.add_argument("--out", help="output folder (default: out/<scenario name>)")
    p.add_argument(SYNC_OPTION, choices=SYNC_MODES, help="override the scenario's synchronisation mode")
    g = p.add_argument_group("failure injection (added to the scenario's own)")
    g.add_argument("--kill", action="append", default=[], metavar="K@STEP", help="SIGKILL K agents at STEP")
    g.add_argument(
        "--freeze",
        action="append",
        default=[],
        metavar="K@STEP:SECONDS",
        help="SIGSTOP K agents at STEP for SECONDS, then SIGCONT",
    )
    g.add_argument(
        "--drop",
        action="append",
        default=[],
        metavar="AGENT:FRACTION",
        help="agent AGENT drops FRACTION of its outgoing states",
    )
    g.add_argument(
        "--kill-coordinator",
        action="append",
        default=[],
        type=int,
        metavar="STEP",
        help="SIGKILL the coordinator at STEP (agents keep the last command)",
    )
    g.add_argument("--late-join", action="append", default=[], metavar="K@STEP", help="start K extra agents at STEP")
    g.add_argument(
        "--compare", action="store_true", help="also run without failures (same seed) and print fidelity_ratio"
    )
    add_swarm_arguments(p)
    add_workers_arguments(p)
    add_json_argument(p)
    p.set_defaults(func=_run)
    p = sub.add_parser("demo", help="the main job: a real V-sign photograph imitated by ~60 agent processes")
    p.add_argument("--out", default="out/demo")
    add_swarm_arguments(p)
    add_json_argument(p)
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


def kind_for(sc: Scenario, agents: int):
    """The scenario's RunKind: an imitation (one frame or a gesture sequence) or a physics experiment."""
    if sc.experiment != "imitate":
        from fluidswarm.experiment import Experiment, experiment_setup

        experiment_setup(sc, agents)  # its robots must fit it before anything starts
        return Experiment(sc, agents)
    from coordinator.control.imitation_setup import DEFAULT_STEPS
    from fluidswarm.experiment import scenario_sync
    from fluidswarm.orchestration.imitate import FileImitation

    path = sc.input_path()
    if path is None or not path.exists():
        raise UserError(f"{sc.path}: key 'input': {sc.input} does not exist")
    drop = {f.agent: f.fraction for f in sc.failures if f.kind == "drop"}
    if any(a >= agents for a in drop):
        raise UserError(f"{sc.path}: key 'failures': drop names agent {max(drop)}, the swarm has ids 0..{agents - 1}")
    swarm = RunConfig(agents, sc.steps or DEFAULT_STEPS, sc.controller, sc.robot, sc.radio)
    return FileImitation(
        str(path),
        swarm,
        None if sc.frame < 0 else sc.frame,
        sc.frame_steps,
        sc.sph,
        sc.dt,
        scenario_sync(sc),
        drop,
        obstacles=sc.obstacles,
        start=sc.start,
        source=str(sc.path),
    )


def run_once(
    sc: Scenario,
    agents: int,
    out: Path,
    live: str = "",
    realtime: bool = False,
    hosts: dict | None = None,
    ros2: str = "",
) -> RunRecord:
    """One run of the scenario with its failures, recorded in `out`; `realtime`: paced to the wall clock;
    `hosts`: with workers on other hosts (worker_command.workers_options: connect, run, workers, ...)."""
    from coordinator.handover import CoordinatorFailed
    from fluidswarm.orchestration.imitate import PerceptionFailed
    from fluidswarm.orchestration.run import Run, RunOptions

    kind = kind_for(sc, agents)
    imitation = sc.experiment == "imitate"
    timeout = sc.neighbour_timeout or (NEIGHBOUR_TIMEOUT.imitation if imitation else NEIGHBOUR_TIMEOUT.default)
    options = RunOptions(
        Recording(out, sc.name, live, ros2),
        timeout,
        failures=sc.failures,
        seed=sc.seed,
        commands=imitation,
        progress=True,
        access=Access(**(hosts or {})),
        realtime=realtime,
    )
    try:
        with Run(kind, options) as run:
            kind.drive(run)
    except (PerceptionFailed, CoordinatorFailed) as exc:  # perception's line names the input
        raise UserError(f"{sc.path}: input {exc}") from None
    return run.record


def execute(
    sc: Scenario,
    agents: int | None,
    out: Path,
    compare: bool = False,
    live: str = "",
    realtime: bool = False,
    hosts: dict | None = None,
    ros2: str = "",
) -> RunRecord:
    """Run a scenario; with failures and a fidelity-ratio criterion (or `compare`), first the same scenario
    without failures (same seed, out/baseline) so the two fidelities are measured side by side."""
    from fluidswarm.scenario_verdict import judge

    agents = agents or sc.agents
    if not hosts:  # the run's own embedded router (a scenario's agents and --agents alike)
        from swarmhost.launcher import check_swarm_size

        check_swarm_size(agents)
    baseline = None
    if sc.failures and (compare or sc.passing.min_fidelity_ratio) and sc.experiment == "imitate":
        clean = replace(sc, failures=(), passing=PassCriteria())
        print(f"baseline: {sc.name} without failures (same seed) -> {out / 'baseline'}", file=sys.stderr)
        baseline = run_once(clean, agents, out / "baseline", realtime=realtime)
    record = run_once(sc, agents, out, live, realtime, hosts, ros2)  # the baseline is not streamed
    return judge(sc, record, out, baseline)


def scenario_figures(r: RunRecord) -> dict:
    """The figures `run` prints, in their order: the formation's, the kind's, then the robustness ones."""
    from fluidswarm.scenario_verdict import ROBUSTNESS

    f: dict = {}
    if r.fidelity is not None:
        f.update(
            fidelity_iou=r.fidelity.iou,
            fidelity_inside=r.fidelity.inside,
            fidelity_coverage=r.fidelity.coverage,
            nn_cv=r.fidelity.nn_cv,
            formation_seconds=r.formation_seconds,
            formation_wall_seconds=r.formation_wall_seconds,
        )
    f.update({k: v for k, v in r.figures.items() if k not in ROBUSTNESS})
    f.update(longest_stall_seconds=r.longest_stall_seconds, neighbour_timeout_seconds=r.neighbour_timeout_seconds)
    f.update(robot_lines(r))
    f.update({k: r.figures[k] for k in ROBUSTNESS if k in r.figures})
    return f


def robot_lines(r: RunRecord) -> dict:
    """robot=, and what the recorder measured on the bodies (collisions=, min_separation_m=; among obstacles
    obstacle_penetrations=, min_obstacle_distance_m=) when it did."""
    f: dict = {"robot": r.robot}
    if r.radio:
        f.update({f"radio_{k}": v for k, v in r.radio.items() if k != "seed"})
    if r.collisions is not None:
        f.update(collisions=r.collisions, min_separation_m=r.min_separation_m)
    if r.obstacle_penetrations is not None:
        f.update(obstacle_penetrations=r.obstacle_penetrations, min_obstacle_distance_m=r.min_obstacle_distance_m)
    return f


def print_summary(s: RunRecord) -> None:
    print(f"scenario={s.name}")
    print(f"sync={s.sync}")
    print(f"agents={s.agents}")
    print(f"finished={s.finished}")
    print(f"steps={s.steps}")
    print(f"steps_per_second={s.steps_per_second:.2f}")
    for k, v in scenario_figures(s).items():
        print(f"{k}={v:.4f}" if isinstance(v, float) else f"{k}={str(v).lower() if isinstance(v, bool) else v}")
    print(f"failures_injected={len(s.failures)}")
    for f in s.failures:
        print(f"  {f}")
    print(f"failures_survived={'true' if s.finished > 0 else 'false'}")
    print(f"mcap={s.mcap}")
    for p in s.pictures:
        print(f"picture={p}")
    print(f"passed={'true' if s.passed else 'false'}" + ("" if s.passed else "  (" + "; ".join(s.why) + ")"))


def _report(args, record: RunRecord, bag: Path | None = None) -> int:
    write_run_bag(record.mcap, bag)
    if args.json:
        print_json(record)
    else:
        print_summary(record)
    return 0 if record.passed else 1


def _run(args) -> int:
    sc = load_scenario(args.scenario)
    if args.agents is not None:
        check_agents(args.agents, embedded=not args.workers)  # workers: the run's routers are the hosts'
    extra = failures_from_args(args)
    if extra or args.sync:
        sc = replace(sc, failures=sc.failures + tuple(extra), sync=args.sync or sc.sync)
    if args.robot is not None:
        sc = replace(
            sc,
            robot=robot_model(
                args.robot,
                {k: v for k, v in sc.robot.as_dict().items() if k != "kind"} if sc.robot != POINT else {},
                where=str(sc.path),
            ),
        )
    sc = with_radio_options(sc, args)
    out = Path(args.out or f"out/{sc.name}")
    live, hosts, bag = live_from_args(args), workers_options(args), ros2_bag_from_args(args)
    if hosts:
        # Failures are injected by one launcher on its own agents, and the baseline would need the workers again.
        if sc.experiment != "imitate":
            raise UserError(f"--workers: {sc.path} is a physics experiment; an imitation scenario only")
        if sc.failures or args.compare:
            raise UserError(f"--workers: {sc.path} injects failures; a scenario without failures only")
    return _report(
        args,
        execute(
            sc,
            args.agents,
            out,
            compare=args.compare,
            live=live,
            realtime=args.realtime,
            hosts=hosts,
            ros2=ros2_from_args(args),
        ),
        bag,
    )


def with_radio_options(sc: Scenario, args) -> Scenario:
    """The scenario with the --radio-* options over its [radio] table (seeded from its seed)."""
    given = radio_options(args)
    if given:
        table = {k: v for k, v in sc.radio.as_dict().items() if k != "seed"}
        sc = replace(sc, radio=radio_model({**table, **given}, sc.seed))
    check_lockstep(sc.radio, sc.sync, "--radio-*" if given else f"{sc.path}: key 'radio'")
    return sc


def _demo(args) -> int:
    sc = load_scenario(scenarios_dir() / DEMO_SCENARIO)
    if args.robot is not None:
        sc = replace(sc, robot=robot_model(args.robot, {}, where=str(sc.path)))
    sc = with_radio_options(sc, args)
    bag = ros2_bag_from_args(args)
    return _report(
        args,
        execute(sc, None, Path(args.out), live=live_from_args(args), realtime=args.realtime, ros2=ros2_from_args(args)),
        bag,
    )
