"""What the recorder does with what it hears: states grouped by step and written as one message once every
agent alive at that step has reported (or the run is far enough past it: the missing agents get a `froze`
event and count as stopped; a later state of theirs gives a `started` event), liveliness turned into
`started`/`died` events (a killed agent's last state is written before its `died` event; an agent whose final
report says it reached its last step, or was told to stop, `finished`/`stopped` instead: its token's removal is
its leaving, not a death), the agents' own events (with their agent and step) and the gesture command passed
through.

`StepAssembly` is that logic without I/O of its own: no session, no queue, no clock. Each input carries the time
(`now`, s on one monotonic clock) and what it decides goes to its `writer` (a RunWriter: states, events, command,
bodies). Its shell is the recorder process's `Recorder` (fluidswarm/recording/recorder.py): zenoh callbacks
enqueue, its main thread drains the queue into the core with the time; tests feed the core message sequences with
made-up times (tests/test_recorder_steps.py)."""

from __future__ import annotations

import json

import numpy as np

from agent.protocol import keys
from agent.protocol.events import EventKind, decode_event
from agent.protocol.report import Status, decode_report
from agent.protocol.wire import batch_records, decode_state
from agent.sph.particle import HEADING, RHO, VX, VY, P, X, Y
from agent.sph.robot import RobotKind, body_centres
from fluidswarm.recording.writer import RunWriter

# A step is written once every agent it waits for has been silent this long (frozen, cut off, never reported).
# Silent, not slow: lockstep is local, so an agent without neighbours (a late joiner placed apart) can run
# hundreds of steps ahead of the rest; timing a step from its first state dropped the whole swarm's states
# as late stragglers once the fast one was 10 s ahead (hand_failures_freeze_drop, 2026-11-26).
RELEASE_SECONDS = 10.0
# Simulated s between two drawings of the robots' bodies in the scene (10 a simulated second): every step's
# would be N discs and arrows of JSON per step, more than the states themselves; Foxglove keeps the last.
BODY_SECONDS = 0.1
QUIET_SECONDS = 3.0  # ... or once nothing new came from anyone for this long
# At the end: the last messages still on their way are taken until none came for this long (at most the limit)
FINISH_QUIET_SECONDS = 0.3
FINISH_LIMIT_SECONDS = 5.0
END_STEPS = 3  # the last steps of a run may lack states cut off by its end (Recorder.last_positions)
# s an agent's final report may come after its token's removal (declarations travel before data): how long its
# leaving waits for the report before it is written as a death
REPORT_GRACE_SECONDS = 1.0
# s an agent's last states may come after its token's removal: a router's relay sends its batches of states every
# 10 ms (agent/native/src/relay.rs BATCH_WAIT); its token goes straight to the recorder
BATCH_GRACE_SECONDS = 0.1
LEFT = {Status.DONE: ("finished", "finished"), Status.STOPPED: ("stopped", "was stopped")}  # kind, wording


class StepAssembly:
    """The recorder's step assembly of one run (module docstring); `dt` [s] a step's simulated time."""

    def __init__(self, run: str, writer: RunWriter, dt: float, contacts=None, now: float = 0.0):
        """`contacts`: a fluidswarm.recording.contacts.ContactCounter fed every step written (robots), or None;
        `now`: the time the recording starts (s, the clock of every later input)."""
        self.run = run
        self.contacts = contacts
        self.writer = writer
        self.dt = dt
        self.body_every = max(1, round(BODY_SECONDS / dt)) if dt > 0 else 1  # steps between body drawings
        self.pending: dict[int, dict[int, tuple]] = {}
        self.alive: set[int] = set()
        self.stopped: set[int] = set()  # alive but not reporting (frozen): waiting for them is pointless
        # Late joiners: alive after the run began; they start at the step of their first state (they adopt
        # the swarm's step when they hear it), so the recorder expects them only from then on.
        self.joining: set[int] = set()
        self.last_step: dict[int, int] = {}
        self.heard_at: dict[int, float] = {}  # agent -> when its last state came (monotonic s)
        # (step, positions) of the last step written, and of the last one with every agent expected at it
        self.last_written: tuple[int, np.ndarray] | None = None
        self.last_complete: tuple[int, np.ndarray] | None = None
        self.first_seen: dict[int, float] = {}
        self.span: tuple[int, float, int, float] | None = None  # first and newest step seen, when (monotonic s)
        self.dead_at: dict[int, int] = {}  # agent -> first step without its state (event not yet written)
        self.gone_at: dict[int, float] = {}  # agent -> when its token went (monotonic s), until its event is written
        self.leaving: dict[int, float] = {}  # agent -> when its token went, until BATCH_GRACE_SECONDS later
        self.reported: dict[int, Status] = {}  # agent -> how its final report says it ended
        self.skipping: dict[int, int] = {}  # agent -> the step it comes back at, after steps it skipped (rejoined)
        self.next_step = 0
        self.newest = -1
        self.rejected = 0
        self.last_message = now  # when the last input came

    def t(self, step: int) -> float:
        return max(step, 0) * self.dt

    def _agent_event(self, j: int, step: int, kind: str, words: str, at: int | None = None) -> None:
        """Agent j's lifecycle event `kind` at `step` (timed at step `at`, `step` when not given): "agent J WORDS",
        a warning when it died, else info."""
        level = "warning" if kind == "died" else "info"
        t = self.t(step if at is None else at)
        self.writer.write_event(t, level, f"agent/{j}", f"agent {j} {words}", kind=kind, agent=j, step=step)

    def realtime_factor(self) -> float | None:
        """Simulated seconds / wall seconds from the first step seen to the newest (as the launcher's pacer
        measures it, from its own sightings): 1.0 keeps pace with the wall clock; None before two steps."""
        if self.span is None or self.span[2] <= self.span[0] or self.span[3] <= self.span[1]:
            return None
        first, t0, last, t1 = self.span
        return (last - first) * self.dt / (t1 - t0)

    # --- inputs: each one the bytes (or token change) and key heard, and when ---------------------------------

    def heard_state(self, data: bytes, key: str, now: float) -> None:
        """A state record on `key`."""
        self.last_message = now
        decoded, _reason = decode_state(data)
        # The key's id is the publisher's (the router's access control, docs/security.md); a record
        # naming another agent is a forgery.
        if decoded is None or not keys.state_key_vouches(key, decoded[0]):
            self.rejected += 1
            return
        self._state(*decoded)

    def heard_batch(self, data: bytes, key: str, now: float) -> None:
        """A router's relay's batch (docs/protocol.md "State batches"): whole state records, each taken from its
        sender's own key and checked against it by the relay; on an exact batch key, which only routers may
        put. Each record is still decoded (untrusted bytes, whoever vouched)."""
        self.last_message = now
        records = batch_records(data) if keys.is_batch_key(self.run, key) else None
        if records is None:
            self.rejected += 1
            return
        for record in records:
            decoded, _reason = decode_state(record)
            if decoded is None:
                self.rejected += 1
            else:
                self._state(*decoded)

    def heard_alive(self, key: str, up: bool, now: float) -> None:
        """An agent's alive token on `key` appeared (`up`) or went."""
        self.last_message = now
        j = keys.id_from_key(key)
        if j is None:
            return
        if up:
            if j not in self.alive and self.newest >= 0 and j not in self.last_step:
                self.joining.add(j)
            elif j not in self.alive:
                self.alive.add(j)
                self._agent_event(j, self.next_step if self.newest >= 0 else 0, "started", "started", self.next_step)
        elif j in self.joining:
            self.joining.discard(j)
        elif j in self.alive:
            # Its last states may still be in a router's batch (up to BATCH_GRACE_SECONDS behind its token):
            # it stays expected until then, and its death is placed after the last state heard by then.
            self.leaving.setdefault(j, now)

    def heard_event(self, data: bytes, key: str, now: float) -> None:
        """An agent's own event on its event key."""
        self.last_message = now
        ev = decode_event(data)
        if ev is None or ev.id != keys.id_from_key(key):
            self.rejected += 1  # malformed, or under another agent's key
            return
        if ev.kind is not EventKind.STARTED:  # lifecycle 'started' comes from liveliness, with its step
            level = "warning" if ev.kind in (EventKind.NEIGHBOUR_TIMEOUT, EventKind.FELL_BEHIND) else "info"
            text = json.dumps(ev.as_json(), sort_keys=True)[:2000]
            self.writer.write_event(
                self.t(ev.step), level, f"agent/{ev.id}", text, kind=ev.kind.value, agent=ev.id, step=ev.step
            )

    def heard_command(self, data: bytes, now: float) -> None:
        """The gesture command (on its exact key), passed through as its JSON text."""
        self.last_message = now
        try:
            text = data.decode("utf-8")
            json.loads(text)
        except (UnicodeDecodeError, ValueError):
            self.rejected += 1
            return
        self.writer.write_command(self.t(self.next_step), text)

    def heard_final(self, data: bytes, key: str, now: float) -> None:
        """An agent's final report: how it ended (finished or stopped is a leaving, not a death)."""
        self.last_message = now
        report = decode_report(data)
        if report is None or report.id != keys.id_from_key(key):
            self.rejected += 1  # malformed, or under another agent's key
            return
        self.reported[report.id] = report.status

    def _state(self, j: int, step: int, cls: int, values) -> None:
        """One decoded state record, vouched for: kept for its step's message."""
        if step < self.next_step or step > self.newest + 100000:
            return  # already written (a late straggler) or absurd
        if j in self.joining:
            self.joining.discard(j)
            self.alive.add(j)
            self._agent_event(j, step, "started", f"joined at step {step}")
        if step not in self.pending:
            self.first_seen[step] = seen = self.last_message  # when this state came
            if self.span is None:
                self.span = (step, seen, step, seen)
            elif step > self.span[2]:
                self.span = (*self.span[:2], step, seen)
        self.pending.setdefault(step, {})[j] = (cls, values)
        self.newest = max(self.newest, step)
        self.last_step[j] = max(self.last_step.get(j, -1), step)
        self.heard_at[j] = self.last_message
        if j in self.stopped:
            self.stopped.discard(j)
            self._agent_event(j, step, "started", "reports again")

    def _take_leavers(self, now: float, force: bool = False) -> None:
        """The agents whose token went BATCH_GRACE_SECONDS ago (all of them with `force`) leave the swarm."""
        for j, since in list(self.leaving.items()):
            if not force and now - since < BATCH_GRACE_SECONDS:
                continue
            del self.leaving[j]
            self.alive.discard(j)
            self.stopped.discard(j)
            # Its last state must be written before its death: the event waits for that step.
            self.dead_at[j] = self.last_step.get(j, self.next_step - 1) + 1
            self.gone_at[j] = since
        self._write_deaths(now)

    def _write_deaths(self, now: float, force: bool = False) -> None:
        for j, first_missing in list(self.dead_at.items()):
            if first_missing > self.next_step:
                continue
            left = LEFT.get(self.reported[j]) if j in self.reported else None
            if left is None and not force and now - self.gone_at.get(j, now) < REPORT_GRACE_SECONDS:
                continue  # its report may still be on the way
            del self.dead_at[j]
            self.gone_at.pop(j, None)
            if left is not None:
                kind, words = left
                self._agent_event(j, first_missing, kind, words)
            else:
                self._agent_event(j, first_missing, "died", "died")

    def _expected_at(self, step: int) -> set[int]:
        dying = {j for j, s in self.dead_at.items() if step < s}
        return (self.alive | dying) - self.stopped

    def _ready(self, step: int, now: float) -> bool:
        have = self.pending.get(step, {})
        waiting = self._expected_at(step) - set(have)
        since = self.first_seen.get(step, now)  # an agent never heard of is timed from the step's first state
        return (
            all(now - self.heard_at.get(j, since) >= RELEASE_SECONDS for j in waiting)
            or now - self.last_message > QUIET_SECONDS
        )

    def _write_step(self, step: int) -> None:
        have = self.pending.pop(step, {})
        self.first_seen.pop(step, None)
        missing = self._expected_at(step) - set(have)
        for j in missing:
            if self.last_step.get(j, -1) < step:  # it stopped reporting: frozen or cut off
                self.stopped.add(j)
                self._agent_event(j, step, "died", "stopped reporting (frozen?)")
            elif j not in self.skipping:
                # It reported later steps but not this one: it froze and rejoined at the swarm's step
                # (docs/protocol.md), skipping the steps between; it is away from here to its next state.
                back = min((k for k, states in self.pending.items() if k > step and j in states), default=None)
                if back is None:
                    continue
                self.skipping[j] = back
                self._agent_event(j, step, "died", f"skipped steps {step}..{back - 1} (frozen, rejoined)")
                self._agent_event(j, back, "started", f"reports again at step {back}")
        for j in [j for j, back in self.skipping.items() if back <= step]:
            del self.skipping[j]
        if not have:
            return
        ids = np.array(sorted(have), dtype=np.int64)
        vals = np.array([have[j][1] for j in ids])
        cls = np.array([have[j][0] for j in ids], dtype=np.int64)
        self.writer.write_states(
            step, self.t(step), ids, vals[:, [X, Y]], vals[:, [VX, VY]], vals[:, RHO], vals[:, P], cls
        )
        if self.writer.tap is not None:  # --ros2 (fluidswarm/recording/ros2_bridge.py): the whole rows, headings too
            self.writer.tap.states(step, self.t(step), ids, vals)
        if self.contacts is not None:
            self.contacts.update(ids, vals)
            robot = self.contacts.robot
            if not robot.is_point and step % self.body_every == 0:
                heads = vals[:, HEADING] if robot.kind == RobotKind.UNICYCLE else None
                self.writer.write_bodies(self.t(step), body_centres(vals, robot), heads, robot.radius)
        self.last_written = (step, vals[:, [X, Y]])
        if not missing:
            self.last_complete = self.last_written

    @property
    def last_positions(self) -> np.ndarray | None:
        """The final formation, scored at the end: the last step written, unless it lacks agents and a step
        with all of them came at most END_STEPS before it — states the run's end cut off, not agents that froze
        or died (a formation of 105 of 300 agents scored IoU 0.45 where the whole one scored 0.79)."""
        if self.last_written is None:
            return None
        if self.last_complete is not None and self.last_complete[0] >= self.last_written[0] - END_STEPS:
            return self.last_complete[1]
        return self.last_written[1]

    def _flush(self, now: float, force: bool = False) -> None:
        while self.next_step <= self.newest:
            if not force and not self._ready(self.next_step, now):
                return
            self._write_step(self.next_step)
            self.next_step += 1
            self._write_deaths(now)

    def all_left(self) -> bool:
        """Nothing the recording waits for is on its way: at least one agent reported its end, every agent heard
        of has left (its finished, stopped or died event written) and every step heard is written. An agent still
        alive, one whose leaving is not yet said or a step still open keeps it false (the end then waits for
        quiet)."""
        return (
            bool(self.reported)
            and not self.alive
            and not self.joining
            and not self.leaving
            and not self.dead_at
            and self.next_step > self.newest
        )

    # --- time ----------------------------------------------------------------------------------------------

    def tick(self, now: float) -> None:
        """What is due at `now`: agents whose token went leave, steps ready (or long waited for) are written."""
        self._take_leavers(now)
        self._flush(now)

    def end(self, now: float) -> None:
        """The recording ends: every agent that left leaves, every step heard is written, every death said."""
        self._take_leavers(now, force=True)
        self._flush(now, force=True)
        self.next_step = max(self.next_step, max(self.dead_at.values(), default=0))
        self._write_deaths(now, force=True)
