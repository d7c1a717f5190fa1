"""What a camera's coordinator says, into the recording (`fluidswarm record --coordinator-events DIR`).

The coordinator of `imitate --camera` (coordinator/camera.py) writes what happened to `DIR/events.jsonl`
(`EventLog`: one JSON object a line) and each command's observation to `DIR/command-<seq>.npz`, on the
host the launcher starts it and the recorder on. The recorder follows that file as the run goes:

- each `missing` event (no hand or person found, a hand leaving the frame, a silhouette the swarm cannot
  take) becomes a `foxglove.Log` warning of name `coordinator`, kind `missing`, on the run's event topic,
  at the simulated time it was read (live viewers see it as it happens);
- each command after the first (whose observation is the recorder's `--target`) becomes a new target
  (`RunWriter.write_target`: its silhouette, the first command's image -> domain map, which the coordinator
  keeps), so the file's last target -- the one its `fidelity` record and `replay` score -- is the last
  gesture's, and `gesture` names it.

A note said before the recorder started (a video that begins without a hand) is written at t = 0.

The launcher's events folder (`--launcher-events DIR`, swarmhost/launcher.py) is followed the same way: each
`host_lost` event (the clock's owner dropped a host of a split run whose share clock went silent) becomes a
`foxglove.Log` warning of name `launcher`, kind `host_lost`, naming the agents lost with that host.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from coordinator.control.geometry import ImageToDomain

EVENTS_FILE = "events.jsonl"


def command_file(seq: int) -> str:
    """The coordinator's observation of command `seq` in its events folder."""
    return f"command-{int(seq)}.npz"


def split_lines(buffer: bytes) -> tuple[list[dict], bytes]:
    """The JSON objects of the whole lines in `buffer` (others skipped), and the unfinished rest."""
    *whole, rest = buffer.split(b"\n")
    out = []
    for line in whole:
        try:
            e = json.loads(line)
        except ValueError:
            continue
        if isinstance(e, dict):
            out.append(e)
    return out, rest


class CoordinatorEvents:
    """Follows `folder`'s events.jsonl for `writer` (a RunWriter); `transform`: the targets' map (the
    recorder's first target's), None if it had none (then no target is added)."""

    def __init__(self, folder: Path, writer, transform: ImageToDomain | None, gesture: str | None = None):
        self.path = Path(folder) / EVENTS_FILE
        self.folder = Path(folder)
        self.writer = writer
        self.transform = transform
        self.target: tuple[np.ndarray, ImageToDomain] | None = None  # the last command's, after the first
        self.gesture = gesture  # of the last command seen
        self.notes = 0
        self._offset = 0
        self._rest = b""

    def poll(self, t: float) -> None:
        """Write what was added to the file since the last poll, at simulated time `t`."""
        try:
            with open(self.path, "rb") as f:
                f.seek(self._offset)
                data = f.read()
        except OSError:
            return  # not written yet
        self._offset += len(data)
        events, self._rest = split_lines(self._rest + data)
        for e in events:
            self._take(e, t)

    def _take(self, e: dict, t: float) -> None:
        kind = e.get("event")
        if kind == "missing":
            self.writer.write_event(t, "warning", "coordinator", str(e.get("what")), kind="missing")
            self.notes += 1
        elif kind == "host_lost":
            self.writer.write_event(t, "warning", "launcher", str(e.get("what")), kind="host_lost")
            self.notes += 1
        elif kind == "command":
            seq = e.get("seq")
            if not isinstance(seq, int):
                return
            if seq == 1 or self.transform is None:
                self.gesture = str(e.get("gesture"))
                return  # the first command's observation is the recorder's --target
            try:
                with np.load(self.folder / command_file(seq)) as z:
                    mask = z["mask"].astype(bool)
            except (OSError, KeyError, ValueError):
                return
            self.target, self.gesture = (mask, self.transform), str(e.get("gesture"))
            self.writer.write_target(t, mask, self.transform)
