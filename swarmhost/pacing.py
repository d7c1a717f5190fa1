"""Following a run's progress and pacing it: the zenoh shell of the launcher's pacing core.

A passive observer of every state message (like the recorder): the step each agent is at, when each step
was first seen, the newest state record of each agent (for watchers such as coordinator/control/settle.py).
From that, a thread publishes the pacing clock (the slowest live agent's step), relays lost agents on
ctl/gone and repeats ctl/end (docs/protocol.md), as agent/protocol/ctl.py records. What to say and when is
decided by `PaceCore` (swarmhost/pacing_core.py, no I/O); this shell declares the subscribers, drains them into
the core with the time, hands it the supervisor's losses, and puts what the core answers.

In a split run (`Pacer.split`, under per-process rights) a launcher follows only its own share's states (one
subscriber per own agent's id key: no state of another host crosses a router-to-router link for it) and says
its share's clock on `pace/<id>` (agent/protocol/pace.py); the host that owns the run's clock puts `ctl/clock`
= the minimum over every host's share clock, and stops waiting for a host whose share clock went silent for
PACE_SILENCE s (named once on stderr and in `notes`).
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable

import numpy as np
import zenoh

from agent.protocol import keys
from agent.protocol.ctl import ctl_message
from agent.protocol.errors import SwarmTimeout
from agent.protocol.pace import pace_expr, pace_key
from swarmhost.pacing_core import (
    CLOCK_PERIOD,
    GONE_GRACE,
    Action,
    HostLost,
    Note,
    PaceCore,
    Say,
    SayPace,
    Share,
)

__all__ = ["CLOCK_PERIOD", "GONE_GRACE", "Pacer", "Share"]


class Pacer:
    """`swarm` (swarmhost/supervisor.py Swarm): its alive agents and lost ones; `agent_timeout` [s]: an agent
    silent this long (frozen) does not hold the clock back."""

    def __init__(
        self, swarm, agent_timeout: float, id_keys: bool, batches: bool = False, clock_period: float = CLOCK_PERIOD
    ):
        self.swarm, self.agent_timeout, self.clock_period = swarm, agent_timeout, clock_period
        self.id_keys = id_keys  # states on the agents' id keys (per-process rights), else on cell keys
        # `batches`: follow the embedded router's relay's batches (docs/protocol.md "State batches": one message
        # per lockstep step or BATCH_WAIT) instead of every agent's state message, when the launcher's own router
        # relays every state of the run (issue 49: each process woken about once per step, not N times)
        self.batches = batches
        self.session, self.run = swarm.session, swarm.run
        self.core = PaceCore(self.run, agent_timeout)
        self._states: list[zenoh.Subscriber] | None = None  # the state subscribers, then the share clocks'
        self._stop = threading.Event()
        self.on_host_lost: Callable[[dict, str], None] | None = None  # who hears of a dropped host as it happens

    # What the run reads, kept by the core (written by the clock thread, read between its ticks).
    @property
    def share(self) -> Share | None:
        return self.core.share

    @property
    def step_times(self) -> dict[int, float]:
        return self.core.step_times

    @property
    def max_step(self) -> int:
        return self.core.max_step

    @property
    def agent_steps(self) -> dict[int, tuple[int, float]]:
        return self.core.agent_steps

    @property
    def newest(self) -> dict[int, bytes]:
        return self.core.newest

    @property
    def notes(self) -> list[str]:
        return self.core.notes

    @property
    def lost_hosts(self) -> list[dict]:
        return self.core.lost_hosts

    @property
    def started_at(self) -> float | None:
        return self.core.started_at

    def split(self, share: Share) -> None:
        """Pace as one host of a split run (before start). Without per-process rights the states are on the
        cell keys only, so nothing can be followed by id: every launcher then follows every state and puts
        ctl/clock, as in one host's run."""
        if self.id_keys and self._states is None and set(share.own) and len(share.own) < share.swarm:
            self.core.share = share

    def start(self) -> None:
        """Start following and pacing (idempotent)."""
        if self._states is not None:
            return
        # Queued in zenoh (a ring: a slow launcher loses old samples, never blocks the router it hosts) and
        # drained in batches by the clock thread: no Python callback, no GIL, per state message on the
        # router's receiving threads (N messages per step).
        sh = self.share
        if sh is None and self.batches:
            self._states = states = [
                self.session.declare_subscriber(keys.batch_expr(self.run), zenoh.handlers.RingChannel(1 << 12))
            ]
        elif sh is None:
            self._states = states = [
                self.session.declare_subscriber(
                    keys.state_observed_expr(self.run, self.id_keys), zenoh.handlers.RingChannel(1 << 16)
                )
            ]
        else:  # only this host's agents: a subscriber on each one's id key
            self._states = states = [
                self.session.declare_subscriber(keys.state_key(self.run, i), zenoh.handlers.RingChannel(1 << 10))
                for i in sh.own
            ]
        if sh is not None and sh.follow_all:
            # The other hosts' states from their routers' batches (docs/protocol.md "State batches"), which
            # cross to this host for its recorder anyway: a subscriber on every id key pulled each of their
            # states over a router-to-router link once more, one message each (scripts/imitation_traffic.py).
            states.append(
                self.session.declare_subscriber(keys.batch_expr(self.run), zenoh.handlers.RingChannel(1 << 12))
            )
        paces, clocks = [], []
        if sh is not None and sh.owner:
            paces = [self.session.declare_subscriber(pace_expr(self.run), zenoh.handlers.RingChannel(1 << 12))]
        elif sh is not None:  # the owner's clock, to notice its silence (not this host's own puts of it)
            clocks = [
                self.session.declare_subscriber(
                    keys.ctl_key(self.run, "clock"),
                    zenoh.handlers.RingChannel(64),
                    allowed_origin=zenoh.Locality.REMOTE,
                )
            ]
        threading.Thread(target=self._clock, args=(states, paces, clocks), daemon=True).start()
        self._states = states + paces + clocks

    def stop(self) -> None:
        self._stop.set()
        if self._states is not None:
            self._act(self.core.farewell())  # a non-owner's share is done: the owner stops waiting for it at once
        for sub in self._states or []:
            try:
                sub.undeclare()
            except Exception:  # noqa: BLE001, S110  # undeclaring on a session that is closing may fail; nothing left to do
                pass

    def mark_start(self, dt: float) -> None:
        """The agents were just told to start; a step lasts `dt` simulated seconds (realtime_factor)."""
        self.core.mark_start(dt, time.monotonic())

    def pace_realtime(self) -> None:
        """From now on (after mark_start) simulated time never runs ahead of the wall clock (PaceCore)."""
        for action in self.core.pace_realtime():
            self._put(action)

    def realtime_factor(self) -> float | None:
        """Simulated seconds / wall seconds of the swarm's run (PaceCore.realtime_factor)."""
        return self.core.realtime_factor()

    def _put(self, action: Say | SayPace) -> None:
        """Put one of the core's messages; raises when the session is closing."""
        if isinstance(action, Say):
            key, payload = ctl_message(self.run, action.message)
        else:
            key, payload = pace_key(self.run, action.pace.first), action.pace.encode()
        self.session.put(key, payload, congestion_control=zenoh.CongestionControl.BLOCK)

    def _act(self, actions: list[Action]) -> bool:
        """Carry out the core's actions in order; False when the session is closing (nothing more to say)."""
        for action in actions:
            if isinstance(action, Note):
                print(f"fluidswarm: {action.text}", file=sys.stderr, flush=True)
            elif isinstance(action, HostLost):
                if self.on_host_lost is not None:
                    try:
                        self.on_host_lost(action.lost, action.text)
                    except OSError:  # the note is also in `notes`; a full disk loses only the MCAP's copy
                        pass
            else:
                try:
                    self._put(action)
                except Exception:  # noqa: BLE001  # the session is closing (zenoh raises several types then)
                    return False
        return True

    def hosts_done(self) -> bool:
        """Owner: every other host heard is done or dropped, and together they cover the swarm (or gave up)."""
        return self.core.hosts_done()

    def wait_hosts(self, timeout: float) -> None:
        """Owner of a split run's clock: after its own agents finished, keep pacing until every other host's
        share is done (or dropped as silent), at most `timeout` s: the others' agents step on this clock."""
        deadline = time.monotonic() + timeout
        while not self.hosts_done() and time.monotonic() < deadline and not self._stop.is_set():
            time.sleep(0.05)

    def _clock(
        self, states: list[zenoh.Subscriber], paces: list[zenoh.Subscriber], clocks: list[zenoh.Subscriber]
    ) -> None:
        """Every `clock_period` s: what the subscribers received and the supervisor's losses into the core, then
        its actions out. 50 Hz: with a lead of CLOCK_LEAD steps, a 10 Hz clock capped every swarm at ~30 steps/s
        (the compiled agents run faster than that); the core says the clock only when it moves."""
        core = self.core
        while not self._stop.wait(self.clock_period):
            now = time.monotonic()
            try:
                for sub in states:
                    while (sample := sub.try_recv()) is not None:
                        core.sample(str(sample.key_expr), sample.payload.to_bytes(), time.monotonic())
                for sub in paces:
                    while (sample := sub.try_recv()) is not None:
                        core.pace(str(sample.key_expr), sample.payload.to_bytes(), now)
                for sub in clocks:
                    while sub.try_recv() is not None:
                        core.owner_heard(now)
            except Exception:  # noqa: BLE001  # the session is closing (zenoh raises several types then)
                return
            with self.swarm.changed:
                alive = set(self.swarm.alive)
                for j, t in self.swarm.gone:
                    core.lose(j, t)
                self.swarm.gone = []
                core.finished(self.swarm.finals)
            if not self._act(core.tick(now, alive)):
                return

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
        for action in self.core.end_at(step):
            self._put(action)
