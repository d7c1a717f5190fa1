"""Start a swarm of agent processes on this host, run it, collect the final reports, clean up.

Used through fluidswarm/orchestration/run.py by `fluidswarm launch`, `verify`, `imitate`, `run` and the benchmarks. The
`Launcher` of one run puts together parts with one job each:

    swarmhost/router_host.py       the run's Zenoh session: an embedded router (at level acl the compiled one,
                               swarmhost/router_process.py, with the state relay), or a client of one elsewhere
    swarmhost/host_relay.py        the relay of another host's router, for a launcher that is its client (multi-host)
    swarmhost/supervisor.py        the agent processes: start, alive tokens, final reports, stop
    swarmhost/pacing.py            the run's progress (steps seen) and its pacing clock, ctl/end and ctl/gone
    swarmhost/recorder_process.py  the MCAP recorder process
    swarmhost/helpers.py           the router, recorder and coordinator, watched: a lost one ends the run (HelperLost)

and `run_swarm` holds the start barrier: every agent's alive token before the start signal. Every process
started is stopped when the launcher closes (also on an exception or SIGINT/SIGTERM).
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import tempfile
import time
import uuid
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from agent.protocol import keys
from agent.protocol.access import AGENT_CAPACITY
from agent.protocol.access import level as access_level
from agent.protocol.errors import UserError
from agent.protocol.events import AgentEvent
from agent.protocol.report import FinalReport
from agent.protocol.spec import NEIGHBOUR_TIMEOUT, AgentSpec
from agent.sph.particle import Control, initial_state
from swarmhost.helpers import Helpers
from swarmhost.initial_neighbours import initial_neighbours
from swarmhost.pacing import Pacer, Share
from swarmhost.recorder_process import RecorderInputs, RecorderProcess
from swarmhost.router_host import RouterHost
from swarmhost.router_process import CompiledRelay
from swarmhost.supervisor import Supervisor, Swarm

GOLDEN_ANGLE = 2.399963  # rad: late joiners on a spiral, none on top of another
JOINER_SPACING = 0.6  # m: the spiral's radius grows as JOINER_SPACING * sqrt(k + 1)


@dataclass
class SwarmResult:
    ids: list[int]
    finals: dict[int, FinalReport]  # agent id -> its final report
    events: list[AgentEvent]
    exit_codes: dict[int, int | None]
    wall_seconds: float
    startup_seconds: float
    steps: int

    def final_states(self) -> dict[int, np.ndarray]:
        return {i: np.array(r.state) for i, r in self.finals.items()}

    def steps_per_second(self) -> float:
        """The steps the swarm made (its furthest agent's) over the time from the first agent's start to the last
        one's end. Not `steps`, the run's cap: an imitation that settled ends before it (ctl/end), and the cap
        over its shorter time made a 300-agent gesture that ran ~450 steps at ~22 steps/s report 34."""
        starts = [r.t_start for r in self.finals.values() if r.t_start]
        ends = [r.t_end for r in self.finals.values() if r.t_end]
        made = max((r.steps for r in self.finals.values() if r.t_end), default=0)
        if not starts or not ends:
            return 0.0
        return made / max(max(ends) - min(starts), 1e-9)

    def msgs_per_agent_step(self) -> float:
        rs = [r for r in self.finals.values() if r.steps]
        return float(np.mean([r.msgs_received / r.steps for r in rs])) if rs else 0.0

    def neighbours_per_agent(self) -> float:
        rs = [r for r in self.finals.values() if r.steps]
        return float(np.mean([r.neighbours / r.steps for r in rs])) if rs else 0.0


def check_swarm_size(agents: int) -> None:
    """A swarm of ids 0..agents-1 fits an embedded router (checked before anything starts): at access level acl or
    auth it provisions ids 0..AGENT_CAPACITY-1 only (docs/security.md), and every id needs a key (docs/protocol.md)."""
    bound = keys.MAX_AGENTS if access_level() == "none" else AGENT_CAPACITY
    if agents > bound:
        raise UserError(
            f"--agents {agents}: an embedded router knows agent ids 0..{bound - 1} only (at most "
            f"{bound} agents on one host; split a larger swarm over hosts, docs/multi-host.md)"
        )


class Launcher:
    """Owns an embedded router (or a connection to one), the agent processes and the recorder of one run.

    run: the run's name (default a fresh one); connect: a router elsewhere (tcp/HOST:PORT) instead of an
    embedded one listening on `listen`; secret: the run's command key (hex; default fresh); agent_timeout
    [s]: the neighbour timeout given to every agent; commands: the agents follow signed gesture commands
    (they get the key); user/password/auth_file: credentials for a router elsewhere (docs/security.md);
    capacity: the agent ids an embedded router provisions (0..capacity-1; a run that knows its swarm and late
    joiners gives their number: the router starts faster with fewer users)."""

    def __init__(
        self,
        run: str | None = None,
        connect: str | None = None,
        listen: str | None = None,
        secret: str | None = None,
        agent_timeout: float = NEIGHBOUR_TIMEOUT.default,
        quiet: bool = True,
        user: str = "",
        password: str = "",
        auth_file: str = "",
        commands: bool = False,
        capacity: int = AGENT_CAPACITY,
    ):
        self.run = run or f"run-{uuid.uuid4().hex[:8]}"
        if not keys.valid_run_name(self.run):
            raise ValueError(f"run name {self.run!r}: use 1-64 letters, digits, '-' or '_'")
        self.secret = secret if secret is not None else secrets.token_hex(32)
        self.agent_timeout, self.commands, self.quiet = agent_timeout, commands, quiet
        self.router = RouterHost(self.run, connect, listen, user, password, auth_file, capacity)
        self.endpoint, self.agent_endpoint = self.router.endpoint, self.router.agent_endpoint
        self.access, self.session = self.router.access, self.router.session
        self.swarm = Swarm(self.run, self.endpoint, self.session)
        # An embedded router's batches carry every state of the run: the pacer follows those
        self.pacer = Pacer(
            self.swarm, agent_timeout, self.access.state_key_ids, batches=isinstance(self.router.relay, CompiledRelay)
        )
        self.pacer.on_host_lost = self._log_host_lost
        # What this launcher learns that the MCAP should hold too (a lost host): events.jsonl here, which its
        # recorder follows (--launcher-events, recording/coordinator_events.py); made with the recorder.
        self._events: Path | None = None
        self.helpers = Helpers(step=lambda: self.pacer.max_step)
        if self.router.process is not None:
            proc = self.router.process.proc
            self.helpers.watch(
                f"embedded router (fluidswarm-router, pid {proc.pid})", proc, why=self.router.process.last_words
            )
        try:
            self.supervisor = Supervisor(
                self.swarm, self.access.env_for_agent, self.secret if commands else "", quiet, health=self.helpers.check
            )
        except BaseException:
            self.router.close()
            raise
        self.relay = self.router.relay  # under per-process rights: agents' id keys -> cell keys
        # The embedded router's relay also fills the agents' inboxes: a lockstep step's neighbour states in one
        # message (agent/native/src/relay/inboxes.rs); a host's router (multi-host) relays on the cells only.
        # FLUIDSWARM_INBOX=0 keeps the cell subscriptions (the side-by-side measurements, an older agent).
        self.inboxes = isinstance(self.relay, CompiledRelay) and os.environ.get("FLUIDSWARM_INBOX", "1") != "0"
        self.recorder = RecorderProcess(
            self.run, self.endpoint, self.session, self.access.env_for("recorder"), quiet, self.access.state_key_ids
        )
        self.closed = False

    # the run's progress (swarmhost/pacing.py)
    @property
    def step_times(self) -> dict[int, float]:
        return self.pacer.step_times

    @property
    def max_step(self) -> int:
        return self.pacer.max_step

    @property
    def agent_steps(self) -> dict[int, tuple[int, float]]:
        return self.pacer.agent_steps

    @property
    def newest(self) -> dict[int, bytes]:
        return self.pacer.newest

    def pace_split(self, ids, swarm_ids, owner: bool | None = None, follow_all: bool = False, others=()) -> None:
        """This launcher starts `ids` of the run's `swarm_ids` (a split run, before track_progress): it follows only
        its own agents' states and says its share's clock, or, as the `owner` of the run's clock (default: the
        host holding the swarm's smallest id), puts ctl/clock from every host's (swarmhost/pacing.py); `others`:
        the other hosts' ids where known (a main host's workers'), so a lost host's agents are named."""
        own, everyone = sorted({int(i) for i in ids}), {int(i) for i in swarm_ids}
        if own and set(own) < everyone:
            owner = min(everyone) in own if owner is None else owner
            shares = tuple(tuple(int(i) for i in share) for share in others)
            self.pacer.split(Share(tuple(own), len(everyone), owner, follow_all, shares))

    def _log_host_lost(self, lost: dict, text: str) -> None:
        """The pacer dropped a silent host: into the MCAP too (a `host_lost` warning of name `launcher`)."""
        if self._events is not None:
            with open(self._events / "events.jsonl", "a") as f:
                f.write(json.dumps({"event": "host_lost", "what": text, **lost}) + "\n")

    def track_progress(self) -> None:
        """Follow every state message and publish the pacing clock (idempotent)."""
        self.pacer.start()

    def wait_step(self, step: int, timeout: float) -> None:
        self.pacer.wait_step(step, timeout)

    def end_at(self, step: int) -> None:
        self.pacer.end_at(step)

    # the recorder (swarmhost/recorder_process.py)
    def start_recorder(
        self,
        path: str,
        metadata: dict,
        dt: float,
        inputs: RecorderInputs = RecorderInputs(),
        timeout: float = 30.0,
    ):
        if self._events is None:
            self._events = Path(tempfile.mkdtemp(prefix="fluidswarm-launcher-"))
        proc = self.recorder.start(path, metadata, dt, inputs, str(self._events), timeout)
        self.helpers.watch(f"recorder (pid {proc.pid}, writing {path})", proc, self.recorder.last_words)
        return proc

    def stop_recorder(self, timeout: float = 60.0) -> int | None:
        if self.recorder.proc is not None:
            self.helpers.forget(self.recorder.proc)
        return self.recorder.stop(timeout)

    def watch_coordinator(self, proc) -> None:
        """The run's coordinator: lost if it fails (killed, or a non-zero exit) while the run goes on, unless a
        failure kills it on purpose (Helpers.expect_loss); one that ends its job (exit 0) is not lost."""
        self.helpers.watch(f"coordinator (pid {proc.pid})", proc, fine_exit=True)

    def check_ids(self, ids) -> None:
        """Every id in `ids` has credentials on this run's router: else one line naming the bound, before
        any agent starts."""
        ids = [int(i) for i in ids]
        if not ids:
            return
        cap = self.access.capacity  # the router's own bound comes before the keys' (docs/protocol.md)
        beyond = [i for i in ids if cap is not None and i >= cap]
        for i in [min(ids)] + ([min(beyond)] if beyond else []) + [max(ids)]:
            try:
                self.access.env_for_agent(i)
            except ValueError as exc:
                raise UserError(f"{exc}; nothing was started") from None

    # the agents (swarmhost/supervisor.py)
    def spec_for(self, agent_id: int, state: np.ndarray, control: Control, params, steps: int, **extra) -> AgentSpec:
        p = params.as_dict()
        p["domain"] = list(p["domain"])
        return AgentSpec(
            run=self.run,
            id=int(agent_id),
            connect=[self.agent_endpoint],
            steps=int(steps),
            initial=[float(v) for v in state[:4]],
            control=asdict(control),
            params=p,
            timeout=self.agent_timeout,
            state_key_ids=self.access.state_key_ids,
            inbox=self.inboxes,
            **extra,
        )

    def spawn(self, spec: AgentSpec):
        if self.relay is not None:
            self.relay.add(spec.id, spec.params["h"])
        return self.supervisor.spawn(spec)

    def spawn_joiners(self, count: int, centre, control: Control, params, steps: int, **extra) -> list[int]:
        """Start `count` late joiners (ids after every agent so far) around `centre` on a golden-angle
        spiral, so none starts on top of another; they adopt the swarm's step (docs/protocol.md)."""
        start = max(self.swarm.procs, default=-1) + 1
        for k in range(count):
            r, angle = JOINER_SPACING * np.sqrt(k + 1), GOLDEN_ANGLE * k
            state = initial_state(centre[0] + r * np.cos(angle), centre[1] + r * np.sin(angle), 0.0, 0.0, params)
            self.spawn(self.spec_for(start + k, state, control, params, steps, join=True, **extra))
        return list(range(start, start + count))

    def wait_alive(self, ids, timeout: float) -> None:
        self.supervisor.wait_alive(ids, timeout)

    def use_secret(self, secret: str) -> None:
        """The run's command key is `secret` (hex; before any agent or the coordinator starts): a run with
        workers derives it from the users file (agent/protocol/plan.py command_key)."""
        self.secret = secret
        if self.commands:
            self.supervisor.secret = secret

    def start(self) -> None:
        self.supervisor.start()

    def wait_finals(self, ids, timeout: float, progress: Callable[[], None] | None = None) -> None:
        self.supervisor.wait_finals(ids, timeout, progress)

    def close(self) -> dict[int, int | None]:
        """Stop every agent (stop message, then SIGTERM, then SIGKILL), the recorder and the router. Idempotent."""
        if self.closed:
            return {i: p.returncode for i, p in self.swarm.procs.items()}
        self.closed = True
        self.pacer.stop()
        router_lost = self.router.process is not None and self.router.process.proc.poll() is not None
        codes = self.supervisor.stop_all(bus=not router_lost)  # without a router no stop message arrives
        if self.recorder.proc is not None:
            self.helpers.forget(self.recorder.proc)
        self.recorder.stop()
        if self.relay is not None:
            self.relay.close()
        self.supervisor.undeclare()
        self.router.close()
        if self._events is not None:
            shutil.rmtree(self._events, ignore_errors=True)
        return codes

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def startup_budget(everyone, startup_timeout: float | None = None) -> float:
    """s the start barrier waits for the agents of `everyone` to come up (a 1000-agent swarm takes minutes on two
    cores): `startup_timeout` or 60 + 0.5 s per agent."""
    return startup_timeout or 60.0 + 0.5 * len(everyone)


def agent_specs(
    launcher: Launcher, setup, steps: int, chosen, everyone, per_agent=None, **spec_extra
) -> list[AgentSpec]:
    """The specs of `chosen` (ids of `setup`) in a swarm of `everyone`, as this launcher starts them (its
    endpoint; a worker sets its own, swarmhost/workers.py)."""
    index = {int(i): k for k, i in enumerate(setup.ids)}
    near = initial_neighbours(everyone, [setup.states[index[i]][:2] for i in everyone], setup.params)
    specs = []
    for i in chosen:
        k = index[i]
        extra = {
            **spec_extra,
            "neighbours": near[i],
            "robot": setup.robot.as_dict(),
            # only an imperfect radio is written: a perfect one is the agent's default
            **({} if setup.radio.is_perfect else {"radio": setup.radio.as_dict()}),
            **({"obstacles": setup.obstacle_dicts()} if setup.obstacles else {}),
            **(per_agent or {}).get(i, {}),
        }
        specs.append(launcher.spec_for(i, setup.states[k], setup.controls[k], setup.params, steps, **extra))
    return specs


def run_swarm(
    setup,
    steps: int,
    *,
    launcher: Launcher | None = None,
    startup_timeout: float | None = None,
    run_timeout: float | None = None,
    on_started: Callable[[Launcher], None] | None = None,
    before_start: Callable[[], None] | None = None,
    progress: Callable[[], None] | None = None,
    ids=None,
    swarm_ids=None,
    per_agent: dict | None = None,
    report_ids=None,
    **spec_extra,
) -> SwarmResult:
    """Run `setup` (agent.sph.setups.Setup) through one agent process per particle, lockstep, `steps` steps.

    With a `launcher` given, the caller owns it (and closes it); otherwise one is made and closed here.
    `ids` is the slice started on this host; `swarm_ids` the whole swarm, whose alive tokens the start
    barrier waits for (other hosts start the rest), so nobody steps before every subscriber is known;
    `report_ids`: other hosts' agents whose final reports this host's result holds too (a main host's
    workers'; one that never comes, of a lost host, is left out). `before_start` runs once every agent is
    alive, before the start signal (what must be done before the first step, and may overlap the start-up).
    """
    own = launcher is None
    launcher = launcher or Launcher()
    result = None
    try:
        chosen = [int(i) for i in (setup.ids if ids is None else ids)]
        everyone = [int(i) for i in swarm_ids] if swarm_ids is not None else chosen
        launcher.check_ids(everyone)
        budget = startup_budget(everyone, startup_timeout)
        # An agent waits for the start signal as long as the launcher waits for the swarm to come up (a
        # 1000-agent swarm takes minutes on two cores), not a fixed 120 s.
        spec_extra.setdefault("start_timeout", max(120.0, budget + 30.0))
        t0 = time.monotonic()
        for spec in agent_specs(launcher, setup, steps, chosen, everyone, per_agent, **spec_extra):
            launcher.spawn(spec)
        launcher.track_progress()
        launcher.wait_alive(everyone, budget)
        if before_start is not None:
            before_start()
        startup = time.monotonic() - t0
        t1 = time.monotonic()
        launcher.start()
        if on_started is not None:
            on_started(launcher)
        run_budget = run_timeout or 60.0 + steps * (0.05 + 0.004 * len(chosen))
        launcher.wait_finals(chosen, run_budget, progress)
        # the owner of a split run's clock paces the other hosts' agents until their shares are done
        launcher.pacer.wait_hosts(max(1.0, run_budget - (time.monotonic() - t1)))
        others = [int(i) for i in report_ids or () if int(i) not in set(chosen)]
        if others:
            launcher.supervisor.wait_reports(others, 10.0)
        wall = time.monotonic() - t1
        # Late joiners (spawned during the run) finish at the same step as the rest: count them too.
        late = [i for i in list(launcher.swarm.procs) if i not in set(chosen) and i not in set(everyone)]
        if late:
            launcher.wait_finals(late, 30.0 + 0.1 * steps)
        with launcher.swarm.changed:
            kept = chosen + others + late
            finals = {i: launcher.swarm.finals[i] for i in kept if i in launcher.swarm.finals}
            events = list(launcher.swarm.events)
        result = SwarmResult(chosen + others, finals, events, {}, wall, startup, steps)
        return result
    finally:
        if own:
            codes = launcher.close()
            if result is not None:
                result.exit_codes.update(codes)
