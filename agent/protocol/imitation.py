"""An imitation's records between its launcher and its coordinator (docs/protocol.md "Imitation"): typed here,
versioned, encoded and decoded (every field checked) by the agent crate's imitation.rs through agent._native.

- `Plan` (launcher -> coordinator, `fluidswarm/<run>/imitation/plan`): the launcher perceives a file and plans
  the imitation itself (coordinator/control/imitation_setup.py); its coordinator only broadcasts the plan's
  commands, each a command envelope signed with the run's key, which the coordinator verifies too.
- the notes (coordinator -> launcher, recorder, `fluidswarm/<run>/imitation/note`): what a camera's coordinator
  saw: the subject it watches, the first command's observation (the launcher places the swarm from it), each
  command's silhouette, what it could not see, the end of a video file.

A receiver drops anything malformed (`decode_*` return None): another version, an unknown kind or field, a
value of the wrong type or out of range, a silhouette whose runs do not cover its pixels exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from agent.protocol import keys
from agent.records import native

VERSION = native.IMITATION_VERSION
MAX_BYTES = native.IMITATION_MAX_BYTES
MAX_COMMANDS = native.IMITATION_MAX_COMMANDS
MAX_TEXT = native.IMITATION_MAX_TEXT
MAX_PIXELS = native.IMITATION_MAX_PIXELS  # of one silhouette


def plan_key(run: str) -> str:
    """Where the launcher puts the plan of `run` (the exact key its coordinator subscribes)."""
    return f"{keys.PREFIX}/{run}/imitation/plan"


def note_key(run: str) -> str:
    """Where the coordinator of `run` puts its notes (the exact key the launcher and the recorder subscribe)."""
    return f"{keys.PREFIX}/{run}/imitation/note"


def mask_runs(mask: np.ndarray) -> dict:
    """A silhouette as the record carries it: its size and the lengths of its alternating runs, row-major,
    the first of false pixels (0 if it starts with a true one)."""
    flat = np.asarray(mask, bool).ravel()
    edges = np.flatnonzero(flat[1:] != flat[:-1]) + 1
    bounds = np.concatenate(([0], edges, [flat.size]))
    runs = np.diff(bounds).tolist()
    if flat.size and flat[0]:
        runs = [0, *runs]
    rows, cols = mask.shape
    return {"rows": int(rows), "cols": int(cols), "runs": [int(r) for r in runs]}


def mask_of(record: dict) -> np.ndarray:
    """The silhouette of a mask the crate accepted (its runs cover its pixels exactly)."""
    runs = np.asarray(record["runs"], np.int64)
    values = np.arange(len(runs)) % 2 == 1
    return np.repeat(values, runs).reshape(record["rows"], record["cols"])


@dataclass(frozen=True)
class Plan:
    """The commands of a file's imitation: [(first frame it holds for, signed envelope)], each frame shown for
    `frame_steps` swarm steps of the run's clock (0: one command, shown all along)."""

    commands: tuple[tuple[int, bytes], ...]
    frame_steps: int = 0

    def as_json(self) -> dict:
        return {
            "v": VERSION,
            "record": "plan",
            "frame_steps": self.frame_steps,
            "commands": [[first, env.hex()] for first, env in self.commands],
        }


def encode_plan(plan: Plan) -> bytes:
    """The plan's bytes (imitation.rs, after the receiver's checks: ValueError if it would be refused)."""
    return native.imitation_plan_encode(plan.as_json())


def decode_plan(data: bytes) -> Plan | None:
    """The plan in `data`, or None if anything in it is malformed (the envelopes are still to be verified)."""
    msg = native.imitation_plan_decode(bytes(data))
    if msg is None:
        return None
    return Plan(tuple((first, bytes.fromhex(env)) for first, env in msg["commands"]), msg["frame_steps"])


@dataclass(frozen=True)
class Subject:
    """The subject the coordinator watches ('hand' | 'person'), `how` it was chosen ('given' | 'auto'), and
    with auto how many frames decided it."""

    subject: str
    how: str
    frames: int | None = None


@dataclass(frozen=True)
class Seen:
    """The first command's observation (coordinator/control/observe.py Observation's fields; the frame as the
    JPEG the recorder is given), which the launcher places the swarm from."""

    seq: int
    observed: str
    label: str
    index: int
    mask: np.ndarray
    parts: dict[str, np.ndarray]
    picture: bytes


@dataclass(frozen=True)
class Commanded:
    """Command `seq` went out for `gesture`, `why` ('first' | 'gesture' | 'silhouette'); `mask` its silhouette."""

    seq: int
    gesture: str
    why: str
    mask: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class Missing:
    """Nothing commanded: `what` the coordinator could not see (once per reason)."""

    what: str


@dataclass(frozen=True)
class End:
    """A video file ended after `frames` frames."""

    frames: int


Note = Subject | Seen | Commanded | Missing | End


def note_json(note: Note) -> dict:
    """The note as the record's JSON object."""
    head = {"v": VERSION, "record": "note"}
    if isinstance(note, Subject):
        extra = {} if note.frames is None else {"frames": note.frames}
        return {**head, "note": "subject", "subject": note.subject, "how": note.how, **extra}
    if isinstance(note, Seen):
        return {
            **head,
            "note": "observation",
            "seq": note.seq,
            "observed": note.observed,
            "label": note.label,
            "index": note.index,
            "mask": mask_runs(note.mask),
            "parts": {k: mask_runs(v) for k, v in note.parts.items()},
            "picture": note.picture.hex(),
        }
    if isinstance(note, Commanded):
        return {
            **head,
            "note": "command",
            "seq": note.seq,
            "gesture": note.gesture,
            "why": note.why,
            "mask": mask_runs(note.mask),
        }
    if isinstance(note, Missing):
        return {**head, "note": "missing", "what": note.what}
    return {**head, "note": "end", "frames": note.frames}


def encode_note(note: Note) -> bytes:
    """The note's bytes (imitation.rs, after the receiver's checks: ValueError if it would be refused)."""
    return native.imitation_note_encode(note_json(note))


def decode_note(data: bytes) -> Note | None:
    """The note in `data`, or None if anything in it is malformed (imitation.rs decode_note)."""
    msg = native.imitation_note_decode(bytes(data))
    if msg is None:
        return None
    kind = msg["note"]
    if kind == "subject":
        return Subject(msg["subject"], msg["how"], msg.get("frames"))
    if kind == "observation":
        parts = {k: mask_of(v) for k, v in msg["parts"].items()}
        picture = bytes.fromhex(msg["picture"])
        return Seen(msg["seq"], msg["observed"], msg["label"], msg["index"], mask_of(msg["mask"]), parts, picture)
    if kind == "command":
        return Commanded(msg["seq"], msg["gesture"], msg["why"], mask_of(msg["mask"]))
    if kind == "missing":
        return Missing(msg["what"])
    return End(msg["frames"])
