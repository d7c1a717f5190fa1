"""The recorder's follow of a camera coordinator's notes (fluidswarm/recording/coordinator_events.py): its
missing notes become foxglove.Log events of the coordinator, each later command's silhouette a target, and
the file's fidelity names the gesture it scored (the last). The notes as the coordinator's own EventLog says
them, encoded as on the bus (agent/protocol/imitation.py), into a real MCAP file, read back."""

from __future__ import annotations

import json

import numpy as np

from agent.protocol.imitation import Commanded, Subject, encode_note, note_key
from coordinator.camera import EventLog
from coordinator.control.fidelity import Fidelity
from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording.coordinator_events import CoordinatorNotes, LauncherEvents, split_lines
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
    frames = {c: load_image(shared_image(c)) for c in (5, 2)}
    masks = {c: hand_mask(f) for c, f in frames.items()}
    tf = ImageToDomain(scale=0.02, x0=-1.0, y0=1.0)
    with RunWriter(tmp_path / "run.mcap", {"scenario": "follow", "gesture": "hand_5"}) as w:
        follow = CoordinatorNotes("r", w, tf, "hand_5", early=("no hand found: covers 1.2 %",))
        log = EventLog(lambda note: follow.heard(note_key("r"), encode_note(note)))
        follow.poll(0.3)  # the note said before the recorder started: at t = 0
        log.write(Subject("hand", "given"))
        log.write(Commanded(1, "hand_5", "first", masks[5]))
        follow.poll(0.5)
        log.missing("no hand found: no foreground: the image is blank (uniform)")
        log.write(Commanded(2, "hand_2", "gesture", masks[2]))
        follow.heard(note_key("r"), encode_note(Commanded(3, "hand_1", "gesture", masks[5]))[:-7])  # torn
        follow.heard(note_key("other"), encode_note(Commanded(3, "hand_1", "gesture", masks[5])))  # another run's
        follow.poll(1.5)
        assert follow.gesture == "hand_2" and follow.target is not None and follow.notes == 2
        assert follow.dropped == 2
        np.testing.assert_array_equal(follow.target[0], masks[2])
        w.write_fidelity(Fidelity(0.8, 0.9, 0.7, 0.1), gesture=follow.gesture)  # as the recorder closes
    run = load_run(tmp_path / "run.mcap", images=False)
    said = [(e.t, e.name, e.kind, e.level, e.message) for e in run.events]
    assert said == [
        (0.0, "coordinator", "missing", 3, "no hand found: covers 1.2 %"),
        (1.5, "coordinator", "missing", 3, "no hand found: no foreground: the image is blank (uniform)"),
    ]
    (target,) = run.targets  # the first command's is the recorder's --target, not written again
    assert target.t == 1.5 and (target.mask == masks[2]).all() and target.transform == tf
    assert run.fidelity_gesture == "hand_2" and run.fidelity["fidelity_iou"] == 0.8
    assert recorded_fidelity(tmp_path / "run.mcap") == Fidelity(0.8, 0.9, 0.7, 0.1)  # the numbers only


def test_a_lost_host_from_the_launchers_events_is_a_launcher_warning_naming_its_agents(tmp_path):
    """The launcher's events folder (--launcher-events): the pacer's host_lost note, as Launcher writes it, into a
    real MCAP, read back (`replay --check` prints them: tests/test_workers_netns.py)."""
    from swarmhost.pacing_core import HostLost, PaceCore, Share

    folder = tmp_path / "launcher"
    folder.mkdir()
    core = PaceCore("r", 2.0, Share(own=(0, 1, 2, 3), swarm=12, owner=True, others=((4, 5, 6, 9), (7, 8, 10, 11))))
    written = []

    def log(lost: dict, text: str) -> None:  # Launcher._log_host_lost's line
        written.append(text)
        with open(folder / "events.jsonl", "a") as f:
            f.write(json.dumps({"event": "host_lost", "what": text, **lost}) + "\n")

    def lose_host(first: int, agents: int, step: int) -> None:  # as the pacer's shell hands the core's HostLost on
        for action in core.lose_host(first, agents, step):
            if isinstance(action, HostLost):
                log(action.lost, action.text)

    lose_host(7, 4, 42)
    assert core.lost_hosts == [{"first": 7, "agents": 4, "step": 42, "ids": [7, 8, 10, 11]}]
    assert written[0].startswith("the host of agents 7-8, 10-11 was lost: its share clock stopped at step 42")
    lose_host(30, 2, 5)  # a host this one knows nothing of: named by its first agent and size
    assert core.lost_hosts[1]["ids"] is None and "2 agents from agent 30" in written[1]
    with RunWriter(tmp_path / "run.mcap", {"scenario": "lost"}) as w:
        follow = LauncherEvents(folder, w)
        follow.poll(0.84)
        assert follow.notes == 2
    run = load_run(tmp_path / "run.mcap", images=False)
    said = [(e.t, e.name, e.kind, e.message) for e in run.events]
    assert said == [(0.84, "launcher", "host_lost", written[0]), (0.84, "launcher", "host_lost", written[1])]


def test_a_two_host_split_names_the_other_hosts_ids_without_being_told():
    from swarmhost.pacing_core import Share, _ranges

    assert Share((0, 1, 2), 6, True).ids_of(3, 3) == [3, 4, 5]
    assert Share((0, 1, 2), 6, True).ids_of(4, 2) is None  # three hosts: not the rest
    assert _ranges([3, 4, 5, 9, 11, 12]) == "3-5, 9, 11-12" and _ranges([0]) == "0"
