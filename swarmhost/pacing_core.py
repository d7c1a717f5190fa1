"""The launcher's half of the swarm protocol without I/O: states, share clocks and losses in, what to say out.

Like the agent's core (agent/native/src/agent.rs: Input, Action, Wake), `PaceCore` opens no session, starts no
thread and reads no clock: every input carries its time (`now`, s on one monotonic clock), and `tick` answers
with the actions to take (`Say` a ctl message, `SayPace` a share clock, `Note` a line for stderr, `HostLost`).
The zenoh shell (swarmhost/pacing.py `Pacer`) feeds it what its subscribers received and calls `tick` every
CLOCK_PERIOD s; tests feed it message sequences with made-up times (tests/test_pacing_core.py).

What it decides (docs/protocol.md): the pacing clock (the slowest live agent's step, said on ctl/clock when it
moves and again every CLOCK_REPEAT s), the relay of lost agents on ctl/gone (after GONE_GRACE, unless their
final report came), ctl/end said again with each clock, and in a split run (`Share`) the share clocks: a
non-owner says its own, the owner puts the minimum over every host's and drops a host silent for PACE_SILENCE s.
"""

from __future__ import annotations

from collections.abc import Container
from dataclasses import dataclass

from agent.protocol import keys
from agent.protocol.ctl import Clock, End, Gone
from agent.protocol.pace import Pace, decode_pace
from agent.protocol.wire import batch_records, peek_id_step

# s between ctl/clock messages. Agents stay within CLOCK_LEAD (3) steps of the clock, so a 10 Hz clock capped
# every swarm at ~30 steps/s; the compiled agents run faster than that.
CLOCK_PERIOD = 0.02
CLOCK_REPEAT = 1.0
CLOCK_LEAD = 3  # steps an agent may run past the clock (agent/native/src/agent.rs CLOCK_LEAD)
GONE_GRACE = 0.25  # s a lost agent's report may come after its token's deletion (PaceCore._due_gone)
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


@dataclass(frozen=True)
class Say:
    """Put this ctl message on the run's ctl key (congestion control Block: a dropped tick can hold a swarm)."""

    message: Clock | Gone | End


@dataclass(frozen=True)
class SayPace:
    """Put this host's share clock on its pace key (a non-owner of a split run)."""

    pace: Pace


@dataclass(frozen=True)
class Note:
    """A line for the user (stderr); also kept in `PaceCore.notes`."""

    text: str


@dataclass(frozen=True)
class HostLost:
    """A host of a split run was dropped as silent (`lost`: first, agents, step, ids); `text` names it."""

    lost: dict
    text: str


Action = Say | SayPace | Note | HostLost


class PaceCore:
    """The pacing state of one launcher. `agent_timeout` [s]: an agent silent this long (frozen) does not hold
    the clock back. Read by the shell's owner between ticks: `step_times`, `max_step`, `agent_steps`, `newest`,
    `notes`, `lost_hosts`."""

    def __init__(self, run: str, agent_timeout: float, share: Share | None = None):
        self.run, self.agent_timeout, self.share = run, agent_timeout, share
        self.step_times: dict[int, float] = {}  # step -> time its first state was seen
        self.max_step = -1
        self.agent_steps: dict[int, tuple[int, float]] = {}  # id -> (its newest step, when it was seen)
        self.held_out: set[int] = set()  # went silent (frozen); back on the clock once at the clock's step
        self.newest: dict[int, bytes] = {}  # id -> its newest state record, undecoded (watchers decode it)
        self.end_step: int | None = None
        self.started_at: float | None = None  # when the agents were told to start (mark_start)
        self.dt: float | None = None  # simulated seconds per step (mark_start)
        self.realtime = False  # pace_realtime: simulated time held to the wall clock
        self.hosts: dict[int, list] = {}  # owner: first id -> [agents, step, done, heard at, dropped]
        self.notes: list[str] = []  # hosts whose share clock stopped (owner), said once each
        # owner: each host dropped as silent ({first, agents, step, ids})
        self.lost_hosts: list[dict] = []
        self._lost: list[tuple[int, float]] = []  # agents whose token went, and when: relayed after GONE_GRACE
        self._first_own: float | None = None  # when an own agent's step was first seen
        self._uncovered_said = False
        self._own_seen = False  # non-owner: one of its agents' tokens was seen (so none left means done)
        self._owner_heard: float | None = None  # non-owner: when the owner's ctl/clock was last heard
        self._orphan_said = False
        self._last: int | None = None  # the clock as this tick left it (stands while no agent counts)
        self._said: int | None = None  # the clock last said, and when
        self._said_at = 0.0
        self._paced: int | None = None  # non-owner: the share clock last said, and when, and whether done
        self._paced_at = 0.0
        self._paced_done = False

    # --- inputs -------------------------------------------------------------------------------------------

    def sample(self, key: str, data: bytes, now: float) -> None:
        """A state on its sender's key, or a router's batch of states (split run's main host)."""
        if keys.is_batch_key(self.run, key):  # only routers may put there (docs/security.md); each record checked
            for record in batch_records(data) or ():
                self.state(record, None, now)
            return
        self.state(data, key, now)

    def state(self, data: bytes, key: str | None, now: float) -> None:
        """One state record, from `key` (its sender's, checked) or from a router's batch (`key` None)."""
        peek = peek_id_step(data)
        if peek is None:
            return
        agent_id, step = peek
        if key is not None and not keys.state_key_vouches(key, agent_id):
            return  # under another agent's key or a wildcard key: a forgery (docs/security.md)
        last = self.agent_steps.get(agent_id)
        if (last is None or step > last[0]) and step <= self.max_step + AHEAD:
            self.agent_steps[agent_id] = (step, now)
            self.newest[agent_id] = data
        if step not in self.step_times and step <= self.max_step + AHEAD:
            self.step_times[step] = now
            self.max_step = max(self.max_step, step)

    def pace(self, key: str, data: bytes, now: float) -> None:
        """Owner of a split run: another host's share clock."""
        pace = decode_pace(key, data)
        assert self.share is not None
        if pace is None or pace.first in self.share.own or pace.agents > self.share.swarm:
            return  # malformed, or claims this host's own share
        host = self.hosts.setdefault(pace.first, [pace.agents, pace.step, pace.done, now, False])
        host[:4] = [pace.agents, pace.step, pace.done or host[2], now]

    def owner_heard(self, now: float) -> None:
        """Non-owner of a split run: the owner's ctl/clock was heard."""
        self._owner_heard = now

    def lose(self, agent: int, at: float) -> None:
        """Agent `agent`'s token went at `at`: relayed on ctl/gone GONE_GRACE s later unless it `finished`."""
        self._lost.append((agent, at))

    def finished(self, reports: Container[int]) -> None:
        """The agents with a final report in `reports`: a lost one among them finished, it is never relayed.
        An agent that finished has its token's deletion delivered before its report (declarations travel
        first); told at once, a neighbour still waiting for its last state would stop waiting for it."""
        self._lost = [(j, t) for j, t in self._lost if j not in reports]

    def mark_start(self, dt: float, now: float) -> None:
        """The agents were just told to start; a step lasts `dt` simulated seconds (realtime_factor)."""
        self.started_at, self.dt = now, float(dt)

    def pace_realtime(self) -> list[Say]:
        """From now on (after mark_start) simulated time never runs ahead of the wall clock: the clock is
        held CLOCK_LEAD + 1 steps below the step the wall clock has reached, so no agent passes it."""
        self.realtime = True
        return [Say(Clock(0))]

    def end_at(self, step: int) -> list[Say]:
        """Every agent finishes at `step` (or its own last step if that comes first): ctl/end, said again
        with the clock so that no agent misses it."""
        self.end_step = int(step)
        return [Say(End(self.end_step))]

    def farewell(self) -> list[Action]:
        """A non-owner of a split run stopping: its share is done (the owner stops waiting for it at once)."""
        sh = self.share
        if sh is None or sh.owner:
            return []
        return [SayPace(Pace(min(sh.own), len(sh.own), 0, True))]

    # --- the clock ----------------------------------------------------------------------------------------

    def tick(self, now: float, alive: set[int]) -> list[Action]:
        """The actions of one period: lost agents relayed, this host's share clock, the run's clock.

        Agents that are not connected to anyone (an isolated particle) would otherwise race ahead of the
        swarm and meet it again at a different step; with the clock they stay within CLOCK_LEAD steps.
        Agents silent for longer than the neighbour timeout (frozen) or gone do not hold the clock back.
        `alive`: the agents whose token is there."""
        # Agents learn of a lost neighbour from this relay, not from a liveliness subscriber each on every
        # other agent's token: that was N² declarations at start-up (70 s at N = 1000, native.md).
        actions: list[Action] = [Say(Gone(j)) for j in self._due_gone(now)]
        sh = self.share
        own = set(sh.own) if sh is not None else set()
        # a non-owner's share clock bounds the run's clock from above (a rejoining agent counts again at it)
        clock = self._said if self._said is not None else self._paced
        steps = self._clocked_steps(alive if sh is None or sh.follow_all else alive & own, now, clock)
        if steps:
            self._last = min(steps)
            if self._first_own is None:
                self._first_own = now
        # else the clock of the last tick stands (the owner's minimum, the wall clock's cap included)
        if sh is not None and not sh.owner:  # a host of a split run: its share's clock to the owner
            self._own_seen = self._own_seen or bool(alive & own)
            done = self._own_seen and not alive & own
            last = self._last
            if last is not None and (
                last != self._paced or done != self._paced_done or now - self._paced_at >= CLOCK_REPEAT
            ):
                self._paced, self._paced_at, self._paced_done = last, now, done
                actions.append(SayPace(Pace(min(sh.own), len(sh.own), last, done)))
            if done or not self._owner_silent(now, actions):
                return actions
        elif sh is not None:  # the owner: the minimum over every host's share clock
            self._last = self._owner_clock(self._last if steps or sh.follow_all else None, now, actions)
        if self.realtime:
            wall = self._wall_step(now)
            self._last = wall if self._last is None else min(self._last, wall)
        last = self._last
        # Said again every CLOCK_REPEAT s, and with congestion control Block: a clock tick dropped by a
        # congested link held 555 of 1000 agents at their lead for good (nobody moved, so no new tick).
        if last is not None and (last != self._said or now - self._said_at >= CLOCK_REPEAT):
            self._said, self._said_at = last, now
            actions.append(Say(Clock(last)))
            if self.end_step is not None:
                actions.append(Say(End(self.end_step)))
        return actions

    def _due_gone(self, now: float) -> list[int]:
        due = [j for j, t in self._lost if now - t >= GONE_GRACE]
        self._lost = [(j, t) for j, t in self._lost if now - t < GONE_GRACE]
        return due

    def _wall_step(self, now: float) -> int:
        assert self.started_at is not None and self.dt is not None  # paced only after mark_start
        return max(0, int((now - self.started_at) / self.dt) - CLOCK_LEAD - 1)

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

    # --- a split run's hosts ------------------------------------------------------------------------------

    def _owner_clock(self, own: int | None, now: float, actions: list[Action]) -> int | None:
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
                actions += self.lose_host(first, agents, step)
                continue
            steps.append(step)
        if covered < sh.swarm and not sh.follow_all:
            if self._first_own is None or now - self._first_own < PACE_SILENCE:
                return None
            if not self._uncovered_said:
                self._uncovered_said = True
                actions.append(
                    self._note(
                        f"{sh.swarm - covered} of {sh.swarm} agents' hosts never said their share clock in "
                        f"{PACE_SILENCE:.0f} s: the run is paced without them"
                    )
                )
        return min(steps) if steps else None

    def lose_host(self, first: int, agents: int, step: int) -> list[Action]:
        """A host whose share clock went silent: named once (`notes`, `lost_hosts`, a Note and a HostLost) with
        the agents lost with it, where this host knows them."""
        assert self.share is not None
        ids = self.share.ids_of(first, agents)
        lost = {"first": first, "agents": agents, "step": step, "ids": ids}
        named = f"agents {_ranges(ids)}" if ids else f"{agents} agents from agent {first}"
        text = (
            f"the host of {named} was lost: its share clock stopped at step {step}, silent for "
            f"{PACE_SILENCE:.0f} s; the run is paced without it"
        )
        self.lost_hosts.append(lost)
        return [self._note(text), HostLost(lost, text)]

    def _note(self, text: str) -> Note:
        self.notes.append(text)
        return Note(text)

    def hosts_done(self) -> bool:
        """Owner: every other host heard is done or dropped, and together they cover the swarm (or gave up)."""
        sh = self.share
        if sh is None or not sh.owner:
            return True
        covered = len(sh.own) + sum(h[0] for h in self.hosts.values())
        return (covered >= sh.swarm or self._uncovered_said) and all(h[2] or h[4] for h in self.hosts.values())

    def _owner_silent(self, now: float, actions: list[Action]) -> bool:
        """Non-owner of a split run: the owner's ctl/clock has not been heard for PACE_SILENCE s since this host's
        agents stepped (its host or the link to it lost), so this host paces its own share as a one-host run
        would; said once. Without it a share cut off beyond Zenoh's lease stood still for good after the
        partition healed (its agents at their lead, the owner finished and gone)."""
        heard = self._owner_heard if self._owner_heard is not None else self._first_own
        if heard is None or now - heard < PACE_SILENCE:
            return False
        if not self._orphan_said:
            self._orphan_said = True
            actions.append(
                self._note(
                    f"the run's clock was silent for {PACE_SILENCE:.0f} s (the host that owns it, or the link to "
                    "it, lost): this host paces its own share"
                )
            )
        return True

    # --- what the run reads -------------------------------------------------------------------------------

    def realtime_factor(self) -> float | None:
        """Simulated seconds / wall seconds of the swarm's run: the newest step over the time from the
        start to its first sighting (1.0: as fast as the wall clock; None before mark_start or a step)."""
        if self.started_at is None or self.dt is None or self.max_step < 1:
            return None
        wall = self.step_times[self.max_step] - self.started_at
        return self.max_step * self.dt / wall if wall > 0 else None


def _ranges(ids: list[int]) -> str:
    """`ids` as compact ranges: [3, 4, 5, 9] -> '3-5, 9'."""
    out: list[str] = []
    for i in sorted(ids):
        if out and out[-1].rsplit("-", 1)[-1] == str(i - 1):
            out[-1] = f"{out[-1].split('-')[0]}-{i}"
        else:
            out.append(str(i))
    return ", ".join(out)
