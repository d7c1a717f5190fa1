"""What crosses between an imitation's launcher and its coordinator (coordinator/handover.py): the plan and the
notes on the bus, checked on receipt; a coordinator that dies, stalls or is forged is a one-line
CoordinatorFailed or is not heard, never a hang. Real zenoh sessions, real processes."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import zenoh

from agent.protocol import keys
from agent.protocol.imitation import Missing, Plan, Seen, encode_note, encode_plan, note_key, plan_key
from coordinator import handover
from coordinator.control.imitation_setup import imitation_of_input
from fluidswarm.orchestration.imitate import PerceptionFailed, perceive

REPO = Path(__file__).resolve().parents[1]
PHOTO = REPO / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"
WAVE2 = REPO / "scenarios" / "inputs" / "weizmann_wave2_person0.png"
SECRET = bytes(range(32))
pytestmark = pytest.mark.swarm  # zenoh sessions (tests/conftest.py), a few seconds in all


@pytest.fixture
def session():
    """One zenoh session alone (no scouting, no router): its own puts reach its own subscribers."""
    config = zenoh.Config()
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    s = zenoh.open(config)
    yield s
    s.close()


def stand_in(script: str) -> subprocess.Popen:
    """A stand-in coordinator (`sh -c script`) whose stderr is read as the coordinator's."""
    return subprocess.Popen(["sh", "-c", script], stderr=subprocess.PIPE)


def plan_of(path, frame, secret: bytes = SECRET) -> Plan:
    im = imitation_of_input(path, 24, "region", frame)
    return Plan(tuple((first, c.encode(secret)) for first, c in im.commands), 0 if frame is not None else 40)


@pytest.mark.parametrize("path, frame", [(PHOTO, 0), (WAVE2, None)])
def test_a_plan_signed_with_the_runs_key_is_taken_whole_and_a_forged_one_is_not(session, path, frame):
    """A photo (one command) and a clip's gesture sequence (many): a plan signed with another key, or torn, is
    dropped; the run's own arrives whole."""
    plan, forged = plan_of(path, frame), plan_of(path, frame, bytes(range(1, 33)))
    stop = threading.Event()
    got: list = []
    waiter = threading.Thread(target=lambda: got.append(handover.await_plan(session, "r", SECRET, stop, 30)))
    waiter.start()
    time.sleep(0.3)  # its subscriber declared
    for data in (encode_plan(forged), encode_plan(plan)[:-5], encode_plan(plan)):
        session.put(plan_key("r"), data)
    waiter.join(30)
    assert got == [plan] and len(plan.commands) >= (1 if frame == 0 else 3)


def test_no_plan_in_time_is_none(session):
    t0 = time.monotonic()
    assert handover.await_plan(session, "r", SECRET, threading.Event(), 0.3) is None
    assert time.monotonic() - t0 < 5


def test_a_coordinator_that_exits_is_its_own_error_line(session):
    proc = stand_in(
        "echo 'some library: noise' >&2; echo 'fluidswarm coordinator: error: x.jpg: no such file' >&2; exit 1"
    )
    with pytest.raises(handover.CoordinatorFailed, match=r"^x\.jpg: no such file$"):
        handover.hand_plan(session, "r", plan_of(PHOTO, 0), proc, 30)
    notes = handover.Notes(session, "r")
    with pytest.raises(handover.CoordinatorFailed, match=r"^x\.jpg: no such file$"):
        notes.wait_seen(stand_in("echo 'fluidswarm coordinator: error: x.jpg: no such file' >&2; exit 1"), 30, str)
    notes.close()


def test_a_coordinator_that_dies_of_an_uncaught_exception_names_it_and_where(session):
    # A bug's traceback is the only trace of it once the process has ended: one line of it, not the exit code.
    crash = (
        f'{sys.executable} -c \'import json\ndef observe(frame):\n    raise ValueError("frame 3: bad box")\n'
        'try:\n    json.loads("{")\nexcept Exception:\n    observe(3)\''
    )
    uncaught = r"^uncaught ValueError: frame 3: bad box \(at <string>, line 3, in observe\)$"
    with pytest.raises(handover.CoordinatorFailed, match=uncaught):
        handover.hand_plan(session, "r", plan_of(PHOTO, 0), stand_in(crash), 30)
    notes = handover.Notes(session, "r")
    with pytest.raises(handover.CoordinatorFailed, match=uncaught):
        notes.wait_seen(stand_in(crash), 30, str)
    notes.close()
    # Its own error line still wins over a traceback printed before it.
    proc = stand_in(f"{crash}; echo 'fluidswarm coordinator: error: x.jpg: no such file' >&2; exit 1")
    with pytest.raises(handover.CoordinatorFailed, match=r"^x\.jpg: no such file$"):
        handover.hand_plan(session, "r", plan_of(PHOTO, 0), proc, 30)


def test_a_coordinator_that_exits_without_a_word_is_named_with_its_code(session):
    with pytest.raises(
        handover.CoordinatorFailed, match=r"^the coordinator ended before it commanded \(exit code 3\)$"
    ):
        handover.hand_plan(session, "r", plan_of(PHOTO, 0), stand_in("exit 3"), 30)
    notes = handover.Notes(session, "r")
    with pytest.raises(handover.CoordinatorFailed, match=r"^the coordinator ended without .* \(exit code 3\)$"):
        notes.wait_seen(stand_in("exit 3"), 30, str)
    notes.close()


def test_a_coordinator_that_says_nothing_in_time_is_the_deadline_message(session):
    proc = stand_in("exec sleep 30")
    notes = handover.Notes(session, "r")
    t0 = time.monotonic()
    try:
        with pytest.raises(handover.CoordinatorFailed, match="^no hand seen in 0.3 s$"):
            notes.wait_seen(proc, 0.3, lambda: "no hand seen in 0.3 s")
        with pytest.raises(handover.CoordinatorFailed, match="did not command the launcher's plan within 0 s$"):
            handover.hand_plan(session, "r", plan_of(PHOTO, 0), proc, 0.3)
    finally:
        proc.kill()
        proc.wait()
        notes.close()
    assert time.monotonic() - t0 < 5


def test_torn_or_foreign_notes_are_dropped_and_the_first_observation_is_awaited(session):
    im = imitation_of_input(PHOTO, 8, "fill", 0)
    seen = Seen(1, "hand", "hand_2", 0, im.mask, {}, b"\xff\xd8jpeg")
    notes = handover.Notes(session, "r")
    proc = stand_in("exec sleep 30")
    try:
        session.put(note_key("r"), encode_note(Missing("no hand found: covers 1.2 %")))
        session.put(note_key("r"), encode_note(seen)[:-9])  # torn
        session.put(note_key("other"), encode_note(seen))  # another run's
        threading.Timer(0.3, lambda: session.put(note_key("r"), encode_note(seen))).start()
        got = notes.wait_seen(proc, 30, str)
    finally:
        proc.kill()
        proc.wait()
        notes.close()
    assert got.label == "hand_2" and np.array_equal(got.mask, im.mask) and notes.dropped == 1
    assert notes.last_missing() == "no hand found: covers 1.2 %"


def test_a_picture_that_cannot_be_read_is_one_line_naming_it(tmp_path):
    """The launcher perceives a file itself: its problem is one line naming the input, as the coordinator's was."""
    missing = tmp_path / "missing.jpg"
    with pytest.raises(PerceptionFailed, match=f"^{missing}: .*no such file"):
        perceive(str(missing), 12, "fill", 0)


def test_the_coordinator_process_commands_the_launchers_plan():
    """The real coordinator process (`--plan`) on a real run's router: handed the plan, it broadcasts exactly
    its signed commands; without --agents (it plans nothing)."""
    from swarmhost.launcher import Launcher

    with Launcher(commands=True) as la:
        secret = bytes.fromhex(la.secret)
        plan = plan_of(PHOTO, 0, secret)
        env = dict(os.environ, FLUIDSWARM_SECRET=la.secret, **la.access.env_for("coordinator"))
        heard: list[bytes] = []
        sub = la.session.declare_subscriber(keys.command_key(la.run), lambda s: heard.append(s.payload.to_bytes()))
        proc = subprocess.Popen(
            [sys.executable, "-m", "coordinator", "--connect", la.endpoint, "--run", la.run, "--plan"],
            env=env,
            stderr=subprocess.PIPE,
        )
        try:
            handover.hand_plan(la.session, la.run, plan, proc, 120)
            time.sleep(0.5)
        finally:
            proc.terminate()
            proc.wait(10)
            sub.undeclare()
    assert heard and set(heard) == {plan.commands[0][1]}
