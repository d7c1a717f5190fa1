"""What a camera's coordinator and the launcher say, into the recording (`fluidswarm record --coordinator-notes`,
`--launcher-events DIR`).

The coordinator of `imitate --camera` (coordinator/camera.py) puts its notes on the run's bus
(`fluidswarm/<run>/imitation/note`, agent/protocol/imitation.py: checked on receipt, anything malformed
dropped); the recorder follows them as the run goes (`CoordinatorNotes`):

- each `missing` note (no hand or person found, a hand leaving the frame, a silhouette the swarm cannot
  take) becomes a `foxglove.Log` warning of name `coordinator`, kind `missing`, on the run's event topic,
  at the simulated time it was heard (live viewers see it as it happens);
- each command after the first (whose observation is the recorder's `--target`) becomes a new target
  (`RunWriter.write_target`: its silhouette, the first command's image -> domain map, which the coordinator
  keeps), so the file's last target -- the one its `fidelity` record and `replay` score -- is the last
  gesture's, and `gesture` names it.

The notes said before the recorder started (a video that begins without a hand), which the launcher heard,
are handed to it at its start and written at t = 0.

The launcher's events folder (`--launcher-events DIR`, swarmhost/launcher.py) is followed from its file
(`LauncherEvents`): each `host_lost` event (the clock's owner dropped a host of a split run whose share clock
went silent) becomes a `foxglove.Log` warning of name `launcher`, kind `host_lost`, naming the agents lost
with that host.
"""

from __future__ import annotations

import json
import threading
from collections import deque
from pathlib import Path

import numpy as np

from agent.protocol.imitation import Commanded, Missing, Note, decode_note, note_key
from coordinator.control.geometry import ImageToDomain

EVENTS_FILE = "events.jsonl"


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


class CoordinatorNotes:
    """Follows the coordinator's notes of run `run` for `writer` (a RunWriter): `on_sample` (zenoh's thread)
    checks and queues each, `poll(t)` writes the queued ones at simulated time `t`. `transform`: the targets'
    map (the recorder's first target's), None if it had none (then no target is added); `early`: the missing
    notes said before the recorder started (written at the first poll, at t = 0)."""

    def __init__(
        self,
        run: str,
        writer,
        transform: ImageToDomain | None,
        gesture: str | None = None,
        early: tuple[str, ...] = (),
    ):
        self.key = note_key(run)
        self.writer = writer
        self.transform = transform
        self.target: tuple[np.ndarray, ImageToDomain] | None = None  # the last command's, after the first
        self.gesture = gesture  # of the last command seen
        self.notes = 0
        self.dropped = 0  # malformed, or on another key
        self._queue: deque[Note] = deque(Missing(what) for what in early)
        self._early = len(early)
        self._lock = threading.Lock()

    def on_sample(self, sample) -> None:
        self.heard(str(sample.key_expr), sample.payload.to_bytes())

    def heard(self, key: str, data: bytes) -> None:
        """A message on `key`: queued if it is a valid note on the run's note key, else dropped (counted)."""
        note = decode_note(data) if key == self.key else None
        with self._lock:
            if note is None:
                self.dropped += 1
            else:
                self._queue.append(note)

    def poll(self, t: float) -> None:
        """Write the notes heard since the last poll, at simulated time `t` (the early ones at 0)."""
        while True:
            with self._lock:
                if not self._queue:
                    return
                note = self._queue.popleft()
            early, self._early = self._early > 0, max(0, self._early - 1)
            self.take(note, 0.0 if early else t)

    def take(self, note: Note, t: float) -> None:
        if isinstance(note, Missing):
            self.writer.write_event(t, "warning", "coordinator", note.what, kind="missing")
            self.notes += 1
        elif isinstance(note, Commanded):
            self.gesture = note.gesture
            if note.seq == 1 or self.transform is None:
                return  # the first command's observation is the recorder's --target
            self.target = (note.mask, self.transform)
            self.writer.write_target(t, note.mask, self.transform)


class LauncherEvents:
    """Follows `folder`'s events.jsonl (the launcher's) for `writer` (a RunWriter)."""

    def __init__(self, folder: Path, writer):
        self.path = Path(folder) / EVENTS_FILE
        self.writer = writer
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
            if e.get("event") == "host_lost":
                self.writer.write_event(t, "warning", "launcher", str(e.get("what")), kind="host_lost")
                self.notes += 1
