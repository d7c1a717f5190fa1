"""One run of a swarm, from the router up to the typed record of what happened: the orchestration layer.

Every command that runs agents (demo, run, imitate, imitate --camera, launch, verify, bench) goes through
`Run`: it owns the launcher (router + agent processes), the recorder, the failure injector, the progress
line and the record, once. What differs between kinds of run is behind `RunKind`:

    drive(run)  set up what the kind needs (perception, a coordinator process) and run the swarm with
                `run.record_to(...)` and `run.swarm(plan)`
    score(run)  after the agents and the recorder have stopped: the kind's own figures into `run.record`

    with Run(kind, RunOptions(...)) as run:
        kind.drive(run)
    record = run.record            # RunRecord; record.to_json() is what `--json` prints

Nothing travels back through hooks or attributes patched onto the launcher: side processes, start
callbacks and watchers are registered on the Run, and results are fields of the record.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, Self

import numpy as np

from agent.protocol.errors import UserError
from agent.protocol.report import FinalReport
from agent.protocol.spec import NEIGHBOUR_TIMEOUT, SyncMode
from fluidswarm.orchestration.run_config import Access, Recording, Sync
from fluidswarm.recording.progress import Progress
from swarmhost.failures import FailureInjector
from swarmhost.launcher import Launcher, SwarmResult, run_swarm
from swarmhost.recorder_process import RecorderInputs
from swarmhost.supervisor import stop_process

if TYPE_CHECKING:
    from agent.sph.particle import Control
    from agent.sph.setups import Setup
    from coordinator.control.fidelity import Fidelity


REALTIME_KEPT = 0.95  # a --realtime swarm below this realtime_factor could not keep up (said once)


@dataclass
class SwarmPlan:
    """The agents of a run: `setup` (agent.sph.setups.Setup) stepped `steps` times with `sync`.

    per_agent: id -> extra spec fields (e.g. {"drop_out": 0.3}); joiners_at: (x, y) [m] where late joiners
    start, with `joiner_control` (default the first particle's); ids / swarm_ids: the slice started here
    and the whole swarm (multi-host); startup_timeout / run_timeout [s]: None for run_swarm's defaults."""

    setup: Setup
    steps: int
    sync: Sync = Sync()
    per_agent: dict = field(default_factory=dict)
    joiners_at: tuple[float, float] | None = None
    joiner_control: Control | None = None
    ids: list[int] | None = None
    swarm_ids: list[int] | None = None
    startup_timeout: float | None = None
    run_timeout: float | None = None
    start_timeout: float | None = None  # s an agent waits for the start signal (None: run_swarm's default)
    report_ids: list[int] | None = None  # other hosts' agents whose reports the record holds (workers')
    clock_owner: bool | None = None  # split run: this host puts ctl/clock (None: the host of the smallest id)
    follow_all: bool = False  # split run: this host still follows every state (a settle watch reads them)
    other_shares: tuple[tuple[int, ...], ...] = ()  # split run: the other hosts' ids, where known (workers')
    # where the swarm is going, (n, 2) in setup order: what a run with workers cuts into regions (`formation`
    # shares); None: its start layout
    share_layout: np.ndarray | None = None


@dataclass
class RunOptions:
    """How a run goes beside its kind: `recording` what it writes and where (fluidswarm/orchestration/run_config.py
    Recording: out None writes nothing and starts no recorder; the MCAP is `<out>/<name>.mcap`), `access` the
    bus it runs on (Access: a fresh run on an embedded router, or `connect` + `run` with a users file and other
    hosts as workers); neighbour_timeout [s] (agent/protocol/spec.py NEIGHBOUR_TIMEOUT); failures:
    fluidswarm.scenario.Failure records injected during the run, victims drawn from `seed`; commands: the agents
    follow signed gesture commands; progress: the progress line on stderr (`run` and `demo`; the other commands
    keep stderr for errors); realtime: simulated time held to the wall clock (swarmhost/pacing.py
    pace_realtime)."""

    recording: Recording
    neighbour_timeout: float = NEIGHBOUR_TIMEOUT.default
    failures: tuple = ()
    seed: int = 0
    commands: bool = False
    progress: bool = False
    access: Access = field(default_factory=Access)
    realtime: bool = False

    def capacity(self, swarm_size: int) -> int:
        """The agent ids the run's embedded router provisions: the `swarm_size` agents the run starts (its kind's
        `agents`) and its late joiners, not every id it may take (AGENT_CAPACITY): it starts faster."""
        return swarm_size + sum(f.count for f in self.failures if f.kind == "late_join")


@dataclass
class RunRecord:
    """What one run did. Times in s; `figures` holds the kind's own measures (branch_gap, mean_vx,
    max_position_error, the robustness figures of a scenario ...); `finals` (each agent's report) stays
    out of the JSON."""

    name: str
    kind: str
    agents: int
    steps: int
    sync: str = SyncMode.LOCKSTEP
    run: str = ""
    router: str = ""
    finished: int = 0
    steps_per_second: float = 0.0
    startup_seconds: float = 0.0
    wall_seconds: float = 0.0
    msgs_per_agent_step: float = 0.0
    neighbours_per_agent: float = 0.0
    neighbour_timeout_seconds: float = 0.0
    longest_stall_seconds: float = 0.0
    failures: list[str] = field(default_factory=list)
    failures_killed: int = 0
    failures_frozen: int = 0
    failures_joined: int = 0
    mcap: str | None = None
    pictures: list[str] = field(default_factory=list)
    fidelity: Fidelity | None = None
    formation_seconds: float | None = None
    formation_wall_seconds: float | None = None
    formation_settled: bool | None = None
    robot: str = "point"
    radio: dict | None = None  # the imperfect radio's loss, latency, noise, seed (agent/sph/radio.py); None: perfect
    collisions: int | None = None
    min_separation_m: float | None = None
    obstacles: int = 0  # how many static obstacles the domain holds (agent/sph/obstacles.py)
    obstacle_penetrations: int | None = None  # bodies overlapping an obstacle, once per agent and episode
    min_obstacle_distance_m: float | None = None  # closest approach of a body centre to an obstacle
    figures: dict[str, float | int | str] = field(default_factory=dict)
    realtime_factor: float | None = None  # simulated seconds / wall seconds of the swarm's run
    subject: str = ""  # imitate --camera: "hand" | "person" (and how it was chosen)
    gestures: list[dict] = field(default_factory=list)  # imitate --camera: each command {seq, gesture, t, why}
    notes: list[str] = field(default_factory=list)  # what was not found, a swarm that fell behind real time
    # hosts of a split run lost on the way (their share clock went silent): {first, agents, step, ids}
    lost_hosts: list[dict] = field(default_factory=list)
    passed: bool = True
    why: list[str] = field(default_factory=list)
    finals: dict[int, FinalReport] = field(default_factory=dict, repr=False)

    def done_positions(self) -> tuple[list[int], np.ndarray]:
        """Ids (sorted) and final (x, y) [m] of the agents that reached their last step."""
        ids = sorted(i for i, r in self.finals.items() if r.done)
        pos = np.array([self.finals[i].state[:2] for i in ids]) if ids else np.empty((0, 2))
        return ids, pos

    def as_dict(self) -> dict:
        d = asdict(self)
        del d["finals"]
        return d

    def to_json(self) -> str:
        """One line of JSON (non-finite numbers as null: JSON has no NaN)."""
        return json.dumps(json_finite(self.as_dict()), separators=(",", ":"))


def json_finite(v):
    """`v` with every non-finite float as None, through dicts and lists (JSON has no NaN or inf)."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: json_finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [json_finite(x) for x in v]
    return v


class RunKind(Protocol):
    """A kind of run (experiment, imitation, sequence, camera, plain block): what it adds to `Run`."""

    kind: str

    @property
    def agents(self) -> int:
        """The swarm's size: the agents the run starts (late joiners aside), on every host."""
        ...

    def drive(self, run: Run) -> None: ...

    def score(self, run: Run) -> None: ...


class Run:
    """The frame of one run (see the module's docstring). Usable once."""

    def __init__(self, kind: RunKind, options: RunOptions):
        self.kind, self.options = kind, options
        # Set by __enter__, and a Run is used only inside its `with` block (so never None where it is read).
        self.launcher: Launcher = None  # type: ignore[assignment]  # see above
        self.injector: FailureInjector | None = None
        self.result: SwarmResult | None = None
        # Set when the run's `with` block ends without an error (kinds read it in score(), callers after the block).
        self.record: RunRecord = None  # type: ignore[assignment]  # see above
        self.mcap: Path | None = None
        self.plan: SwarmPlan = None  # type: ignore[assignment]  # set by swarm(), before anything reads it
        self.coordinator: subprocess.Popen | None = None
        self._on_start: list[Callable[[], None]] = []
        self._before_start: list[Callable[[], None]] = []
        self._on_stop: list[Callable[[], None]] = []
        self._bar: Progress | None = None
        self._scratch: Path | None = None
        self._notes: list[str] = []  # what the run learnt at its end (a recorder that ended badly)

    def __enter__(self) -> Self:
        o = self.options
        try:
            self.launcher = Launcher(
                run=o.access.run,
                connect=o.access.connect,
                agent_timeout=o.neighbour_timeout,
                auth_file=o.access.auth_file,
                commands=o.commands,
                capacity=o.capacity(self.kind.agents),
            )
        except ValueError as exc:  # a bad run name
            raise UserError(str(exc)) from None
        self.salt = ""
        if o.access.workers:
            self._derive_command_key()
        if o.recording.out is not None:
            Path(o.recording.out).mkdir(parents=True, exist_ok=True)
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            for stop in reversed(self._on_stop):
                stop()
            if self.injector is not None:
                self.injector.stop()
            if self._bar is not None:
                self._bar.close()
            if self.coordinator is not None:
                self.launcher.helpers.forget(self.coordinator)
                stop_process(self.coordinator)
        finally:
            codes = self.launcher.close()  # agents, then the recorder (the MCAP is complete after this)
            self._recording_survives()
            if self._scratch is not None:
                shutil.rmtree(self._scratch, ignore_errors=True)
        if exc_type is None and self.result is not None:
            self.result.exit_codes.update(codes)
            self.record = self._summarise(self.result)
            self._behind_real_time()
            self.kind.score(self)

    def _recording_survives(self) -> None:
        """A recorder that ended badly (killed, crashed, stuck past its stop) is named, and the file it left
        without a footer rewritten finished (recording/recover.py after_recorder): on stderr at once, and in
        the record's notes."""
        from fluidswarm.recording.recover import after_recorder
        from swarmhost.helpers import describe_exit

        proc = self.launcher.recorder.proc
        code = proc.returncode if proc is not None else None
        how = describe_exit(code) if code is not None else ""
        note = after_recorder(self.mcap, code, how, self.launcher.recorder.words)
        if note is not None:
            self._notes.append(note)
            print(f"fluidswarm: {note}", file=sys.stderr, flush=True)

    def _derive_command_key(self) -> None:
        """A run with workers: its command key from the users file and a fresh salt (the workers derive the
        same from the salt in their share of the plan; agent/protocol/plan.py)."""
        import secrets

        from agent.protocol.plan import command_key
        from swarmhost.workers import launcher_password

        try:
            password = launcher_password(self.launcher)
        except BaseException:
            self.launcher.close()
            raise
        self.salt = secrets.token_hex(16)
        self.launcher.use_secret(command_key(password, self.launcher.run, self.salt))

    def _serve_workers(self, plan: SwarmPlan) -> SwarmPlan:
        """Cut the swarm into 1 + workers shares (SHARE_KINDS), serve all but the most central as the run's plan
        and wait (bounded) until every worker has fetched its share; this host runs the most central one and owns
        the run's clock."""
        from agent.sph.regions import central_first, regions
        from swarmhost.launcher import agent_specs, startup_budget
        from swarmhost.workers import PlanServer, share_plans

        a, la, setup = self.options.access, self.launcher, plan.setup
        everyone = [int(i) for i in setup.ids]
        if a.workers + 1 > len(everyone):
            raise UserError(f"--workers {a.workers}: {len(everyone)} agents make at most {len(everyone) - 1} workers")
        cut = setup.states[:, :2] if plan.share_layout is None else plan.share_layout  # `formation`: the kind's
        if a.shares == "ids":  # ranges of ids (as `launch --ids`): for comparison with regions (docs/multi-host.md)
            parts = np.array_split(np.argsort(np.asarray(setup.ids), kind="stable"), a.workers + 1)
        else:
            parts = regions(cut, a.workers + 1)
        # this host (the workers' routers connect to its router) takes the part bordering the most others
        parts = central_first(cut, parts, float(setup.params.support))
        shares = [sorted(int(setup.ids[k]) for k in part) for part in parts]
        start_timeout = max(120.0, startup_budget(everyone, plan.startup_timeout) + 30.0) + a.workers_timeout
        extra = {**plan.sync.spec(), "start_timeout": start_timeout}
        specs = [agent_specs(la, setup, plan.steps, ids, everyone, plan.per_agent, **extra) for ids in shares[1:]]
        server = PlanServer(la, share_plans(la.run, len(everyone), self.salt, specs))
        self._on_stop.append(server.close)
        self._on_start.insert(0, server.mark_started)
        print(f"run={la.run} waiting_for_workers={a.workers}", flush=True)
        server.wait_workers(a.workers_timeout)
        return replace(
            plan,
            ids=shares[0],
            swarm_ids=everyone,
            start_timeout=start_timeout,
            report_ids=everyone,
            clock_owner=True,
            follow_all=True,
            other_shares=tuple(tuple(ids) for ids in shares[1:]),
        )

    # what a kind uses while it drives
    @property
    def scratch(self) -> Path:
        """A private folder for files handed to the run's processes, removed after they have stopped."""
        if self._scratch is None:
            self._scratch = Path(tempfile.mkdtemp(prefix="fluidswarm-run-"))
        return self._scratch

    def before_start(self, fn: Callable[[], None]) -> None:
        """Call `fn` once every agent is alive, before they are told to start (it may raise: the run ends)."""
        self._before_start.append(fn)

    def _before_starting(self) -> None:
        for fn in self._before_start:
            fn()

    def on_start(self, fn: Callable[[], None]) -> None:
        """Call `fn` when the agents have been told to start (watchers that follow the run)."""
        self._on_start.append(fn)

    def on_stop(self, fn: Callable[[], None]) -> None:
        """Call `fn` when the run ends, before the processes are stopped (in reverse order of registration)."""
        self._on_stop.append(fn)

    def add_coordinator(self, proc: subprocess.Popen) -> None:
        """The run's coordinator process: stopped with the run, the target of a kill_coordinator failure;
        watched (swarmhost/helpers.py): one that dies on its own ends the run as a lost helper."""
        self.coordinator = proc
        self.launcher.watch_coordinator(proc)

    def record_to(
        self,
        metadata: dict,
        dt: float,
        target: str = "",
        image: str = "",
        path: str | None = None,
        coordinator_notes: tuple[str, ...] | None = None,
    ) -> Path | None:
        """Start the recorder on `path` (default `<out>/<name>.mcap`; nothing without either);
        `coordinator_notes`: it follows a camera coordinator's notes on the bus (these said before it started)."""
        if path:
            self.mcap = Path(path)
        elif self.options.recording.out is not None:
            self.mcap = Path(self.options.recording.out) / f"{self.options.recording.name}.mcap"
        else:
            return None
        recording = self.options.recording
        inputs = RecorderInputs(target, image, recording.live, coordinator_notes, recording.ros2)
        self.launcher.start_recorder(str(self.mcap), metadata, dt, inputs)
        return self.mcap

    def swarm(self, plan: SwarmPlan) -> SwarmResult:
        """Run the plan's agents to their end, with the run's failures and its progress line."""
        o, la = self.options, self.launcher
        if o.access.workers:
            plan = self._serve_workers(plan)
        self.plan = plan
        if plan.ids is not None and plan.swarm_ids is not None:
            la.pace_split(plan.ids, plan.swarm_ids, plan.clock_owner, plan.follow_all, plan.other_shares)
        la.track_progress()
        self.injector = injector = FailureInjector(
            la, o.failures, plan.setup.ids, o.seed, coordinator=self.coordinator, spawn_late=self._spawn_late
        )
        if o.progress:
            self._bar = Progress(plan.steps, "step", rate_unit="steps")

        def started(_launcher) -> None:
            la.pacer.mark_start(plan.setup.params.dt)
            if o.realtime:
                la.pacer.pace_realtime()
            injector.start()
            for fn in self._on_start:
                fn()

        self.result = result = run_swarm(
            plan.setup,
            plan.steps,
            launcher=la,
            on_started=started,
            before_start=self._before_starting,
            progress=self._progress,
            per_agent=plan.per_agent,
            ids=plan.ids,
            swarm_ids=plan.swarm_ids,
            startup_timeout=plan.startup_timeout,
            run_timeout=plan.run_timeout,
            report_ids=plan.report_ids,
            **plan.sync.spec(),
            **({} if plan.start_timeout is None else {"start_timeout": plan.start_timeout}),
        )
        return result

    def _spawn_late(self, count: int) -> list[int]:
        # Joiners start at the plan's point and adopt the swarm's step (docs/protocol.md).
        p = self.plan
        at = p.joiners_at if p.joiners_at is not None else tuple(p.setup.states[:, :2].mean(axis=0))
        control = p.joiner_control if p.joiner_control is not None else p.setup.controls[0]
        return self.launcher.spawn_joiners(
            count,
            at,
            control,
            p.setup.params,
            p.steps,
            robot=p.setup.robot.as_dict(),
            **({} if p.setup.radio.is_perfect else {"radio": p.setup.radio.as_dict()}),
            **p.sync.spec(),
        )

    def _progress(self) -> None:
        if self._bar is None:
            return
        la, o = self.launcher, self.options
        injected = len(self.injector.log.injected) if self.injector else 0
        factor = la.pacer.realtime_factor()
        extra = [f"realtime_factor {factor:.2f}"] if factor is not None and o.realtime else []
        self._bar.show(max(la.max_step, 0), f"alive {len(la.swarm.alive)}", f"failures {injected}", *extra)

    def _summarise(self, res: SwarmResult) -> RunRecord:
        la, o, plan = self.launcher, self.options, self.plan
        log = self.injector.log if self.injector else None
        finals = dict(res.finals)
        return RunRecord(
            name=o.recording.name,
            kind=self.kind.kind,
            agents=len(res.ids),
            steps=plan.steps,
            sync=plan.sync.mode,
            run=la.run,
            router=la.endpoint,
            finished=sum(1 for r in finals.values() if r.done),
            steps_per_second=res.steps_per_second(),
            startup_seconds=res.startup_seconds,
            wall_seconds=res.wall_seconds,
            msgs_per_agent_step=res.msgs_per_agent_step(),
            neighbours_per_agent=res.neighbours_per_agent(),
            neighbour_timeout_seconds=la.agent_timeout,
            longest_stall_seconds=la.pacer.longest_stall(),
            failures=list(log.injected) if log else [],
            failures_killed=len(log.killed) if log else 0,
            failures_frozen=len(log.frozen) if log else 0,
            failures_joined=len(log.joined) if log else 0,
            mcap=str(self.mcap) if self.mcap else None,
            finals=finals,
            realtime_factor=la.pacer.realtime_factor(),
            notes=list(la.pacer.notes) + self._notes,
            lost_hosts=[dict(h) for h in la.pacer.lost_hosts],
            **robot_figures(self.mcap, plan.setup),
        )

    def _behind_real_time(self) -> None:
        """A real-time swarm that could not keep up says so, once, with the factor it reached."""
        f = self.record.realtime_factor
        if self.options.realtime and f is not None and f < REALTIME_KEPT:
            note = (
                f"real time not kept: realtime_factor={f:.2f} ({self.record.agents} agents stepped "
                f"{f:.0%} as fast as the wall clock)"
            )
            self.record.notes.append(note)
            print(f"fluidswarm: {note}", file=sys.stderr)


def robot_figures(mcap: Path | None, setup) -> dict:
    """The record's robot fields: the model, and what the recorder measured on the bodies (collisions counted
    once per pair and episode, closest approach; fluidswarm/recording/contacts.py), when it recorded them."""
    from fluidswarm.recording.reader import recorded_robots

    robot = getattr(setup, "robot", None)
    out: dict = {"robot": robot.kind if robot is not None else "point"}
    radio = getattr(setup, "radio", None)
    if radio is not None and not radio.is_perfect:
        out["radio"] = radio.as_dict()
    measured = recorded_robots(mcap) if mcap is not None and Path(mcap).exists() else None
    if measured:
        out["collisions"] = int(measured["collisions"])
        out["min_separation_m"] = float(measured["min_separation_m"])
        if "obstacle_penetrations" in measured:
            out["obstacle_penetrations"] = int(measured["obstacle_penetrations"])
            out["min_obstacle_distance_m"] = float(measured["min_obstacle_distance_m"])
    obstacles = getattr(setup, "obstacles", ())
    if obstacles:
        out["obstacles"] = len(obstacles)
    return out


def busy_with_failures(run: Run) -> Callable[[], bool]:
    """True while the run's failures are still to come or just happened (a formation must not count as
    settled before they have all happened and the swarm had time to recover)."""
    return lambda: run.injector is None or run.injector.busy()
