"""Following a run's progress and pacing it: the launcher's view of the steps, and ctl/clock, end, gone.

A passive observer of every state message (like the recorder): the step each agent is at, when each step
was first seen, the newest state record of each agent (for watchers such as coordinator/control/settle.py).
From that, a thread publishes the pacing clock (the slowest live agent's step), relays lost agents on
ctl/gone and repeats ctl/end (docs/protocol.md), as agent/protocol/ctl.py records.

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
from dataclasses import dataclass

import numpy as np
import zenoh

from agent.protocol import keys
from agent.protocol.ctl import Clock, End, Gone, ctl_message
from agent.protocol.errors import SwarmTimeout
from agent.protocol.pace import Pace, decode_pace, pace_expr, pace_key
from agent.protocol.wire import batch_records, peek_id_step

# s between ctl/clock messages. Agents stay within CLOCK_LEAD (3) steps of the clock, so a 10 Hz clock capped
# every swarm at ~30 steps/s; the compiled agents run faster than that.
CLOCK_PERIOD = 0.02
CLOCK_REPEAT = 1.0
CLOCK_LEAD = 3  # steps an agent may run past the clock (agent/native/src/agent.rs CLOCK_LEAD)
GONE_GRACE = 0.25  # s a lost agent's report may come after its token's deletion (Pacer._clock)
AHEAD = 1000  # steps: a state further ahead of the newest step seen is not believed (untrusted input)
PACE_SILENCE = 5.0  # s: a host whose share clock is silent this long (it repeats every CLOCK_REPEAT) is lost


@dataclass(frozen=True)
class Share:
    """This host's part of a split run: `own` its agents' ids, `swarm` how many agents the whole run holds,
    `owner` this host puts ctl/clock (the others say their share clock), `follow_all` it still follows every
    state (the main host of an imitation: its settle watch reads every agent's newest state)."""

    def ids_of(self, first: int, agents: int) -> list[int] | None:
        """The ids of the host whose share clock says `first` and `agents`: from `others`, or, when the run has
        two hosts, the swarm's ids that are not this host's (a run's ids are 0..swarm-1); None if unknown."""
        for ids in self.others:
            if ids and min(ids) == first and len(ids) == agents:
                return sorted(ids)
        rest = sorted(set(range(self.swarm)) - set(self.own))
        return rest if len(rest) == agents and rest and rest[0] == first else None

    own: tuple[int, ...]
    swarm: int
    owner: bool
    follow_all: bool = False
    others: tuple[tuple[int, ...], ...] = ()  # the other hosts' ids, where this host knows them (a main host)


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
        self._states: list[zenoh.Subscriber] | None = None  # the state subscribers, then the share clocks'
        self._stop = threading.Event()
        self.share: Share | None = None  # a split run's pacing (split())
        self.hosts: dict[int, list] = {}  # owner: first id -> [agents, step, done, heard at, dropped]
        self.notes: list[str] = []  # hosts whose share clock stopped (owner), said once each
        # owner: each host dropped as silent ({first, agents, step, ids}), and who hears of it as it happens
        self.lost_hosts: list[dict] = []
        self.on_host_lost: Callable[[dict, str], None] | None = None
        self._first_own: float | None = None  # when an own agent's step was first seen
        self._uncovered_said = False
        self._own_seen = False  # non-owner: one of its agents' tokens was seen (so none left means done)
        self._owner_heard: float | None = None  # non-owner: when the owner's ctl/clock was last heard
        self._orphan_said = False

    def split(self, share: Share) -> None:
        """Pace as one host of a split run (before start). Without per-process rights the states are on the
        cell keys only, so nothing can be followed by id: every launcher then follows every state and puts
        ctl/clock, as in one host's run."""
        if self.id_keys and self._states is None and set(share.own) and len(share.own) < share.swarm:
            self.share = share

    def start(self) -> None:
        """Start following and pacing (idempotent)."""
        if self._states is not None:
            return
        # Queued in zenoh (a ring: a slow launcher loses old samples, never blocks the router it hosts) and
        # drained in batches by the clock thread: no Python callback, no GIL, per state message on the
        # router's receiving threads (N messages per step).
        sh = self.share
        if sh is None:
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
        sh = self.share
        if sh is not None and not sh.owner and self._states is not None:
            self._say_pace(None, done=True)  # the owner stops waiting for this host at once
        for sub in self._states or []:
            try:
                sub.undeclare()
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

    def _on_sample(self, sample) -> None:
        """A state on its sender's key, or a router's batch of states (split run's main host)."""
        data, key = sample.payload.to_bytes(), str(sample.key_expr)
        if keys.is_batch_key(self.run, key):  # only routers may put there (docs/security.md); each record checked
            for record in batch_records(data) or ():
                self._on_state(record, None)
            return
        self._on_state(data, key)

    def _on_state(self, data: bytes, key: str | None) -> None:
        """One state record, from `key` (its sender's, checked) or from a router's batch (`key` None)."""
        peek = peek_id_step(data)
        if peek is None:
            return
        agent_id, step = peek
        if key is not None and not keys.state_key_vouches(key, agent_id):
            return  # under another agent's key or a wildcard key: a forgery (docs/security.md)
        now = time.monotonic()
        last = self.agent_steps.get(agent_id)
        if (last is None or step > last[0]) and step <= self.max_step + AHEAD:
            self.agent_steps[agent_id] = (step, now)
            self.newest[agent_id] = data
        if step not in self.step_times and step <= self.max_step + AHEAD:
            self.step_times[step] = now
            self.max_step = max(self.max_step, step)

    def _say_pace(self, step: int | None, done: bool = False) -> bool:
        """Put this host's share clock (non-owner); False when the session is closing."""
        assert self.share is not None
        own = self.share.own
        try:
            self.session.put(
                pace_key(self.run, min(own)),
                Pace(min(own), len(own), 0 if step is None else step, done).encode(),
                congestion_control=zenoh.CongestionControl.BLOCK,
            )
        except Exception:  # noqa: BLE001  # the session is closing (zenoh raises several types then)
            return False
        return True

    def _on_pace(self, sample, now: float) -> None:
        pace = decode_pace(str(sample.key_expr), sample.payload.to_bytes())
        assert self.share is not None
        if pace is None or pace.first in self.share.own or pace.agents > self.share.swarm:
            return  # malformed, or claims this host's own share
        host = self.hosts.setdefault(pace.first, [pace.agents, pace.step, pace.done, now, False])
        host[:4] = [pace.agents, pace.step, pace.done or host[2], now]

    def _owner_clock(self, own: int | None, now: float) -> int | None:
        """The run's clock from this host's own clock and every other host's share clock: None while the hosts
        heard do not yet cover the swarm (for at most PACE_SILENCE s after the first own step), then the
        minimum over the hosts still pacing. A host silent for PACE_SILENCE s is dropped, named once."""
        sh = self.share
        assert sh is not None
        steps = [] if own is None else [own]
        covered = len(sh.own)
        for first, host in self.hosts.items():
            agents, step, done, heard, dropped = host
            covered += agents
            if done or dropped:
                continue
            if now - heard >= PACE_SILENCE:
                host[4] = True
                self._lose_host(first, agents, step)
                continue
            steps.append(step)
        if covered < sh.swarm and not sh.follow_all:
            if self._first_own is None or now - self._first_own < PACE_SILENCE:
                return None
            if not self._uncovered_said:
                self._uncovered_said = True
                self._note(
                    f"{sh.swarm - covered} of {sh.swarm} agents' hosts never said their share clock in "
                    f"{PACE_SILENCE:.0f} s: the run is paced without them"
                )
        return min(steps) if steps else None

    def _lose_host(self, first: int, agents: int, step: int) -> None:
        """A host whose share clock went silent: named once (stderr, `notes`, `lost_hosts`, `on_host_lost`)
        with the agents lost with it, where this host knows them."""
        assert self.share is not None
        ids = self.share.ids_of(first, agents)
        lost = {"first": first, "agents": agents, "step": step, "ids": ids}
        named = f"agents {_ranges(ids)}" if ids else f"{agents} agents from agent {first}"
        text = (
            f"the host of {named} was lost: its share clock stopped at step {step}, silent for "
            f"{PACE_SILENCE:.0f} s; the run is paced without it"
        )
        self.lost_hosts.append(lost)
        self._note(text)
        if self.on_host_lost is not None:
            try:
                self.on_host_lost(lost, text)
            except OSError:  # the note is also in `notes`; a full disk loses only the MCAP's copy
                pass

    def _note(self, text: str) -> None:
        self.notes.append(text)
        print(f"fluidswarm: {text}", file=sys.stderr, flush=True)

    def hosts_done(self) -> bool:
        """Owner: every other host heard is done or dropped, and together they cover the swarm (or gave up)."""
        sh = self.share
        if sh is None or not sh.owner:
            return True
        covered = len(sh.own) + sum(h[0] for h in self.hosts.values())
        return (covered >= sh.swarm or self._uncovered_said) and all(h[2] or h[4] for h in self.hosts.values())

    def wait_hosts(self, timeout: float) -> None:
        """Owner of a split run's clock: after its own agents finished, keep pacing until every other host's
        share is done (or dropped as silent), at most `timeout` s: the others' agents step on this clock."""
        deadline = time.monotonic() + timeout
        while not self.hosts_done() and time.monotonic() < deadline and not self._stop.is_set():
            time.sleep(0.05)

    def _owner_silent(self, now: float) -> bool:
        """Non-owner of a split run: the owner's ctl/clock has not been heard for PACE_SILENCE s since this host's
        agents stepped (its host or the link to it lost), so this host paces its own share as a one-host run
        would; said once. Without it a share cut off beyond Zenoh's lease stood still for good after the
        partition healed (its agents at their lead, the owner finished and gone)."""
        heard = self._owner_heard if self._owner_heard is not None else self._first_own
        if heard is None or now - heard < PACE_SILENCE:
            return False
        if not self._orphan_said:
            self._orphan_said = True
            self._note(
                f"the run's clock was silent for {PACE_SILENCE:.0f} s (the host that owns it, or the link to it, "
                "lost): this host paces its own share"
            )
        return True

    def _clock(
        self, states: list[zenoh.Subscriber], paces: list[zenoh.Subscriber], clocks: list[zenoh.Subscriber]
    ) -> None:
        """Publish the slowest live agent's step on ctl/clock every `clock_period` s when it moved.

        Agents that are not connected to anyone (an isolated particle) would otherwise race ahead of the
        swarm and meet it again at a different step; with the clock they stay within CLOCK_LEAD steps.
        Agents silent for longer than the neighbour timeout (frozen) or gone do not hold the clock back.
        """
        last = said = paced = None
        said_at, paced_at, paced_done = 0.0, 0.0, False
        sh = self.share
        own = set(sh.own) if sh is not None else set()
        # 50 Hz, and only when it moves: with a lead of CLOCK_LEAD steps, a 10 Hz clock capped every swarm at
        # ~30 steps/s (the compiled agents run faster than that).
        while not self._stop.wait(self.clock_period):
            now = time.monotonic()
            try:
                for sub in states:
                    while (sample := sub.try_recv()) is not None:
                        self._on_sample(sample)
                for sub in paces:
                    while (sample := sub.try_recv()) is not None:
                        self._on_pace(sample, now)
                for sub in clocks:
                    while sub.try_recv() is not None:
                        self._owner_heard = now
            except Exception:  # noqa: BLE001  # the session is closing (zenoh raises several types then)
                return
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
            # a non-owner's share clock bounds the run's clock from above (a rejoining agent counts again at it)
            clock = said if said is not None else paced
            steps = self._clocked_steps(alive if sh is None or sh.follow_all else alive & own, now, clock)
            if steps:
                last = min(steps)
                if self._first_own is None:
                    self._first_own = now
            if sh is not None and not sh.owner:  # a host of a split run: its share's clock to the owner
                self._own_seen = self._own_seen or bool(alive & own)
                done = self._own_seen and not alive & own
                if last is not None and (last != paced or done != paced_done or now - paced_at >= CLOCK_REPEAT):
                    paced, paced_at, paced_done = last, now, done
                    if not self._say_pace(last, done):
                        return
                if done or not self._owner_silent(now):
                    continue
            elif sh is not None:  # the owner: the minimum over every host's share clock
                last = self._owner_clock(last if steps or sh.follow_all else None, now)
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
        timeout). So an agent that went silent counts again only once it has reached the clock's step.

        When none counts (every one silent: a split run's owner whose clock a lost host held for PACE_SILENCE,
        or a host pacing itself after its owner went silent, has all its agents waiting at the clock's lead),
        the slowest alive agent's step paces: without it no clock came, nobody could step, and the run stood
        still for good (CI: 20 agents still running after 255 s). Frozen agents stand still either way."""
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
        if not steps:
            waiting = [s for j, (s, _t) in self.agent_steps.items() if j in alive]
            return [min(waiting)] if waiting else []
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


def _ranges(ids: list[int]) -> str:
    """`ids` as compact ranges: [3, 4, 5, 9] -> '3-5, 9'."""
    out: list[str] = []
    for i in sorted(ids):
        if out and out[-1].rsplit("-", 1)[-1] == str(i - 1):
            out[-1] = f"{out[-1].split('-')[0]}-{i}"
        else:
            out.append(str(i))
    return ", ".join(out)
