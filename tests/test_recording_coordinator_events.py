"""The recorder's follow of a camera coordinator's events (fluidswarm/recording/coordinator_events.py): its
notes become foxglove.Log events of the coordinator, each later command's silhouette a target, and the
file's fidelity names the gesture it scored (the last). Written with the coordinator's own EventLog and
save_observation, into a real MCAP file, read back."""

from __future__ import annotations

import numpy as np

from coordinator.camera import EventLog, save_observation
from coordinator.control.fidelity import Fidelity
from coordinator.control.geometry import ImageToDomain
from coordinator.control.observe import Observation
from fluidswarm.recording.coordinator_events import CoordinatorEvents, command_file, split_lines
from fluidswarm.recording.reader import load_run, recorded_fidelity
from fluidswarm.recording.writer import RunWriter
from perception.io import load_image
from perception.segmentation import hand_mask


def test_a_torn_last_line_waits_for_its_end():
    events, rest = split_lines(b'{"event": "a"}\nnot json\n{"event": "b"')
    assert events == [{"event": "a"}] and rest == b'{"event": "b"'
    events, rest = split_lines(rest + b"}\n")
    assert events == [{"event": "b"}] and rest == b""


def test_notes_and_later_commands_are_written_as_events_and_targets(shared_image, tmp_path):
    folder = tmp_path / "obs"
    folder.mkdir()
    log = EventLog(folder)
    frames = {c: load_image(shared_image(c)) for c in (5, 2)}
    masks = {c: hand_mask(f) for c, f in frames.items()}
    tf = ImageToDomain(scale=0.02, x0=-1.0, y0=1.0)
    with RunWriter(tmp_path / "run.mcap", {"scenario": "follow", "gesture": "hand_5"}) as w:
        follow = CoordinatorEvents(folder, w, tf, "hand_5")
        follow.poll(0.0)  # no file yet: nothing
        log.write("subject", subject="hand", how="given")
        log.write("command", seq=1, gesture="hand_5", why="first")
        follow.poll(0.5)
        log.missing("no hand found: no foreground: the image is blank (uniform)")
        save_observation(folder / command_file(2), Observation("hand", masks[2], "hand_2", frames[2], {}))
        log.write("command", seq=2, gesture="hand_2", why="gesture")
        with open(folder / "events.jsonl", "a") as f:
            f.write('{"t": 1.0, "event": "missing", "what": "torn')  # the coordinator still writing it
        follow.poll(1.5)
        with open(folder / "events.jsonl", "a") as f:
            f.write(' line"}\n')
        follow.poll(2.0)
        assert follow.gesture == "hand_2" and follow.target is not None and follow.notes == 2
        np.testing.assert_array_equal(follow.target[0], masks[2])
        w.write_fidelity(Fidelity(0.8, 0.9, 0.7, 0.1), gesture=follow.gesture)  # as the recorder closes
    run = load_run(tmp_path / "run.mcap", images=False)
    said = [(e.t, e.name, e.kind, e.level, e.message) for e in run.events]
    assert said == [
        (1.5, "coordinator", "missing", 3, "no hand found: no foreground: the image is blank (uniform)"),
        (2.0, "coordinator", "missing", 3, "torn line"),
    ]
    (target,) = run.targets  # the first command's is the recorder's --target, not written again
    assert target.t == 1.5 and (target.mask == masks[2]).all() and target.transform == tf
    assert run.fidelity_gesture == "hand_2" and run.fidelity["fidelity_iou"] == 0.8
    assert recorded_fidelity(tmp_path / "run.mcap") == Fidelity(0.8, 0.9, 0.7, 0.1)  # the numbers only
