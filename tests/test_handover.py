"""The coordinator's hand-over of its imitation (coordinator/handover.py): the imitation crosses the pipe whole,
and a coordinator that dies, stalls or tears the pipe is a one-line CoordinatorFailed, never a hang."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from coordinator import handover
from coordinator.control.imitation_setup import imitation_of_input

REPO = Path(__file__).resolve().parents[1]
PHOTO = REPO / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"
WAVE2 = REPO / "scenarios" / "inputs" / "weizmann_wave2_person0.png"


def same(a, b) -> None:
    assert np.array_equal(a.mask, b.mask) and a.transform == b.transform and a.commands == b.commands
    s, t = a.setup, b.setup
    assert np.array_equal(s.ids, t.ids) and np.array_equal(s.states, t.states) and np.array_equal(s.classes, t.classes)
    assert (s.controls, s.class_names, s.params, s.robot) == (t.controls, t.class_names, t.params, t.robot)
    o, p = a.observation, b.observation
    assert (o.kind, o.label, o.index) == (p.kind, p.label, p.index) and np.array_equal(o.mask, p.mask)
    assert np.array_equal(o.frame, p.frame) and o.parts.keys() == p.parts.keys()
    assert all(np.array_equal(o.parts[k], p.parts[k]) for k in o.parts)


@pytest.mark.parametrize("path, controller, frame", [(PHOTO, "fill", 0), (WAVE2, "region", None)])
def test_an_imitation_crosses_the_pipe_whole(path, controller, frame):
    """A photo (fill: the shape and its zones) and a clip's gesture sequence (region: body parts, many commands)."""
    im = imitation_of_input(path, 24, controller, frame)
    read, write = os.pipe()
    sender = threading.Thread(target=handover.send, args=(write, im))
    sender.start()
    proc = subprocess.Popen(["true"])
    got = handover.receive(read, proc, 30, lambda: "not in time")
    sender.join()
    proc.wait()
    same(im, got)
    assert len(got.commands) == len(im.commands) >= (1 if frame == 0 else 3)


def dead_end(script: str) -> tuple[subprocess.Popen, int]:
    """A stand-in coordinator (`sh -c script`) holding the pipe's write end, and the read end."""
    read, write = os.pipe()
    proc = subprocess.Popen(["sh", "-c", script], stderr=subprocess.PIPE, pass_fds=(write,))
    os.close(write)
    return proc, read


def test_a_coordinator_that_exits_is_its_own_error_line():
    proc, read = dead_end(
        "echo 'some library: noise' >&2; echo 'fluidswarm coordinator: error: x.jpg: no such file' >&2; exit 1"
    )
    with pytest.raises(handover.CoordinatorFailed, match=r"^x\.jpg: no such file$"):
        handover.receive(read, proc, 30, lambda: "not in time")


def test_a_coordinator_that_exits_without_a_word_is_named_with_its_code():
    proc, read = dead_end("exit 3")
    with pytest.raises(handover.CoordinatorFailed, match=r"^the coordinator ended without .* \(exit code 3\)$"):
        handover.receive(read, proc, 30, lambda: "not in time")


def test_a_coordinator_that_says_nothing_in_time_is_the_deadline_message():
    proc, read = dead_end("exec sleep 30")
    t0 = time.monotonic()
    try:
        with pytest.raises(handover.CoordinatorFailed, match="^no hand seen in 0.3 s$"):
            handover.receive(read, proc, 0.3, lambda: "no hand seen in 0.3 s")
    finally:
        proc.kill()
        proc.wait()
    assert time.monotonic() - t0 < 5


def test_a_torn_imitation_is_not_taken():
    im = imitation_of_input(PHOTO, 8, "fill", 0)
    read, write = os.pipe()
    whole = handover.encode(im)
    proc = subprocess.Popen(["true"], stderr=subprocess.PIPE)
    proc.wait()
    threading.Thread(target=lambda: (os.write(write, whole[: len(whole) // 2]), os.close(write))).start()
    with pytest.raises(handover.CoordinatorFailed, match=r"ended without handing over an imitation \(exit code 0\)"):
        handover.receive(read, proc, 30, lambda: "not in time")


@pytest.mark.swarm
def test_the_coordinator_process_hands_over_what_it_perceived_or_its_error(tmp_path):
    """The real coordinator process: a picture it cannot read is its one-line error through the hand-over
    (it perceives before it connects: no router needed); a good one arrives whole, as perceived here."""
    env = dict(os.environ, FLUIDSWARM_SECRET="ab" * 32)

    def coordinator(path: Path, timeout: float = 120):
        read, write = os.pipe()
        argv = ["--connect", "tcp/127.0.0.1:9", "--run", "handover", "--agents", "12", "--frame", "0"]
        proc = subprocess.Popen(
            [sys.executable, "-m", "coordinator", *argv, "--input", str(path), "--handover", str(write)],
            env=env,
            stderr=subprocess.PIPE,
            pass_fds=(write,),
        )
        os.close(write)
        try:
            return handover.receive(read, proc, timeout, lambda: "not in time")
        finally:
            proc.kill()
            proc.wait()

    missing = tmp_path / "missing.jpg"
    with pytest.raises(handover.CoordinatorFailed, match=f"^{missing}: .*no such file"):
        coordinator(missing)
    same(imitation_of_input(PHOTO, 12, "fill", 0), coordinator(PHOTO))
