"""The agent process: one particle, its neighbours over Zenoh, the physics core's per-particle step.

Protocol (docs/protocol.md): one exchange per step. At step m the agent publishes its state in its
spatial cell, waits for the step-m states of the agents it expects near it, and computes its state for
step m+1 with `step_particle`. It only ever subscribes to the cells within R_sub of itself.

Asynchronous mode (`mode="async"`) drops the wait: each agent steps on its own clock at `rate` steps/s
with the latest state heard from each neighbour, as long as it is no older than `max_age` seconds -- what
a robot with its own control loop and lossy radio would do. Not reproducible, by design.
"""

from __future__ import annotations

import gc
import json
import math
import os
import random
import signal
import struct
import sys
import threading
import time
from collections import defaultdict, deque

import numpy as np
import zenoh

from agent import keys
from agent.session import client_config
from agent.spec import AgentSpec
from agent.sph.particle import NFIELDS, X, Y, initial_state, interacting, step_particle
from agent.wire import STATE_SIZE, decode_state, encode_state

_ID_STEP = struct.Struct("<II")  # agent id and step, at offset 4 of a state record (agent/wire.py)
_NOBODY: frozenset = frozenset()

# A neighbour can be at most one step ahead of an agent it waits for; messages further ahead are kept
# (another part of the swarm may run ahead) up to this window, beyond it they are rejected as bogus.
MAX_AHEAD = 1000
# Distinct senders within the support, BEHIND_STEPS or more steps ahead, mean the swarm has dropped
# this agent (it was frozen): a neighbour that still waited for us could be at most one step ahead.
BEHIND_SENDERS = 2
BEHIND_STEPS = 5
# A neighbour at most this many steps behind is waited for (a slower group catching up); one further
# behind has stalled and is not (it catches up from the queued states or leaves, see FellBehind).
LAG_WAIT_STEPS = 3
# Pacing: never more than this many steps ahead of the launcher's clock (the slowest live agent).
CLOCK_LEAD = 3
EXIT_OK, EXIT_FELL_BEHIND, EXIT_STOPPED, EXIT_NO_START = 0, 3, 4, 5


def direct(fn):
    """Run a callback on Zenoh's own receiving thread. A plain Python callable gets a Python thread of its
    own per subscriber (zenoh-python's default, indirect=True): ~35 threads per agent, one cell each, and
    a thread hand-over per message (docs/benchmarks/profile.md)."""
    return zenoh.handlers.Callback(fn, indirect=False)


class Stop(Exception):
    """SIGTERM/SIGINT or the launcher's stop: leave the loop and close cleanly."""


def covering_cells(x: float, y: float, radius: float, cell: float) -> set[tuple[int, int]]:
    """Cells of side `cell` that intersect the disc of `radius` around (x, y)."""
    cx0, cx1 = math.floor((x - radius) / cell), math.floor((x + radius) / cell)
    cy0, cy1 = math.floor((y - radius) / cell), math.floor((y + radius) / cell)
    out = set()
    for cx in range(cx0, cx1 + 1):
        dx = max(cx * cell - x, 0.0, x - (cx + 1) * cell)
        for cy in range(cy0, cy1 + 1):
            dy = max(cy * cell - y, 0.0, y - (cy + 1) * cell)
            if dx * dx + dy * dy <= radius * radius:
                out.add((cx, cy))
    return out


class Agent:
    def __init__(self, spec: AgentSpec, controller=None):
        self.spec = spec
        self.params = spec.sph_params()
        p = self.params
        self.cell = p.h
        d = p.max_step_displacement
        # Radii (docs/protocol.md): wait for agents last seen within r_expect; subscribe to r_sub.
        self.r_expect = p.support + 3 * d
        self.r_sub = p.support + 6 * d
        self.r_keep = self.r_sub + 0.5 * self.cell
        x, y, vx, vy = spec.initial
        self.state = initial_state(x, y, vx, vy, p)
        self.controller = controller
        self.static_control = spec.static_control()
        # Zenoh's receiving thread appends (kind, data) here and rings the bell only when the main thread
        # has something to do: a control/liveliness/command message, or the last awaited state of a step.
        # One wake-up per step instead of one per message (docs/benchmarks/profile.md).
        self.inbox: deque = deque()
        self._bell = threading.Lock()
        self._bell.acquire()
        self._await_step = -1
        self._awaited: set[int] | frozenset = _NOBODY  # ids whose _await_step state the main thread waits for
        self._wake_on_state = False
        self.buffer: dict[int, dict[int, list]] = defaultdict(dict)
        self.latest: dict[int, tuple[int, float, float]] = {}
        self.dead: set[int] = set()
        self.ahead_senders: set[int] = set()
        self.heard_at: dict[int, float] = {}
        self.clock: int | None = None  # the slowest live agent's step, from the launcher (ctl/clock)
        self.last_step_done = time.monotonic()
        self.step = 0
        self.started = False
        self.stop_requested = False
        self.rng = random.Random(spec.id)
        self.counters = {"msgs_received": 0, "neighbours": 0, "rejected": defaultdict(int), "timeouts": 0,
                         "deaths_seen": 0, "stale": 0, "dropped_out": 0, "lost": 0}
        self.subscribers: dict[tuple[int, int], object] = {}
        self.step_started_at: float | None = None
        self.step_ended_at: float | None = None
        self.asynchronous = spec.mode == "async"
        self.fresh: dict[int, tuple[float, list]] = {}  # async: neighbour -> (heard at, latest state)

    # ---- Zenoh callbacks (on Zenoh's receiving thread): enqueue, decode nothing, rarely wake -----------
    def _ring(self) -> None:
        try:
            self._bell.release()
        except RuntimeError:  # already rung
            pass

    def _on_state(self, sample) -> None:
        data = sample.payload.to_bytes()
        self.inbox.append((0, data))
        awaited = self._awaited
        if awaited:
            # A hint only: the main thread validates the record and recomputes what it still misses. A
            # later step counts too: that neighbour has moved on (see _wait_for).
            if len(data) == STATE_SIZE:
                j, step = _ID_STEP.unpack_from(data, 4)
                if j in awaited and step >= self._await_step:
                    awaited.discard(j)
                    if not awaited:
                        self._ring()
        elif self._wake_on_state:
            self._ring()

    def _on_alive(self, sample) -> None:
        if sample.kind == zenoh.SampleKind.DELETE:
            self.inbox.append((1, str(sample.key_expr)))
            self._ring()

    def _on_ctl(self, sample) -> None:
        self.inbox.append((2, (str(sample.key_expr), sample.payload.to_bytes())))
        self._ring()

    def _on_command(self, sample) -> None:
        self.inbox.append((3, sample.payload.to_bytes()))
        self._ring()

    # ---- message handling ----------------------------------------------------------------------
    def _handle(self, item) -> None:
        kind, data = item
        if kind == 0:
            self._handle_state(data)
        elif kind == 1:
            j = keys.id_from_key(data)
            if j is not None and j != self.spec.id and j not in self.dead:
                self.dead.add(j)
                self.latest.pop(j, None)
                self.fresh.pop(j, None)
                self.counters["deaths_seen"] += 1
        elif kind == 2:
            key, payload = data
            if key.endswith("/start"):
                self.started = True
            elif key.endswith("/stop"):
                raise Stop()
            elif key.endswith("/clock") and len(payload) == 8:
                self.clock = int.from_bytes(payload, "little")
        elif kind == 3 and self.controller is not None:
            first = not self.controller.has_command
            reason = self.controller.offer(data)
            if reason:
                self.counters["rejected"]["command_" + reason] += 1
            elif first and self.controller.has_command:
                self._event("command_received", seconds_since_session_open=time.time() - self.session_opened_at)

    def _handle_state(self, data: bytes) -> None:
        decoded, reason = decode_state(data)
        if decoded is None:
            self.counters["rejected"][reason] += 1
            return
        j, step, _cls, values = decoded
        if j == self.spec.id:
            return
        if j in self.dead or step > self.step + MAX_AHEAD:
            self.counters["rejected"]["dead" if j in self.dead else "step"] += 1
            return
        self.counters["msgs_received"] += 1
        last = self.latest.get(j)
        if last is None or step >= last[0]:
            self.latest[j] = (step, values[X], values[Y])
            self.heard_at[j] = time.monotonic()
            if self.asynchronous:
                self.fresh[j] = (self.heard_at[j], values)
        if self.asynchronous:
            return
        if step < self.step:
            self.counters["stale"] += 1
            return
        self.buffer[step][j] = values
        if self.started and step >= self.step + BEHIND_STEPS:
            # A particle within the support that is this far ahead is no longer waiting for us.
            dx, dy = values[X] - self.state[X], values[Y] - self.state[Y]
            # Only an agent that itself stalled (SIGSTOP) concludes it was dropped; a merely slower group
            # is waited for by the faster one (see _expected).
            stalled = time.monotonic() - self.last_step_done > self.spec.timeout
            if stalled and dx * dx + dy * dy <= self.params.support ** 2:
                self.ahead_senders.add(j)
                if len(self.ahead_senders) >= BEHIND_SENDERS:
                    raise FellBehind()

    # ---- subscriptions -------------------------------------------------------------------------
    def _update_subscriptions(self) -> None:
        x, y = self.state[X], self.state[Y]
        want = covering_cells(x, y, self.r_sub, self.cell)
        keep = covering_cells(x, y, self.r_keep, self.cell)
        for c in list(self.subscribers):
            if c not in keep:
                self.subscribers.pop(c).undeclare()
        for c in want:
            if c not in self.subscribers:
                self.subscribers[c] = self.session.declare_subscriber(keys.state_cell_expr(self.spec.run, *c), direct(self._on_state))

    # ---- the run -------------------------------------------------------------------------------
    def _event(self, what: str, **fields) -> None:
        msg = {"id": self.spec.id, "step": self.step, "event": what, **fields}
        self.session.put(keys.event_key(self.spec.run, self.spec.id), json.dumps(msg))

    def _drain(self, timeout: float) -> bool:
        """Handle queued messages. With none queued, sleep up to `timeout` or until a callback rings (states
        ring only for the last awaited one, see _wait_for). False if nothing was handled."""
        inbox = self.inbox
        if not inbox and timeout > 0:
            self._bell.acquire(timeout=timeout)
        if not inbox:
            return False
        pop, handle = inbox.popleft, self._handle
        while inbox:
            handle(pop())
        return True

    def _discover_initial_neighbours(self) -> None:
        """Step-0 neighbours: the agents whose *born* token lies in a cell we watch (liveliness query)."""
        x, y = self.state[X], self.state[Y]
        for c in covering_cells(x, y, self.r_sub, self.cell):
            for reply in self.session.liveliness().get(keys.born_cell_expr(self.spec.run, *c), timeout=10.0):
                try:
                    j = keys.id_from_key(str(reply.ok.key_expr))
                except Exception:  # an error reply carries no key: nothing to learn from it
                    continue
                if j is not None and j != self.spec.id and j not in self.latest:
                    self.latest[j] = (-1, math.nan, math.nan)

    def _expected(self) -> set[int]:
        x, y = self.state[X], self.state[Y]
        r2 = self.r_expect * self.r_expect
        out = set()
        recent = self.step - 1
        now = time.monotonic()
        stale = []
        for j, (s, jx, jy) in self.latest.items():
            if math.isnan(jx):
                out.add(j)
            elif s < recent - LAG_WAIT_STEPS:
                stale.append(j)  # never expected again unless heard again (which records it anew)
            elif (jx - x) ** 2 + (jy - y) ** 2 <= r2:
                # Heard at the previous step: a neighbour in step. Heard lately at an older step: a
                # lagging group we must let catch up. Otherwise the sighting is stale (it moved away).
                if s >= recent or now - self.heard_at.get(j, 0.0) < self.spec.timeout:
                    out.add(j)
        for j in stale:  # keep this loop proportional to the neighbourhood, not to everyone ever heard
            del self.latest[j]
            self.heard_at.pop(j, None)
        return out

    def _publish(self) -> None:
        if self.spec.drop_out and self.rng.random() < self.spec.drop_out:
            self.counters["dropped_out"] += 1
            return
        cx, cy = keys.cell_of(self.state[X], self.state[Y], self.cell)
        cls = self.controller.particle_class if self.controller is not None else 0
        self.session.put(keys.state_key(self.spec.run, cx, cy, self.spec.id),
                         encode_state(self.spec.id, self.step, self.state, cls))

    def _wait_for(self, expected: set[int]) -> None:
        try:
            self._wait_for_states(expected)
        finally:
            self._awaited = _NOBODY

    def _wait_for_states(self, expected: set[int]) -> None:
        deadline = time.monotonic() + self.spec.timeout
        resend_at = time.monotonic() + self.spec.timeout / 4
        have = self.buffer[self.step]
        while True:
            self._drain(0)
            # A neighbour already heard at a later step has moved on: its state of this step was lost
            # (messages of one publisher arrive in order), so waiting for it would only cost the timeout.
            missing = {j for j in expected if j not in have and j not in self.dead
                       and not self.latest.get(j, (-1,))[0] > self.step}
            if not missing:
                lost = [j for j in expected if j not in have and j not in self.dead]
                self.counters["lost"] += len(lost)
                return
            now = time.monotonic()
            if now >= resend_at:
                # Lossy links: say it again while waiting (a neighbour that missed our state of this step
                # is waiting too). Spaced at timeout/4 so a merely slow swarm is not flooded.
                self._publish()
                resend_at = now + self.spec.timeout / 4
            left = deadline - now
            if left <= 0:
                for j in missing:  # silent too long: frozen, partitioned, or dropping messages
                    self.latest.pop(j, None)
                    self.counters["timeouts"] += 1
                self._event("neighbour_timeout", neighbours=sorted(missing))
                return
            # Arm the bell: the receiving thread rings when the last of `missing` has been heard. The step is
            # set before the set, and whatever was queued before arming is handled first (loop again).
            self._await_step = self.step
            self._awaited = missing
            if self.inbox:
                continue
            self._bell.acquire(timeout=min(left, resend_at - now, 0.25))

    def run(self) -> int:
        spec = self.spec
        self.session = zenoh.open(client_config(spec.connect, spec.user, spec.password))
        self.session_opened_at = time.time()
        try:
            return self._run()
        finally:
            for sub in self.subscribers.values():
                sub.undeclare()
            self._flush()
            self.session.close()

    def _flush(self) -> None:
        """Make sure what we put last (the final report) has left: Zenoh's close does not wait for the send
        queue, and with nothing else to do at exit the report was sometimes lost. A query to the router travels
        behind it on the same link, so its answer means the router has the report."""
        try:
            for _ in self.session.liveliness().get(keys.alive_key(self.spec.run, self.spec.id), timeout=1.0):
                pass
        except Exception:  # the router is gone: nobody left to read the report anyway
            pass

    def _run(self) -> int:
        spec, run = self.spec, self.spec.run
        s = self.session
        s.declare_subscriber(keys.ctl_expr(run), direct(self._on_ctl))
        s.liveliness().declare_subscriber(keys.alive_expr(run), direct(self._on_alive))
        if self.controller is not None:
            s.declare_subscriber(keys.command_key(run), direct(self._on_command))
        self._update_subscriptions()
        if self.controller is not None and not spec.join:
            # Ready only once the gesture command is known, so every agent applies it from step 0.
            deadline = time.monotonic() + spec.start_timeout
            while not self.controller.has_command:
                if time.monotonic() > deadline:
                    return EXIT_NO_START
                self._drain(0.25)
        cx, cy = keys.cell_of(self.state[X], self.state[Y], self.cell)
        # The born token first: the launcher's start barrier waits for alive tokens, so when it fires
        # every born token is already known to the router and the step-0 query sees all of them.
        self.tokens = [s.liveliness().declare_token(keys.born_key(run, cx, cy, spec.id)),
                       s.liveliness().declare_token(keys.alive_key(run, spec.id))]
        try:
            if spec.join:
                self._join()
            else:
                deadline = time.monotonic() + spec.start_timeout
                while not self.started:
                    if time.monotonic() > deadline:
                        return EXIT_NO_START
                    self._drain(0.25)
                self._discover_initial_neighbours()
            self._event("started")
            # Everything allocated so far (modules, numpy, zenoh) lives as long as the process: move it out of
            # the collector's sight, so the collections the message handling triggers stay cheap.
            gc.collect()
            gc.freeze()
            self.step_started_at = time.time()
            self.cpu_at_start = time.process_time()
            self.last_step_done = time.monotonic()
            (self._run_async if self.asynchronous else self._run_lockstep)()
            self.step_ended_at = time.time()
            self._publish()  # the final state, so neighbours still waiting for it are not held up
            self._report("done")
            return EXIT_OK
        except FellBehind:
            self._event("fell_behind")
            self._report("fell_behind")
            return EXIT_FELL_BEHIND
        except Stop:
            self._report("stopped")
            return EXIT_STOPPED

    def _run_lockstep(self) -> None:
        """Publish, wait for the expected neighbours' states of this step, then step (docs/protocol.md)."""
        spec = self.spec
        while self.step < spec.steps:
            while self.clock is not None and self.step > self.clock + CLOCK_LEAD:
                self._drain(0.05)  # an isolated particle must not run ahead of the swarm
            self._publish()
            self._wait_for(self._expected() - {spec.id})
            self._drain(0)
            current = self.buffer.pop(self.step, {})
            if current:
                ids = sorted(current)
                neighbours = np.array([current[j] for j in ids])
            else:
                neighbours = np.empty((0, NFIELDS))
            self._advance(neighbours)

    def _advance(self, neighbours: np.ndarray) -> None:
        """One SPH step of this particle with the given neighbour rows (both modes)."""
        control = self.controller.control(self.state, self.step) if self.controller is not None else self.static_control
        self.counters["neighbours"] += len(interacting(self.state, neighbours, self.params)) if len(neighbours) else 0
        self.state = step_particle(self.state, neighbours, control, self.params)
        self.step += 1
        self.last_step_done = time.monotonic()
        self._update_subscriptions()

    def _fresh_neighbours(self, now: float) -> np.ndarray:
        """Async mode: the latest state of every neighbour heard within max_age; older ones are forgotten."""
        cutoff = now - self.spec.max_age
        rows, expired = [], []
        for j, (t, values) in list(self.fresh.items()):
            if t >= cutoff:
                rows.append(values)
                continue
            del self.fresh[j]
            dx, dy = values[X] - self.state[X], values[Y] - self.state[Y]
            # Within the support when last heard and still subscribed to: it went silent (frozen, dropping
            # messages) rather than moved away, which is what a lockstep neighbour timeout reports.
            if dx * dx + dy * dy <= self.params.support ** 2:
                expired.append(j)
        if expired:
            self.counters["timeouts"] += len(expired)
            self._event("neighbour_timeout", neighbours=sorted(expired))
        return np.array(rows) if rows else np.empty((0, NFIELDS))

    def _run_async(self) -> None:
        """Step on this agent's own clock; never wait for anyone (docs/protocol.md, asynchronous mode)."""
        period = 1.0 / self.spec.rate
        due = time.monotonic()
        while self.step < self.spec.steps:
            self._publish()
            self._drain(0)
            now = time.monotonic()
            self._advance(self._fresh_neighbours(now))
            due += period
            if now - due > self.spec.max_age:
                due = now  # after a freeze: carry on at the rate instead of racing through the missed steps
            while (left := due - time.monotonic()) > 0:
                self._drain(left)

    def _join(self) -> None:
        """A late joiner adopts the step of the first states it hears around it (docs/protocol.md)."""
        deadline = time.monotonic() + self.spec.start_timeout
        self._wake_on_state = True
        try:
            self._await_first_state(deadline)
        finally:
            self._wake_on_state = False

    def _await_first_state(self, deadline: float) -> None:
        while True:
            if not self.inbox:
                self._bell.acquire(timeout=0.25)
                if not self.inbox:
                    if time.monotonic() > deadline:
                        raise Stop()
                    continue
            item = self.inbox.popleft()
            if item[0] == 0:
                decoded, _ = decode_state(item[1])
                if decoded is not None and decoded[0] != self.spec.id:
                    self.step = decoded[1] + 1
                    self.started = True
                    self.buffer.clear()
                    return
            else:
                self._handle(item)

    def _report(self, status: str) -> None:
        c = self.counters
        msg = {
            "id": self.spec.id, "status": status, "steps": self.step, "state": [float(v) for v in self.state],
            "msgs_received": c["msgs_received"], "neighbours": c["neighbours"], "rejected": dict(c["rejected"]),
            "timeouts": c["timeouts"], "deaths_seen": c["deaths_seen"], "stale": c["stale"],
            "dropped_out": c["dropped_out"], "lost": c["lost"], "t_start": self.step_started_at, "t_end": self.step_ended_at,
            "session_opened_at": getattr(self, "session_opened_at", None),
            "rss_mb": peak_rss_mb(),
            "cpu_seconds": time.process_time(), "cpu_seconds_at_start": getattr(self, "cpu_at_start", None),
        }
        if self.controller is not None:
            msg.update(self.controller.report())
        self.session.put(keys.final_key(self.spec.run, self.spec.id), json.dumps(msg))


def peak_rss_mb() -> float:
    """This process's peak resident memory (VmHWM). Not getrusage's ru_maxrss: Linux carries the high-water
    mark of the forked copy of the parent across exec, so every agent reported at least the launcher's size
    at spawn time (the first benchmark's 74-143 MB per agent; docs/benchmarks/profile.md)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class FellBehind(Exception):
    """Neighbours are two or more steps ahead: the swarm has dropped this agent (after a freeze)."""


def main(argv: list[str] | None = None) -> int:
    import argparse

    parser = argparse.ArgumentParser(prog="fluidswarm agent", description="run one SPH particle agent")
    parser.add_argument("--spec", required=True, help="the agent's start-up parameters as JSON (agent/spec.py)")
    args = parser.parse_args(argv)
    try:
        spec = AgentSpec.from_json(args.spec)
    except ValueError as exc:
        print(f"fluidswarm agent: error: {exc}", file=sys.stderr)
        return 2

    def on_signal(signum, frame):
        raise Stop()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    controller = None
    if spec.secret or os.environ.get("FLUIDSWARM_SECRET"):
        from agent.route import CommandFollower

        controller = CommandFollower(spec)
    try:
        return Agent(spec, controller).run()
    except Stop:
        return EXIT_STOPPED
