"""The recorder's step release (fluidswarm/recording/steps.py StepAssembly, no I/O: the time is an argument) fed
message sequences on a clock of our own: a fast agent far ahead of the others must not make their states late
stragglers; a silent (frozen) agent must not hold the file. Two tests drive its zenoh shell
(fluidswarm/recording/recorder.py Recorder) on the wall clock: the states still in flight at its end, a stop
signal during a write."""

from __future__ import annotations

import signal
import threading
import time

import numpy as np
import pytest

from agent.protocol import keys
from agent.protocol.stopping import stop_on_signals
from agent.protocol.wire import encode_state
from agent.sph.particle import NFIELDS
from fluidswarm.recording import steps
from fluidswarm.recording.reader import check, load_run
from fluidswarm.recording.recorder import Recorder, record
from fluidswarm.recording.writer import RunWriter

RUN = "r1"


class Clock:
    """The made-up time the tests hand the core with each input."""

    def __init__(self):
        self.t = 100.0


class Fed:
    """A StepAssembly and the clock its inputs are fed on; `pump` is what is due now, `finish` the end."""

    def __init__(self, core: steps.StepAssembly, clock: Clock):
        self.core, self.clock = core, clock

    def __getattr__(self, name):
        return getattr(self.core, name)

    def pump(self, _timeout: float = 0.0) -> None:
        self.core.tick(self.clock.t)

    def finish(self, **_waits) -> None:
        self.core.end(self.clock.t)


@pytest.fixture
def recorder(tmp_path):
    clock = Clock()
    writer = RunWriter(tmp_path / "r.mcap", {"run": RUN})
    rec = Fed(steps.StepAssembly(RUN, writer, dt=0.01, now=clock.t), clock)
    for j in range(3):
        rec.heard_alive(keys.alive_key(RUN, j), True, clock.t)
    rec.pump()
    yield rec, clock, tmp_path / "r.mcap"
    writer.close()


@pytest.fixture
def shell(tmp_path):
    """The zenoh shell on the wall clock (no session: its queue is fed as zenoh's callbacks would)."""
    writer = RunWriter(tmp_path / "r.mcap", {"run": RUN})
    rec = Recorder(RUN, writer, dt=0.01)
    for j in range(3):
        rec.inbox.put((1, (keys.alive_key(RUN, j), True)))
    rec.pump(0.0)
    yield rec, None, tmp_path / "r.mcap"
    writer.close()


def state_record(agent: int, step: int) -> bytes:
    state = np.zeros(NFIELDS)
    state[0], state[1], state[4] = agent, step * 0.01, 1.0  # x, y, rho (> 0: a real density)
    return encode_state(agent, step, state)


def post(rec, agent: int, step: int) -> None:
    if isinstance(rec, Recorder):  # the shell: onto its queue
        rec.inbox.put((0, (state_record(agent, step), keys.cell_key(RUN, 0, 0))))
    else:
        rec.heard_state(state_record(agent, step), keys.cell_key(RUN, 0, 0), rec.clock.t)


def recorded(path) -> dict[int, set[int]]:
    per_agent: dict[int, set[int]] = {}
    for f in load_run(path, images=False).frames:
        for j in f.ids.tolist():
            per_agent.setdefault(j, set()).add(f.step)
    return per_agent


def test_an_agent_far_ahead_does_not_drop_the_others_states(recorder):
    rec, clock, path = recorder
    for k in range(60):  # agent 2 has no neighbours (lockstep is local): it runs its 60 steps at once
        post(rec, 2, k)
    rec.pump(0.0)
    for k in range(60):  # the others, one step a second: 6 x RELEASE_SECONDS behind agent 2 at the end
        clock.t += 1.0
        post(rec, 0, k)
        post(rec, 1, k)
        rec.pump(0.0)
    rec.finish()
    rec.writer.close()
    got = recorded(path)
    assert all(got[j] == set(range(60)) for j in range(3)), {j: 60 - len(s) for j, s in got.items()}


def test_a_silent_agent_is_written_off_after_release_seconds(recorder):
    rec, clock, _path = recorder
    for k in range(40):
        clock.t += 0.5
        for j in (0, 1) if k > 5 else (0, 1, 2):  # agent 2 freezes after step 5
            post(rec, j, k)
        rec.pump(0.0)
    # 17 s of agent 2's silence: the steps it misses were written without it, not held back
    assert rec.next_step > 30 and 2 in rec.stopped
    assert rec.next_step <= 40


def test_the_last_states_still_in_flight_when_told_to_stop_are_written_and_scored(shell):
    rec, _clock, path = shell
    for k in range(10):
        for j in range(3):
            post(rec, j, k)
        rec.pump(0.0)

    def late() -> None:  # the run's last steps arrive after the stop (the recorder runs a step or two behind)
        time.sleep(0.1)
        for k in (10, 11):
            for j in range(3):
                post(rec, j, k)

    threading.Thread(target=late).start()
    rec.finish()
    rec.writer.close()
    assert recorded(path) == {j: set(range(12)) for j in range(3)}
    assert sorted(rec.last_positions[:, 1]) == pytest.approx([0.11] * 3)  # step 11's y, every agent


def test_a_last_step_missing_agents_is_not_the_scored_formation(recorder):
    rec, _clock, _path = recorder
    for k in range(10):
        for j in range(3) if k < 9 else (0,):  # step 9: only agent 0's state came before the end
            post(rec, j, k)
    rec.finish(quiet=0.05)
    assert rec.next_step == 10
    assert sorted(rec.last_positions[:, 0]) == [0.0, 1.0, 2.0]  # step 8, the last with every agent
    assert rec.last_positions[:, 1] == pytest.approx([0.08] * 3)


def test_a_frozen_agent_is_left_out_of_the_scored_formation_as_before(recorder):
    rec, clock, _path = recorder
    for k in range(30):
        clock.t += 0.5
        for j in (0, 1, 2) if k < 10 else (0, 1):  # agent 2 freezes for good at step 10
            post(rec, j, k)
        rec.pump(0.0)
    rec.finish(quiet=0.05)
    assert sorted(rec.last_positions[:, 0]) == [0.0, 1.0]  # step 29 without the frozen agent
    assert rec.last_positions[:, 1] == pytest.approx([0.29] * 2)


def test_a_stop_signal_landing_while_a_step_is_written_loses_nothing(shell):
    """The recorder process's SIGTERM (the launcher stops it at the run's end) arrives wherever its main thread
    is; here, inside the write of step 5. The step being written and the ones after it must all be in the file."""
    rec, _clock, path = shell
    saved = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}
    write_states = rec.writer.write_states

    def write_and_be_stopped(step, *rest):
        if step == 5:
            signal.raise_signal(signal.SIGTERM)  # its handler runs before the write below
        write_states(step, *rest)

    rec.writer.write_states = write_and_be_stopped
    try:
        stop = stop_on_signals()
        for k in range(10):
            for j in range(3):
                post(rec, j, k)
        record(rec, stop, poll=0.0)
        assert stop.is_set()
        rec.finish(quiet=0.01)
    finally:
        for s, h in saved.items():
            signal.signal(s, h)
    rec.writer.close()
    assert recorded(path) == {j: set(range(10)) for j in range(3)}


def report(agent: int, status: str) -> bytes:
    import json

    return json.dumps(
        {
            "v": 1,
            "id": agent,
            "status": status,
            "steps": 5,
            "state": [0.0] * 10,
            "msgs_received": 0,
            "neighbours": 0,
            "rejected": {},
            "timeouts": 0,
            "deaths_seen": 0,
            "stale": 0,
            "dropped_out": 0,
            "lost": 0,
            "t_start": None,
            "t_end": None,
            "session_opened_at": 1.79e9,
            "rss_mb": 1.0,
            "cpu_seconds": 0.1,
            "cpu_seconds_at_start": None,
        }
    ).encode()


def test_a_finished_agents_leaving_is_not_a_death_and_agent_events_say_whose_they_are(recorder):
    rec, clock, path = recorder
    for s in range(5):
        for j in range(3):
            post(rec, j, s)
    # the agent's own event carries its agent and step into the file's Log fields
    timeout = b'{"v":1,"id":2,"step":3,"event":"neighbour_timeout","neighbours":[1]}'
    rec.heard_event(timeout, keys.event_key(RUN, 2), clock.t)
    rec.heard_final(report(0, "done"), keys.final_key(RUN, 0), clock.t)
    rec.heard_final(report(1, "stopped"), keys.final_key(RUN, 1), clock.t)
    rec.heard_final(report(1, "done"), keys.final_key(RUN, 2), clock.t)  # under another agent's key: dropped
    rec.pump(0.0)
    for j in range(3):  # the tokens go; agent 2 sent no report of its own: it died
        rec.heard_alive(keys.alive_key(RUN, j), False, clock.t)
    rec.pump(0.0)
    clock.t += steps.REPORT_GRACE_SECONDS + 0.1
    rec.pump(0.0)
    rec.finish(quiet=0.0, limit=0.0)
    rec.writer.close()
    events = {(e.kind, e.agent, e.step) for e in load_run(path, images=False).events if e.kind != "started"}
    assert events == {("neighbour_timeout", 2, 3), ("finished", 0, 5), ("stopped", 1, 5), ("died", 2, 5)}
    assert rec.rejected == 1


def test_all_left_once_every_agent_left_with_its_report_and_its_last_step_is_written(recorder):
    # What lets the recorder end without waiting out the quiet: nothing is on its way any more.
    rec, clock, path = recorder
    for s in range(5):
        for j in range(3):
            post(rec, j, s)
    rec.pump(0.0)
    assert not rec.all_left()  # every agent still alive
    rec.heard_final(report(0, "done"), keys.final_key(RUN, 0), clock.t)
    rec.heard_final(report(1, "stopped"), keys.final_key(RUN, 1), clock.t)
    for j in range(3):
        rec.heard_alive(keys.alive_key(RUN, j), False, clock.t)
    rec.pump(0.0)
    assert not rec.all_left()  # their last states may still be in a router's batch
    clock.t += steps.BATCH_GRACE_SECONDS + 0.01
    rec.pump(0.0)
    assert not rec.all_left()  # agent 2 sent no report: its death waits for the report's grace
    rec.heard_final(report(2, "done"), keys.final_key(RUN, 2), clock.t)
    rec.pump(0.0)
    assert rec.all_left()
    rec.finish()
    rec.writer.close()
    events = {(e.kind, e.agent, e.step) for e in load_run(path, images=False).events if e.kind != "started"}
    assert events == {("finished", 0, 5), ("stopped", 1, 5), ("finished", 2, 5)}
    assert check(path)[0]


def test_an_agent_that_rejoined_skipping_steps_is_recorded_away_for_them(recorder):
    rec, _clock, path = recorder
    for k in range(10):
        for j in (0, 1, 2) if k < 4 or k >= 7 else (0, 1):  # agent 2 froze after step 3, rejoined at step 7
            post(rec, j, k)
    rec.pump(0.0)
    rec.finish(quiet=0.0, limit=0.0)
    rec.writer.close()
    run = load_run(path, images=False)
    assert [(e.kind, e.step) for e in run.events if e.agent == 2 and e.step > 0] == [("died", 4), ("started", 7)]
    assert check(path) == (True, 10, 0)
    assert recorded(path)[2] == {0, 1, 2, 3, 7, 8, 9}


def test_a_routers_batch_is_taken_record_by_record_and_a_bad_one_is_counted(recorder):
    """The relay's batches (docs/protocol.md "State batches"): whole records on an exact batch key; a record
    that does not decode is dropped alone, a batch off its key or cut inside a record entirely."""
    rec, clock, path = recorder
    batch_key = f"{keys.PREFIX}/{RUN}/batch/5a3f"

    def record(agent: int, step: int, rho: float = 1.0) -> bytes:
        state = np.zeros(NFIELDS)
        state[0], state[1], state[4] = agent, step * 0.01, rho
        return encode_state(agent, step, state)

    rec.heard_batch(b"".join(record(j, 0) for j in range(3)), batch_key, clock.t)
    rec.heard_batch(record(0, 1) + record(1, 1, rho=-1.0) + record(2, 1), batch_key, clock.t)  # agent 1's is bad
    rec.heard_batch(record(1, 1), f"{keys.PREFIX}/{RUN}/batch/*", clock.t)  # a wildcard: no router's key
    rec.heard_batch(record(1, 1), f"{keys.PREFIX}/other-run/batch/5a3f", clock.t)
    rec.heard_batch(record(1, 1)[:60], batch_key, clock.t)
    rec.pump(0.0)
    assert rec.rejected == 4
    for j in range(3):
        post(rec, j, 2)
    clock.t += steps.RELEASE_SECONDS + 1
    rec.pump(0.0)
    rec.finish(quiet=0.0)
    rec.writer.close()
    assert recorded(path) == {0: {0, 1, 2}, 1: {0, 2}, 2: {0, 1, 2}}


def test_agents_stopped_a_step_apart_leave_a_complete_file(recorder):
    """A run stopped mid-step (ctl/stop, the launcher's SIGINT) leaves its agents a step or two apart: the ones
    stopped before a step another made have not lost it (reader.completeness ends them at their `stopped`)."""
    rec, clock, path = recorder
    for s in range(25):
        for j in range(3):
            post(rec, j, s)
    post(rec, 2, 25)  # agent 2 was a step ahead when the stop came
    rec.pump(0.0)
    for j in range(3):
        rec.heard_final(report(j, "stopped"), keys.final_key(RUN, j), clock.t)
        rec.heard_alive(keys.alive_key(RUN, j), False, clock.t)
    rec.pump(0.0)
    rec.finish(quiet=0.0, limit=0.0)
    rec.writer.close()
    events = {(e.kind, e.agent, e.step) for e in load_run(path, images=False).events if e.kind != "started"}
    assert events == {("stopped", 0, 25), ("stopped", 1, 25), ("stopped", 2, 26)}
    assert check(path) == (True, 26, 0)
