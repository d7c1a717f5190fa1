"""The agent processes of one run: start them, follow their alive tokens and final reports, stop them.

Every process started here is stopped by `stop_all` (stop message, SIGTERM, SIGKILL); agents also get
SIGTERM from the kernel if the launcher dies (PR_SET_PDEATHSIG, set by the agent itself), so none
outlives it. The kernel ties that signal to the *thread* that spawned the process, so every agent is
spawned by one thread of the supervisor's that lives until `stop_all` (late joiners too, whichever thread
asks). Reports and events come from the network: they are decoded and validated by
agent/protocol/report.py and events.py, and one that is malformed or published under another agent's key is
dropped (events are counted in `Swarm.malformed_events`). Start and stop go out as agent/protocol/ctl.py
records.
"""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import zenoh

from agent.protocol import keys
from agent.protocol.ctl import Start, Stop, ctl_message
from agent.protocol.errors import SwarmFailed, SwarmTimeout
from agent.protocol.events import AgentEvent, decode_event
from agent.protocol.report import FinalReport, decode_report
from agent.protocol.spec import AgentSpec
from swarmhost.executable import agent_executable

_PR_SET_PDEATHSIG = 1
# s an exited agent's final report is still awaited, if its exit code says it sent one
REPORT_GRACE = 10.0
REPORTED = (0, 3, 4)


def die_with_parent() -> None:  # runs in the child between fork and exec
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except OSError:
        pass


@dataclass
class Swarm:
    """A running swarm: its router session, its agent processes, what they reported."""

    run: str
    endpoint: str
    session: zenoh.Session
    procs: dict[int, subprocess.Popen] = field(default_factory=dict)
    finals: dict[int, FinalReport] = field(default_factory=dict)
    events: list[AgentEvent] = field(default_factory=list)
    malformed_events: int = 0  # dropped: not a valid event, or under another agent's key
    alive: set[int] = field(default_factory=set)
    gone: list[tuple[int, float]] = field(default_factory=list)  # (agent, monotonic s lost) not yet relayed on ctl/gone
    lock: threading.Lock = field(default_factory=threading.Lock)
    changed: threading.Condition = None  # type: ignore[assignment]

    def __post_init__(self):
        self.changed = threading.Condition(self.lock)


class Supervisor:
    """Starts agents with `env_for_agent(id)` (their credentials) and, with `secret`, the run's command key
    in their environment; `quiet`: their output goes nowhere."""

    def __init__(
        self,
        swarm: Swarm,
        env_for_agent: Callable[[int], dict],
        secret: str = "",
        quiet: bool = True,
        health: Callable[[], None] = lambda: None,
    ):
        self.swarm, self.env_for_agent, self.secret, self.quiet = swarm, env_for_agent, secret, quiet
        # called at every wake-up of the waits below (<= 0.2 s apart): raises when a helper of the run (router,
        # recorder, coordinator) is lost, so no wait outlives it (swarmhost/launcher.py: Launcher.check_helpers)
        self.health = health
        self.program = agent_executable()  # the compiled agent (agent/native); fail before any process starts
        # The one thread that spawns agents (see the module's docstring): it lives until stop_all.
        self._spawner = ThreadPoolExecutor(1, thread_name_prefix="agent-spawner")
        session, run = swarm.session, swarm.run
        self._subs = [
            session.declare_subscriber(keys.final_expr(run), self._on_final),
            session.declare_subscriber(keys.event_expr(run), self._on_event),
            session.liveliness().declare_subscriber(keys.alive_expr(run), self._on_alive, history=True),
        ]

    def spawn(self, spec: AgentSpec) -> subprocess.Popen:
        out = subprocess.DEVNULL if self.quiet else None
        env = dict(os.environ, **self.env_for_agent(spec.id))
        if self.secret:  # the run's command key travels in the environment, never on the bus or argv
            env["FLUIDSWARM_SECRET"] = self.secret
        # No preexec_fn: it forces a full fork() of this (large) Python process per agent, which made starting
        # 300 agents take seconds; without it Python spawns with vfork. The agent asks the kernel for SIGTERM
        # when its parent dies itself (PR_SET_PDEATHSIG first thing in main.rs, then checks it was not
        # already orphaned), so none outlives the launcher. That signal also fires when the spawning *thread*
        # exits: the spawner thread outlives every agent it starts (a late joiner's helper thread would not).
        argv = [self.program, "--spec", spec.to_json()]
        proc = self._spawner.submit(
            subprocess.Popen, argv, env=env, stdout=out, stderr=out, stdin=subprocess.DEVNULL
        ).result()
        self.swarm.procs[spec.id] = proc
        return proc

    # callbacks: tiny, under the lock
    def _on_final(self, sample) -> None:
        report = decode_report(sample.payload.to_bytes())
        if report is None or report.id != keys.id_from_key(str(sample.key_expr)):
            return  # untrusted: a malformed report, or one under another agent's key, counts as none
        with self.swarm.changed:
            self.swarm.finals[report.id] = report
            self.swarm.changed.notify_all()

    def _on_event(self, sample) -> None:
        event = decode_event(sample.payload.to_bytes())
        with self.swarm.changed:
            if event is None or event.id != keys.id_from_key(str(sample.key_expr)):
                self.swarm.malformed_events += 1  # malformed, or under another agent's key (docs/security.md)
            else:
                self.swarm.events.append(event)

    def _on_alive(self, sample) -> None:
        j = keys.id_from_key(str(sample.key_expr))
        if j is None:
            return
        with self.swarm.changed:
            if sample.kind == zenoh.SampleKind.PUT:
                self.swarm.alive.add(j)
            else:
                self.swarm.alive.discard(j)
                # Relayed on ctl/gone by the clock thread (no put on the router's thread), which also decides
                # whether it was a loss: a finished agent's report may still come after its token's deletion.
                self.swarm.gone.append((j, time.monotonic()))
            self.swarm.changed.notify_all()

    def wait_alive(self, ids, timeout: float) -> None:
        """Until every agent in `ids` shows its alive token (the start barrier's wait)."""
        want = set(ids)
        deadline = time.monotonic() + timeout
        with self.swarm.changed:
            while not want <= self.swarm.alive:
                self.health()
                left = deadline - time.monotonic()
                dead = [i for i in want if i in self.swarm.procs and self.swarm.procs[i].poll() is not None]
                if dead:
                    raise SwarmFailed(
                        f"agent {dead[0]} exited during start-up (code {self.swarm.procs[dead[0]].returncode})"
                    )
                if left <= 0:
                    missing = sorted(want - self.swarm.alive)
                    raise SwarmTimeout(f"{len(missing)} agents not ready after {timeout:.0f} s (first: {missing[:5]})")
                self.swarm.changed.wait(min(left, 0.2))

    def start(self) -> None:
        """The start signal (ctl/start) every waiting agent steps from."""
        # Block, not zenoh's default Drop: at N = 1000 the links are still full of liveliness declarations
        # when the swarm starts, and an agent that missed the one start message never stepped.
        self.swarm.session.put(*ctl_message(self.swarm.run, Start()), congestion_control=zenoh.CongestionControl.BLOCK)

    def wait_finals(self, ids, timeout: float, progress: Callable[[], None] | None = None) -> None:
        """Until every agent in `ids` has reported or exited."""
        deadline = time.monotonic() + timeout
        exited: dict[int, float] = {}  # id -> when its process was first seen ended without its report here

        def waiting(i: int, now: float) -> bool:
            if i in self.swarm.finals:
                return False
            code = self.swarm.procs[i].poll()
            if code is None:
                return True
            # An agent that reported (done 0, fell behind 3, stopped 4) waited for the router to hold its
            # report before it exited, but this process may not have handled it yet (1000 reports at once).
            return code in REPORTED and now - exited.setdefault(i, now) < REPORT_GRACE

        with self.swarm.changed:
            while True:
                self.health()
                pending = [i for i in ids if waiting(i, time.monotonic())]
                if not pending:
                    return
                left = deadline - time.monotonic()
                if left <= 0:
                    raise SwarmTimeout(f"{len(pending)} agents still running after {timeout:.0f} s")
                self.swarm.changed.wait(min(left, 0.2))
                if progress is not None:
                    self.swarm.changed.release()
                    try:
                        progress()
                    finally:
                        self.swarm.changed.acquire()

    def wait_reports(self, ids, timeout: float) -> list[int]:
        """Until every agent in `ids` (another host's: no process here) has reported, at most `timeout` s; the
        ids still without a report."""
        deadline = time.monotonic() + timeout
        with self.swarm.changed:
            while True:
                missing = [i for i in ids if i not in self.swarm.finals]
                left = deadline - time.monotonic()
                if not missing or left <= 0:
                    return missing
                self.swarm.changed.wait(min(left, 0.2))

    def stop_all(self, bus: bool = True) -> dict[int, int | None]:
        """Stop every agent (stop message, then SIGTERM, then SIGKILL); their exit codes. `bus` False: the
        router is gone, so no stop message can reach them: SIGTERM at once."""
        procs = self.swarm.procs
        with self.swarm.changed:
            unreported = [i for i, p in procs.items() if p.poll() is None and i not in self.swarm.finals]
        # ctl/stop reaches every agent of the run, on every host: an agent that reported is leaving anyway, and
        # in a multi-host run the stop of the host that finished first would halt the others' last steps.
        if unreported and bus:
            try:
                self.swarm.session.put(*ctl_message(self.swarm.run, Stop()))
            except Exception:  # noqa: BLE001, S110  # the session may already be gone on an interrupted run
                pass
        if bus and any(p.poll() is None for p in procs.values()):
            _wait_all(procs.values(), 2.0)
        for p in procs.values():
            if p.poll() is None:
                try:
                    p.send_signal(signal.SIGCONT)  # a frozen agent must be able to handle SIGTERM
                    p.terminate()
                except ProcessLookupError:
                    pass
        _wait_all(procs.values(), 3.0)
        for p in procs.values():
            if p.poll() is None:
                p.kill()
        self._spawner.shutdown()  # every agent has gone: its spawning thread may end
        _wait_all(procs.values(), 5.0)
        return {i: p.returncode for i, p in procs.items()}

    def undeclare(self) -> None:
        for s in self._subs:
            try:
                s.undeclare()
            except Exception:  # noqa: BLE001, S110  # undeclaring on a closed session may fail; nothing left to do
                pass


def stop_process(proc: subprocess.Popen, timeout: float = 10.0) -> None:
    """SIGTERM a side process (it closes its session), SIGKILL after `timeout` s."""
    if proc.poll() is None:
        proc.terminate()
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def _wait_all(procs, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    for p in procs:
        try:
            p.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass
