"""Start a swarm of agent processes on this host, run it, collect the final states, clean up.

Used by `fluidswarm launch`, `verify`, `imitate`, `run` and the benchmarks. Every process it starts is
stopped when it returns, raises, or is interrupted (SIGINT/SIGTERM); agents also get SIGTERM from the
kernel if the launcher itself dies (PR_SET_PDEATHSIG), so none outlives it.
"""

from __future__ import annotations

import ctypes
import json
import os
import secrets
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from dataclasses import astuple, dataclass, field
from typing import Callable

import numpy as np
import zenoh

from agent.protocol import keys
from agent.executable import agent_executable
from agent.initial_neighbours import initial_neighbours
from agent.protocol.access import LaunchAccess
from agent.protocol.session import router_config
from agent.protocol.report import FinalReport, decode_report
from agent.protocol.spec import NEIGHBOUR_TIMEOUT, AgentSpec
from agent.sph.particle import Control
from agent.protocol.wire import STATE_SIZE

_ID_STEP = struct.Struct("<II")
_CLOCK = struct.Struct("<Q")
_GONE = struct.Struct("<I")

_PR_SET_PDEATHSIG = 1
# s between ctl/clock messages. Agents stay within CLOCK_LEAD (3) steps of the clock, so a 10 Hz clock capped
# every swarm at ~30 steps/s; the compiled agents run faster than that.
CLOCK_PERIOD = 0.02
CLOCK_REPEAT = 1.0
# s an exited agent's final report is still awaited, if its exit code says it sent one
REPORT_GRACE = 10.0
REPORTED = (0, 3, 4)
# How local agents reach the embedded router: "unix" (a unix socket) or "tcp" (loopback).
AGENT_LINK = os.environ.get("FLUIDSWARM_AGENT_LINK", "tcp")


def die_with_parent() -> None:  # runs in the child between fork and exec
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except OSError:
        pass


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@dataclass
class SwarmResult:
    ids: list[int]
    finals: dict[int, FinalReport]  # agent id -> its final report
    events: list[dict]
    exit_codes: dict[int, int | None]
    wall_seconds: float
    startup_seconds: float
    steps: int

    def final_states(self) -> dict[int, np.ndarray]:
        return {i: np.array(r.state) for i, r in self.finals.items()}

    def steps_per_second(self) -> float:
        starts = [r.t_start for r in self.finals.values() if r.t_start]
        ends = [r.t_end for r in self.finals.values() if r.t_end]
        if not starts or not ends:
            return 0.0
        return self.steps / max(max(ends) - min(starts), 1e-9)

    def msgs_per_agent_step(self) -> float:
        rs = [r for r in self.finals.values() if r.steps]
        return float(np.mean([r.msgs_received / r.steps for r in rs])) if rs else 0.0

    def neighbours_per_agent(self) -> float:
        rs = [r for r in self.finals.values() if r.steps]
        return float(np.mean([r.neighbours / r.steps for r in rs])) if rs else 0.0


@dataclass
class Swarm:
    """A running swarm: its router session, its agent processes, what they reported."""

    run: str
    endpoint: str
    session: zenoh.Session
    procs: dict[int, subprocess.Popen] = field(default_factory=dict)
    finals: dict[int, FinalReport] = field(default_factory=dict)
    events: list[dict] = field(default_factory=list)
    alive: set[int] = field(default_factory=set)
    gone: list[int] = field(default_factory=list)  # lost agents not yet relayed on ctl/gone
    lock: threading.Lock = field(default_factory=threading.Lock)
    changed: threading.Condition = None  # type: ignore[assignment]

    def __post_init__(self):
        self.changed = threading.Condition(self.lock)


class Launcher:
    """Owns an embedded router (or a connection to one) and the agent processes of one run."""

    def __init__(self, run: str | None = None, connect: str | None = None, listen: str | None = None,
                 secret: str | None = None, agent_timeout: float = NEIGHBOUR_TIMEOUT.default, quiet: bool = True,
                 user: str = "", password: str = "", auth_file: str = "", commands: bool = False):
        self.run = run or f"run-{uuid.uuid4().hex[:8]}"
        if not keys.valid_run_name(self.run):
            raise ValueError(f"run name {self.run!r}: use 1-64 letters, digits, '-' or '_'")
        self.secret = secret if secret is not None else secrets.token_hex(32)
        self.agent_timeout = agent_timeout
        self.commands = commands  # agents follow signed gesture commands (they wait for the first one)
        self.quiet = quiet
        self.agent_program = agent_executable()  # the compiled agent (agent/native); fail before any process starts
        self.user, self.password = user, password
        self._socket_dir = None
        if connect:
            self.endpoint = connect
            from agent.protocol.session import client_config
            self.access = LaunchAccess.client(user, password, auth_file)  # docs/security.md
            conf = client_config([connect], *(astuple(self.access.own) if self.access.own else ()))
            self.agent_endpoint = connect
        else:
            self.endpoint = listen or f"tcp/127.0.0.1:{free_port()}"
            listeners = [self.endpoint]
            self.agent_endpoint = self.endpoint
            if AGENT_LINK == "unix":
                # The local agents reach the embedded router over a unix socket (measured against TCP
                # loopback in docs/benchmarks/native.md); other processes and hosts use the TCP endpoint.
                self._socket_dir = tempfile.mkdtemp(prefix="fluidswarm-")
                self.agent_endpoint = f"unixsock-stream/{self._socket_dir}/router.sock"
                listeners.append(self.agent_endpoint)
            self.access = LaunchAccess.embedded()  # fresh credentials and per-process rights (docs/security.md)
            conf = router_config(listeners, dictionary_file=self.access.users_file, acl=self.access.acl)
        try:
            self.session = zenoh.open(conf)
        finally:
            self.access.opened()
        self.swarm = Swarm(self.run, self.endpoint, self.session)
        self._subs = [
            self.session.declare_subscriber(keys.final_expr(self.run), self._on_final),
            self.session.declare_subscriber(keys.event_expr(self.run), self._on_event),
            self.session.liveliness().declare_subscriber(keys.alive_expr(self.run), self._on_alive, history=True),
        ]
        self.closed = False
        self.clock_period = CLOCK_PERIOD
        self.step_times: dict[int, float] = {}  # step -> wall time its first state was seen
        self.max_step = -1

    def track_progress(self) -> None:
        """Watch every state message (a passive observer, like the recorder) to follow the run's step,
        and publish the pacing clock (idempotent)."""
        if getattr(self, "_tracking", False):
            return
        self._tracking = True
        self.agent_steps: dict[int, tuple[int, float]] = {}
        self.newest: dict[int, bytes] = {}  # id -> its newest state record, undecoded (watchers decode it)
        self.end_step: int | None = None
        # Queued in zenoh (a ring: a slow launcher loses old samples, never blocks the router it hosts) and
        # drained in batches by the clock thread: no Python callback, no GIL, per state message on the
        # router's receiving threads (N messages per step).
        self._states = self.session.declare_subscriber(keys.state_all_expr(self.run), zenoh.handlers.RingChannel(1 << 16))
        self._subs.append(self._states)
        self._clock_stop = threading.Event()
        threading.Thread(target=self._clock, daemon=True).start()

    def _on_state(self, sample) -> None:
        data = sample.payload.to_bytes()
        if len(data) != STATE_SIZE:
            return
        agent_id, step = _ID_STEP.unpack_from(data, 4)
        if keys.id_from_key(str(sample.key_expr)) != agent_id:
            return  # under another agent's key: a forgery (docs/security.md)
        now = time.monotonic()
        last = self.agent_steps.get(agent_id)
        if (last is None or step > last[0]) and step <= self.max_step + 1000:
            self.agent_steps[agent_id] = (step, now)
            self.newest[agent_id] = data
        if step not in self.step_times and step <= self.max_step + 1000:
            self.step_times[step] = now
            if step > self.max_step:
                self.max_step = step

    def _clock(self) -> None:
        """Publish the slowest live agent's step on ctl/clock every `clock_period` s when it moved.

        Agents that are not connected to anyone (an isolated particle) would otherwise race ahead of the
        swarm and meet it again at a different step; with the clock they stay within CLOCK_LEAD steps.
        Agents silent for longer than the neighbour timeout (frozen) or gone do not hold the clock back.
        """
        key = keys.ctl_key(self.run, "clock")
        last = said = None
        said_at = 0.0
        # 50 Hz, and only when it moves: with a lead of CLOCK_LEAD steps, a 10 Hz clock capped every swarm at
        # ~30 steps/s (the compiled agents run faster than that).
        while not self._clock_stop.wait(self.clock_period):
            try:
                while (sample := self._states.try_recv()) is not None:
                    self._on_state(sample)
            except Exception:  # the session is closing
                return
            now = time.monotonic()
            with self.swarm.changed:
                alive = set(self.swarm.alive)
                gone, self.swarm.gone = self.swarm.gone, []
            # Agents learn of a lost neighbour from this relay, not from a liveliness subscriber each on every
            # other agent's token: that was N² declarations at start-up (70 s at N = 1000, native.md).
            for j in gone:
                try:
                    self.session.put(keys.ctl_key(self.run, "gone"), _GONE.pack(j),
                                     congestion_control=zenoh.CongestionControl.BLOCK)
                except Exception:  # the session is closing
                    return
            steps = [s for j, (s, t) in list(self.agent_steps.items()) if j in alive and now - t < self.agent_timeout]
            if steps:
                last = min(steps)
            # Said again every CLOCK_REPEAT s, and with congestion control Block: a clock tick dropped by a
            # congested link held 555 of 1000 agents at their lead for good (nobody moved, so no new tick).
            if last is not None and (last != said or now - said_at >= CLOCK_REPEAT):
                said, said_at = last, now
                try:
                    self.session.put(key, _CLOCK.pack(last), congestion_control=zenoh.CongestionControl.BLOCK)
                    if self.end_step is not None:
                        self.end_at(self.end_step)
                except Exception:  # the session is closing
                    return

    def wait_step(self, step: int, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while self.max_step < step:
            if time.monotonic() > deadline:
                raise TimeoutError(f"run did not reach step {step} in {timeout:.0f} s")
            time.sleep(0.01)

    # callbacks: tiny, under the lock
    def _on_final(self, sample) -> None:
        report = decode_report(sample.payload.to_bytes())
        if report is None or report.id != keys.id_from_key(str(sample.key_expr)):
            return  # untrusted: a malformed report, or one under another agent's key, counts as none
        with self.swarm.changed:
            self.swarm.finals[report.id] = report
            self.swarm.changed.notify_all()

    def _on_event(self, sample) -> None:
        try:
            msg = json.loads(sample.payload.to_bytes())
        except ValueError:
            return
        if not isinstance(msg, dict) or msg.get("id") != keys.id_from_key(str(sample.key_expr)):
            return  # malformed, or under another agent's key
        with self.swarm.changed:
            self.swarm.events.append(msg)

    def _on_alive(self, sample) -> None:
        j = keys.id_from_key(str(sample.key_expr))
        if j is None:
            return
        with self.swarm.changed:
            if sample.kind == zenoh.SampleKind.PUT:
                self.swarm.alive.add(j)
                gone = False
            else:
                self.swarm.alive.discard(j)
                gone = j not in self.swarm.finals  # a finished agent's neighbours are done with it too
            if gone:
                self.swarm.gone.append(j)  # relayed on ctl/gone by the clock thread (no put on the router's thread)
            self.swarm.changed.notify_all()

    def start_recorder(self, path: str, metadata: dict, dt: float, timeout: float = 30.0, target: str = "",
                       image: str = "", live: str = "") -> subprocess.Popen:
        """Start the passive MCAP recorder process (fluidswarm/recording/recorder.py) and wait until its
        subscribers are declared (it then shows a liveliness token), so it misses no step."""
        meta = dict(metadata)
        meta.setdefault("run", self.run)
        out = subprocess.DEVNULL if self.quiet else None
        cmd = [sys.executable, "-m", "fluidswarm.recording.recorder", "--connect", self.endpoint, "--run", self.run,
               "--out", str(path), "--dt", repr(float(dt)), "--metadata", json.dumps(meta)]
        if target:
            cmd += ["--target", target]
        if image:
            cmd += ["--image", image]
        if live:  # HOST:PORT of its Foxglove WebSocket server (fluidswarm/recording/live.py)
            cmd += ["--live", live]
        self.recorder = subprocess.Popen(cmd, stdout=out, stderr=out, stdin=subprocess.DEVNULL, preexec_fn=die_with_parent,
                                         env=dict(os.environ, **self.access.env_for("recorder")))
        deadline = time.monotonic() + timeout
        key = f"{keys.PREFIX}/{self.run}/recorder"
        while time.monotonic() < deadline:
            if self.recorder.poll() is not None:
                raise RuntimeError(f"recorder exited at start-up (code {self.recorder.returncode})")
            if list(self.session.liveliness().get(key, timeout=1.0)):
                return self.recorder
            time.sleep(0.1)
        raise TimeoutError(f"recorder not ready after {timeout:.0f} s")

    def stop_recorder(self, timeout: float = 60.0) -> int | None:
        """SIGTERM the recorder: it writes the pending steps and the MCAP footer, then exits."""
        rec = getattr(self, "recorder", None)
        if rec is None:
            return None
        if rec.poll() is None:
            rec.terminate()
            try:
                rec.wait(timeout)
            except subprocess.TimeoutExpired:
                rec.kill()
                rec.wait(5)
        return rec.returncode

    def spec_for(self, agent_id: int, state: np.ndarray, control: Control, params, steps: int, **extra) -> AgentSpec:
        from dataclasses import asdict

        p = params.as_dict()
        p["domain"] = list(p["domain"])
        return AgentSpec(run=self.run, id=int(agent_id), connect=[self.agent_endpoint], steps=int(steps),
                         initial=[float(v) for v in state[:4]], control=asdict(control), params=p,
                         timeout=self.agent_timeout, **extra)

    def spawn(self, spec: AgentSpec) -> subprocess.Popen:
        out = subprocess.DEVNULL if self.quiet else None
        env = dict(os.environ, **self.access.env_for_agent(spec.id))
        if self.commands:  # the run's command key travels in the environment, never on the bus or argv
            env["FLUIDSWARM_SECRET"] = self.secret
        # No preexec_fn: it forces a full fork() of this (large) Python process per agent, which made starting
        # 300 agents take seconds; without it Python spawns with vfork. The agent asks the kernel for SIGTERM
        # when its parent dies itself (PR_SET_PDEATHSIG first thing in main.rs, then checks it was not
        # already orphaned), so none outlives the launcher.
        # The death signal fires when the *thread* that spawned exits: late joiners started from a helper thread
        # must not ask for it (they rely on close()).
        if threading.current_thread() is not threading.main_thread():
            env["FLUIDSWARM_NO_PDEATHSIG"] = "1"
        proc = subprocess.Popen([self.agent_program, "--spec", spec.to_json()], env=env,
                                stdout=out, stderr=out, stdin=subprocess.DEVNULL)
        self.swarm.procs[spec.id] = proc
        return proc

    def spawn_joiners(self, count: int, centre, control: Control, params, steps: int, **extra) -> list[int]:
        """Start `count` late joiners (ids after every agent so far) around `centre` on a golden-angle
        spiral, so none starts on top of another; they adopt the swarm's step (docs/protocol.md)."""
        from agent.sph.particle import initial_state

        start = max(self.swarm.procs, default=-1) + 1
        for k in range(count):
            angle = 2.399963 * k
            x = centre[0] + 0.6 * np.sqrt(k + 1) * np.cos(angle)
            y = centre[1] + 0.6 * np.sqrt(k + 1) * np.sin(angle)
            state = initial_state(x, y, 0.0, 0.0, params)
            self.spawn(self.spec_for(start + k, state, control, params, steps, join=True, **extra))
        return list(range(start, start + count))

    def wait_alive(self, ids, timeout: float) -> None:
        want = set(ids)
        deadline = time.monotonic() + timeout
        with self.swarm.changed:
            while not want <= self.swarm.alive:
                left = deadline - time.monotonic()
                dead = [i for i in want if i in self.swarm.procs and self.swarm.procs[i].poll() is not None]
                if dead:
                    raise RuntimeError(f"agent {dead[0]} exited during start-up (code {self.swarm.procs[dead[0]].returncode})")
                if left <= 0:
                    missing = sorted(want - self.swarm.alive)
                    raise TimeoutError(f"{len(missing)} agents not ready after {timeout:.0f} s (first: {missing[:5]})")
                self.swarm.changed.wait(min(left, 0.5))

    def end_at(self, step: int) -> None:
        """Every agent finishes at `step` (or its own last step if that comes first): ctl/end, said again
        with the clock so that no agent misses it."""
        self.end_step = int(step)
        self.session.put(keys.ctl_key(self.run, "end"), _CLOCK.pack(self.end_step),
                         congestion_control=zenoh.CongestionControl.BLOCK)

    def start(self) -> None:
        # Block, not zenoh's default Drop: at N = 1000 the links are still full of liveliness declarations
        # when the swarm starts, and an agent that missed the one start message never stepped.
        self.session.put(keys.ctl_key(self.run, "start"), b"start", congestion_control=zenoh.CongestionControl.BLOCK)

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
                pending = [i for i in ids if waiting(i, time.monotonic())]
                if not pending:
                    return
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"{len(pending)} agents still running after {timeout:.0f} s")
                self.swarm.changed.wait(min(left, 0.2))
                if progress is not None:
                    self.swarm.changed.release()
                    try:
                        progress()
                    finally:
                        self.swarm.changed.acquire()

    def close(self) -> dict[int, int | None]:
        """Stop every agent (stop message, then SIGTERM, then SIGKILL) and the router. Idempotent."""
        if self.closed:
            return {i: p.returncode for i, p in self.swarm.procs.items()}
        self.closed = True
        if getattr(self, "_clock_stop", None) is not None:
            self._clock_stop.set()
        procs = self.swarm.procs
        if any(p.poll() is None for p in procs.values()):
            try:
                self.session.put(keys.ctl_key(self.run, "stop"), b"stop")
            except Exception:  # the session may already be gone on an interrupted run
                pass
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
        _wait_all(procs.values(), 5.0)
        self.stop_recorder()
        for s in self._subs:
            try:
                s.undeclare()
            except Exception:
                pass
        try:
            self.session.close()
        except zenoh.ZError:  # the router's close can time out with many links still open; nothing is lost
            pass
        if self._socket_dir:
            shutil.rmtree(self._socket_dir, ignore_errors=True)
        return {i: p.returncode for i, p in procs.items()}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _wait_all(procs, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    for p in procs:
        try:
            p.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass


def run_swarm(setup, steps: int, *, launcher: Launcher | None = None, startup_timeout: float | None = None,
              run_timeout: float | None = None, on_started: Callable[[Launcher], None] | None = None,
              progress: Callable[[], None] | None = None, ids=None, swarm_ids=None, per_agent: dict | None = None,
              **spec_extra) -> SwarmResult:
    """Run `setup` (agent.sph.setups.Setup) through one agent process per particle, lockstep, `steps` steps.

    With a `launcher` given, the caller owns it (and closes it); otherwise one is made and closed here.
    `ids` is the slice started on this host; `swarm_ids` the whole swarm, whose alive tokens the start
    barrier waits for (other hosts start the rest), so nobody steps before every subscriber is known.
    """
    own = launcher is None
    launcher = launcher or Launcher()
    result = None
    try:
        chosen = [int(i) for i in (setup.ids if ids is None else ids)]
        index = {int(i): k for k, i in enumerate(setup.ids)}
        everyone = [int(i) for i in swarm_ids] if swarm_ids is not None else chosen
        startup_budget = startup_timeout or 60.0 + 0.5 * len(everyone)
        # An agent waits for the start signal as long as the launcher waits for the swarm to come up (a
        # 1000-agent swarm takes minutes on two cores), not a fixed 120 s.
        spec_extra.setdefault("start_timeout", max(120.0, startup_budget + 30.0))
        t0 = time.monotonic()
        near = initial_neighbours(everyone, [setup.states[index[i]][:2] for i in everyone], setup.params)
        for i in chosen:
            k = index[i]
            extra = {**spec_extra, "neighbours": near[i], **(per_agent or {}).get(i, {})}
            launcher.spawn(launcher.spec_for(i, setup.states[k], setup.controls[k], setup.params, steps, **extra))
        launcher.track_progress()
        launcher.wait_alive(everyone, startup_budget)
        startup = time.monotonic() - t0
        t1 = time.monotonic()
        launcher.start()
        if on_started is not None:
            on_started(launcher)
        launcher.wait_finals(chosen, run_timeout or 60.0 + steps * (0.05 + 0.004 * len(chosen)), progress)
        wall = time.monotonic() - t1
        # Late joiners (spawned during the run) finish at the same step as the rest: count them too.
        late = [i for i in list(launcher.swarm.procs) if i not in set(chosen) and i not in set(everyone)]
        if late:
            launcher.wait_finals(late, 30.0 + 0.1 * steps)
        with launcher.swarm.changed:
            finals = {i: launcher.swarm.finals[i] for i in chosen + late if i in launcher.swarm.finals}
            events = list(launcher.swarm.events)
        result = SwarmResult(chosen, finals, events, {}, wall, startup, steps)
        return result
    finally:
        if own:
            codes = launcher.close()
            if result is not None:
                result.exit_codes.update(codes)
