"""Following a run's progress and pacing it: the launcher's view of the steps, and ctl/clock, end, gone.

A passive observer of every state message (like the recorder): the step each agent is at, when each step
was first seen, the newest state record of each agent (for watchers such as coordinator/control/settle.py).
From that, a thread publishes the pacing clock (the slowest live agent's step), relays lost agents on
ctl/gone and repeats ctl/end (docs/protocol.md), as agent/protocol/ctl.py records.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import zenoh

from agent.protocol import keys
from agent.protocol.ctl import Clock, End, Gone, ctl_message
from agent.protocol.errors import SwarmTimeout
from agent.protocol.wire import peek_id_step

# s between ctl/clock messages. Agents stay within CLOCK_LEAD (3) steps of the clock, so a 10 Hz clock capped
# every swarm at ~30 steps/s; the compiled agents run faster than that.
CLOCK_PERIOD = 0.02
CLOCK_REPEAT = 1.0
CLOCK_LEAD = 3  # steps an agent may run past the clock (agent/native/src/agent.rs CLOCK_LEAD)
GONE_GRACE = 0.25  # s a lost agent's report may come after its token's deletion (Pacer._clock)
AHEAD = 1000  # steps: a state further ahead of the newest step seen is not believed (untrusted input)


class Pacer:
    """`swarm` (swarmhost/supervisor.py Swarm): its alive agents and lost ones; `agent_timeout` [s]: an agent
    silent this long (frozen) does not hold the clock back."""

    def __init__(self, swarm, agent_timeout: float, id_keys: bool, clock_period: float = CLOCK_PERIOD):
        self.swarm, self.agent_timeout, self.clock_period = swarm, agent_timeout, clock_period
        self.id_keys = id_keys  # states on the agents' id keys (per-process rights), else on cell keys
        self.session, self.run = swarm.session, swarm.run
        self.step_times: dict[int, float] = {}  # step -> wall time its first state was seen
        self.max_step = -1
        self.agent_steps: dict[int, tuple[int, float]] = {}  # id -> (its newest step, when it was seen)
        self.held_out: set[int] = set()  # went silent (frozen); back on the clock once at the clock's step
        self.newest: dict[int, bytes] = {}  # id -> its newest state record, undecoded (watchers decode it)
        self.end_step: int | None = None
        self.started_at: float | None = None  # when the agents were told to start (mark_start)
        self.dt: float | None = None  # simulated seconds per step (mark_start)
        self.realtime = False  # pace_realtime: simulated time held to the wall clock
        self._states = None
        self._stop = threading.Event()

    def start(self) -> None:
        """Start following and pacing (idempotent)."""
        if self._states is not None:
            return
        # Queued in zenoh (a ring: a slow launcher loses old samples, never blocks the router it hosts) and
        # drained in batches by the clock thread: no Python callback, no GIL, per state message on the
        # router's receiving threads (N messages per step).
        self._states = states = self.session.declare_subscriber(
            keys.state_observed_expr(self.run, self.id_keys), zenoh.handlers.RingChannel(1 << 16)
        )
        threading.Thread(target=self._clock, args=(states,), daemon=True).start()

    def stop(self) -> None:
        self._stop.set()
        if self._states is not None:
            try:
                self._states.undeclare()
            except Exception:  # noqa: BLE001, S110  # undeclaring on a session that is closing may fail; nothing left to do
                pass

    def mark_start(self, dt: float) -> None:
        """The agents were just told to start; a step lasts `dt` simulated seconds (realtime_factor)."""
        self.started_at, self.dt = time.monotonic(), float(dt)

    def pace_realtime(self) -> None:
        """From now on (after mark_start) simulated time never runs ahead of the wall clock: the clock is
        held CLOCK_LEAD + 1 steps below the step the wall clock has reached, so no agent passes it."""
        self.realtime = True
        self.session.put(*ctl_message(self.run, Clock(0)), congestion_control=zenoh.CongestionControl.BLOCK)

    def realtime_factor(self) -> float | None:
        """Simulated seconds / wall seconds of the swarm's run: the newest step over the time from the
        start to its first sighting (1.0: as fast as the wall clock; None before mark_start or a step)."""
        if self.started_at is None or self.dt is None or self.max_step < 1:
            return None
        wall = self.step_times[self.max_step] - self.started_at
        return self.max_step * self.dt / wall if wall > 0 else None

    def _wall_step(self, now: float) -> int:
        assert self.started_at is not None and self.dt is not None  # paced only after mark_start
        return max(0, int((now - self.started_at) / self.dt) - CLOCK_LEAD - 1)

    def _on_state(self, sample) -> None:
        data = sample.payload.to_bytes()
        peek = peek_id_step(data)
        if peek is None:
            return
        agent_id, step = peek
        if not keys.state_key_vouches(str(sample.key_expr), agent_id):
            return  # under another agent's key or a wildcard key: a forgery (docs/security.md)
        now = time.monotonic()
        last = self.agent_steps.get(agent_id)
        if (last is None or step > last[0]) and step <= self.max_step + AHEAD:
            self.agent_steps[agent_id] = (step, now)
            self.newest[agent_id] = data
        if step not in self.step_times and step <= self.max_step + AHEAD:
            self.step_times[step] = now
            self.max_step = max(self.max_step, step)

    def _clock(self, states: zenoh.Subscriber[zenoh.Handler[zenoh.Sample]]) -> None:
        """Publish the slowest live agent's step on ctl/clock every `clock_period` s when it moved.

        Agents that are not connected to anyone (an isolated particle) would otherwise race ahead of the
        swarm and meet it again at a different step; with the clock they stay within CLOCK_LEAD steps.
        Agents silent for longer than the neighbour timeout (frozen) or gone do not hold the clock back.
        """
        last = said = None
        said_at = 0.0
        # 50 Hz, and only when it moves: with a lead of CLOCK_LEAD steps, a 10 Hz clock capped every swarm at
        # ~30 steps/s (the compiled agents run faster than that).
        while not self._stop.wait(self.clock_period):
            try:
                while (sample := states.try_recv()) is not None:
                    self._on_state(sample)
            except Exception:  # noqa: BLE001  # the session is closing (zenoh raises several types then)
                return
            now = time.monotonic()
            with self.swarm.changed:
                alive = set(self.swarm.alive)
                # An agent that finished has its token's deletion delivered before its report (declarations
                # travel first): only a loss without a report within GONE_GRACE is relayed. Told at once, a
                # neighbour still waiting for the finished agent's last state would stop waiting for it.
                lost = [(j, t) for j, t in self.swarm.gone if j not in self.swarm.finals]
                gone = [j for j, t in lost if now - t >= GONE_GRACE]
                self.swarm.gone = [(j, t) for j, t in lost if now - t < GONE_GRACE]
            # Agents learn of a lost neighbour from this relay, not from a liveliness subscriber each on every
            # other agent's token: that was N² declarations at start-up (70 s at N = 1000, native.md).
            for j in gone:
                try:
                    self.session.put(*ctl_message(self.run, Gone(j)), congestion_control=zenoh.CongestionControl.BLOCK)
                except Exception:  # noqa: BLE001  # the session is closing (zenoh raises several types then)
                    return
            steps = self._clocked_steps(alive, now, said)
            if steps:
                last = min(steps)
            if self.realtime:
                last = self._wall_step(now) if last is None else min(last, self._wall_step(now))
            # Said again every CLOCK_REPEAT s, and with congestion control Block: a clock tick dropped by a
            # congested link held 555 of 1000 agents at their lead for good (nobody moved, so no new tick).
            if last is not None and (last != said or now - said_at >= CLOCK_REPEAT):
                said, said_at = last, now
                try:
                    self.session.put(
                        *ctl_message(self.run, Clock(last)), congestion_control=zenoh.CongestionControl.BLOCK
                    )
                    if self.end_step is not None:
                        self.end_at(self.end_step)
                except Exception:  # noqa: BLE001  # the session is closing (zenoh raises several types then)
                    return

    def _clocked_steps(self, alive: set[int], now: float, said: int | None) -> list[int]:
        """The steps of the agents that hold the clock back: alive, heard within the agent timeout, and not
        resumed behind the swarm. A frozen agent that resumes is heard again at the step it froze at while it
        rejoins (docs/protocol.md); counted at once, it pulled the clock back to that step and held the whole
        swarm there (measured: a 2.2 s stall of 30 agents when one resumed 45 steps behind, for a 1.5 s
        timeout). So an agent that went silent counts again only once it has reached the clock's step."""
        steps = []
        for j, (s, t) in list(self.agent_steps.items()):
            if j not in alive:
                continue
            if now - t >= self.agent_timeout:
                self.held_out.add(j)
                continue
            if j in self.held_out:
                if said is not None and s < said:
                    continue
                self.held_out.discard(j)
            steps.append(s)
        return steps

    def longest_stall(self) -> float:
        """Longest wall-clock gap between the first sightings of consecutive steps (s): how long the swarm as
        a whole made no progress, e.g. while it waited for frozen agents."""
        if len(self.step_times) < 2:
            return 0.0
        t = np.maximum.accumulate(np.array([self.step_times[k] for k in sorted(self.step_times)]))
        return float(np.max(np.diff(t)))

    def wait_step(self, step: int, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while self.max_step < step:
            if time.monotonic() > deadline:
                raise SwarmTimeout(f"run did not reach step {step} in {timeout:.0f} s")
            time.sleep(0.01)

    def end_at(self, step: int) -> None:
        """Every agent finishes at `step` (or its own last step if that comes first): ctl/end, said again
        with the clock so that no agent misses it."""
        self.end_step = int(step)
        self.session.put(*ctl_message(self.run, End(self.end_step)), congestion_control=zenoh.CongestionControl.BLOCK)
