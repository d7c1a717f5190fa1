"""Read a run's MCAP back into arrays (`load_run`) and verify that nothing was lost (`check`).

Completeness: for every step, the file holds the state of every agent alive at that step. An agent is
alive from its `started` event (or from the first step if it has none) until its `died`, `stopped` or
`finished` event (a run stopped mid-step leaves its agents a step or two apart: one stopped before a step
the others made has not lost it); an event with a `step` holds from that step on, otherwise it holds for
steps at times >= the event's time.
The roster is every id seen in a state or an event, plus `agent_ids` from the run metadata if present.
Steps are the recorded ones plus any gap between the first and the last (a lost step misses every agent
alive then).

A file whose writer died (no footer) is read up to its last whole record (recording/recover.py); the Recording
says so (`truncated`, `salvage`), and completeness applies to the steps it kept.
"""

from __future__ import annotations

import base64
import json
import os
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import cv2
import numpy as np
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import MCAP0_MAGIC
from zstandard import ZstdError

from agent.protocol.errors import UserError
from coordinator.control.fidelity import Fidelity
from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording import schemas as sc
from fluidswarm.recording.recover import Salvage, ends_with_magic, salvage, salvage_stream
from fluidswarm.recording.steps import LEFT
from fluidswarm.recording.writer import JSON_KEYS

_PNG = b"\x89PNG\r\n\x1a\n"
_MAX_MASK_PIXELS = 1 << 26  # a target mask (an input image's size) of at most 8192 x 8192 pixels
# What the mcap reader raises on a damaged file: its own errors, the struct/record decoding's, and what it lets
# through (found by fuzzing): the decompressors' (zstd's ZstdError, lz4's RuntimeError), the MemoryError of
# a length field that claims more than memory holds (it reads that many bytes), and the OverflowError of an
# offset beyond 2^63 that it seeks to in an io.BytesIO (`read_run`; a real file's seek raises ValueError).
_DAMAGED = (
    McapError,
    struct.error,
    EOFError,
    ValueError,
    KeyError,
    TypeError,
    ZstdError,
    RuntimeError,
    MemoryError,
    OverflowError,
)


@dataclass(frozen=True)
class Frame:
    """The alive particles of one step, one row each."""

    step: int
    t: float
    ids: np.ndarray  # (N,) int64
    positions: np.ndarray  # (N, 2)
    velocities: np.ndarray  # (N, 2)
    density: np.ndarray  # (N,)
    pressure: np.ndarray  # (N,)
    class_ids: np.ndarray  # (N,) int64


@dataclass(frozen=True)
class Event:
    t: float
    level: int
    name: str
    message: str
    kind: str | None
    agent: int | None
    step: int | None


@dataclass(frozen=True)
class Scene:
    t: float
    waypoints: list[tuple[float, float, float]]  # (x, y, r)
    ellipses: list[tuple[float, float, float, float, float]]  # (x, y, major, minor, angle_deg)


@dataclass(frozen=True)
class Target:
    t: float
    mask: np.ndarray  # bool, image pixels
    transform: ImageToDomain


@dataclass(frozen=True)
class Image:
    t: float
    frame_id: str
    format: str
    data: bytes


@dataclass
class Recording:
    """A run as its MCAP file holds it, read back (`load_run`); the run itself is
    fluidswarm/orchestration/run.py `Run`."""

    path: Path
    name: str
    metadata: dict  # the `run` metadata record, JSON values decoded
    frames: list[Frame] = field(default_factory=list)  # sorted by step
    events: list[Event] = field(default_factory=list)
    commands: list[tuple[float, dict]] = field(default_factory=list)
    scenes: list[Scene] = field(default_factory=list)
    images: list[Image] = field(default_factory=list)
    targets: list[Target] = field(default_factory=list)
    schemas: dict[str, str] = field(default_factory=dict)  # topic -> schema name
    fidelity: dict = field(default_factory=dict)  # the recorder's score of the final formation (metadata `fidelity`)
    fidelity_gesture: str | None = None  # the gesture of the target it scored, when the recorder named it
    timing: dict = field(default_factory=dict)  # how the run kept time (metadata `timing`: realtime_factor)
    salvage: Salvage | None = None  # the file had no footer (its writer died): what was read of it

    @property
    def truncated(self) -> bool:
        return self.salvage is not None

    @property
    def steps(self) -> np.ndarray:
        return np.array([f.step for f in self.frames], dtype=np.int64)

    @property
    def times(self) -> np.ndarray:
        return np.array([f.t for f in self.frames], dtype=float)

    @property
    def target(self) -> Target | None:
        """The last target written (the one the final formation is judged against)."""
        return self.targets[-1] if self.targets else None

    def scene_at(self, t: float) -> Scene | None:
        """The latest scene written at or before time t."""
        best = None
        for s in self.scenes:
            if s.t <= t:
                best = s
        return best


def decode_metadata(values: dict[str, str]) -> dict:
    json_keys = set(json.loads(values.get(JSON_KEYS, "[]")))
    return {k: (json.loads(v) if k in json_keys else v) for k, v in values.items() if k != JSON_KEYS}


def _decode_points(msg: dict) -> np.ndarray:
    """The packed `data` of a foxglove.PointCloud as a structured array, using the message's own fields."""
    fields = msg["fields"]
    dtype = np.dtype(
        {
            "names": [f["name"] for f in fields],
            "formats": [sc.NUMERIC_DTYPE[f["type"]] for f in fields],
            "offsets": [f["offset"] for f in fields],
            "itemsize": msg["point_stride"],
        }
    )
    return np.frombuffer(base64.b64decode(msg["data"]), dtype=dtype)


def _object(v, what: str) -> dict:
    """A JSON object of a message, or TypeError (a damaged file)."""
    if not isinstance(v, dict):
        raise TypeError(f"{what} is not a JSON object")
    return v


def _id(v, what: str) -> int | None:
    """An agent id or a step (an integer; None: not given), or ValueError (a damaged file): what the
    completeness rule counts with."""
    if v is not None and type(v) is not int:
        raise ValueError(f"{what} is not an integer: {v!r:.40}")
    return v


def _check_png(name: str, data: bytes) -> None:
    """A target mask as the recorder writes it (a PNG, messages.py): ValueError unless its chunks lie within
    the attachment, each with its CRC, and its size is a mask's, checked before OpenCV decodes it (found by
    fuzzing): OpenCV allocates what a chunk's length field claims (4 GB for a 424-byte attachment), leaks
    memory on a chunk that fails its CRC (a few kB each), and a small PNG can inflate to any size."""
    if data[:8] != _PNG:
        raise ValueError(f"attachment {name} is not a PNG")
    at = 8
    while at < len(data):
        if at + 12 > len(data):
            raise ValueError(f"attachment {name}: a PNG chunk is cut off")
        length, kind = struct.unpack(">I4s", data[at : at + 8])
        if at == 8:
            if kind != b"IHDR" or length != 13:
                raise ValueError(f"attachment {name}: a PNG without its IHDR chunk first")
            width, height = struct.unpack(">II", data[at + 8 : at + 16])
            if width * height > _MAX_MASK_PIXELS:
                raise ValueError(f"attachment {name}: a {width} x {height} mask (at most {_MAX_MASK_PIXELS} pixels)")
        end = at + 12 + length
        if end > len(data):
            raise ValueError(f"attachment {name}: a PNG chunk of {length} bytes runs past its end")
        if zlib.crc32(data[at + 4 : end - 4]) != int.from_bytes(data[end - 4 : end], "big"):
            raise ValueError(f"attachment {name}: PNG chunk {kind!r} fails its CRC")
        at = end
        if kind == b"IEND":
            return
    raise ValueError(f"attachment {name}: a PNG without its IEND chunk")


def _frame(msg: dict, log_time: int, sequence: int) -> Frame:
    pts = _decode_points(msg)
    step = int(_object(msg.get(sc.EXTRA_KEY, {}), "a state's extra").get("step", sequence))
    if not 0 <= step < 2**63:
        raise ValueError(f"a state's step {step} is beyond int64")
    return Frame(
        step=step,
        t=log_time / 1e9,
        ids=pts["id"].astype(np.int64),
        positions=np.stack([pts["x"], pts["y"]], axis=1).astype(float),
        velocities=np.stack([pts["vx"], pts["vy"]], axis=1).astype(float),
        density=pts["rho"].astype(float),
        pressure=pts["p"].astype(float),
        class_ids=pts["class"].astype(np.int64),
    )


def finished(path: Path) -> bool:
    """True if the file at `path` is an MCAP file with its footer; False if its writer did not finish it.
    Raises UserError naming the file if it is missing or not MCAP."""
    if not path.is_file():
        raise UserError(f"{path}: no such file")
    with open(path, "rb") as fh:
        return _finished(fh, path)


def _finished(fh: BinaryIO, path: Path) -> bool:
    """`finished` of the open, seekable file `fh` (named `path` in the error); leaves it at its start."""
    fh.seek(0)
    head = fh.read(len(MCAP0_MAGIC))
    if head != MCAP0_MAGIC:
        raise UserError(f"{path}: not an MCAP file" + (" (empty: its writer died before writing)" if not head else ""))
    return ends_with_magic(fh)


def _open_checked(path: Path):
    if not finished(path):
        raise UserError(f"{path}: truncated MCAP file (no footer; the recorder did not finish it)")
    return open(path, "rb")


def salvaged(path: Path, fh: BinaryIO | None = None) -> Salvage:
    """The records of an unfinished file, up to its last whole one (recording/recover.py); from `fh` (the
    file `path`, open and seekable) when given."""
    try:
        return salvage(path) if fh is None else salvage_stream(fh)
    except _DAMAGED as exc:
        raise UserError(f"{path}: damaged MCAP file ({exc})") from None


def load_run(path: str | os.PathLike, *, images: bool = True) -> Recording:
    """Read the whole run; a file whose writer died, up to its last whole record (`Recording.truncated`). Raises
    UserError naming the file if it is missing, not MCAP, or damaged."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such file")
    with open(path, "rb") as fh:
        return read_run(fh, path, images=images)


def read_run(fh: BinaryIO, path: Path, *, images: bool = True) -> Recording:
    """`load_run` of the open, seekable binary file `fh` (a real file, or the bytes of one in an io.BytesIO:
    the fuzz target, fuzz/python_targets.py); `path` names it in errors and in the Recording."""
    if not _finished(fh, path):
        kept = salvaged(path, fh)
        try:
            run = _read(path, kept, images)
        except _DAMAGED as exc:
            raise UserError(f"{path}: damaged MCAP file ({type(exc).__name__}: {exc})") from None
        run.salvage = kept
        return run
    try:
        reader = make_reader(fh)
        if reader.get_summary() is None:
            raise ValueError("no summary section")
        return _read(path, reader, images)
    except _DAMAGED as exc:
        raise UserError(f"{path}: damaged MCAP file ({type(exc).__name__}: {exc})") from None


def _scores(values: dict[str, str]) -> dict[str, float]:
    """The numbers of metadata record `fidelity` (writer.write_fidelity)."""
    return {k: float(v) for k, v in decode_metadata(values).items() if isinstance(v, (int, float))}


def as_fidelity(scores: dict[str, float]) -> Fidelity | None:
    """A run's recorded scores (`Recording.fidelity`) as a Fidelity; None when the file holds none."""
    if not scores:
        return None
    return Fidelity(scores["fidelity_iou"], scores["fidelity_inside"], scores["fidelity_coverage"], scores["nn_cv"])


def recorded_fidelity(path: str | os.PathLike) -> Fidelity | None:
    """The recorder's score of the final formation (metadata `fidelity`) without reading the steps, or None if
    the file holds none (no target, or no state)."""
    path = Path(path)
    if not finished(path):
        return None  # the score is written at the end: a file whose writer died has none
    with _open_checked(path) as fh:
        try:
            for record in make_reader(fh).iter_metadata():
                if record.name == "fidelity":
                    return as_fidelity(_scores(record.metadata))
        except _DAMAGED as exc:
            raise UserError(f"{path}: damaged MCAP file ({type(exc).__name__}: {exc})") from None
    return None


def recorded_robots(path: str | os.PathLike) -> dict | None:
    """What the recorder measured on the robots' bodies (metadata `robots`: robot, radius_m, collisions,
    min_separation_m; fluidswarm/recording/contacts.py), or None (point particles, or no file)."""
    path = Path(path)
    with _open_checked(path) as fh:
        try:
            for record in make_reader(fh).iter_metadata():
                if record.name == "robots":
                    return decode_metadata(record.metadata)
        except _DAMAGED as exc:
            raise UserError(f"{path}: damaged MCAP file ({type(exc).__name__}: {exc})") from None
    return None


def _read(path: Path, reader, want_images: bool) -> Recording:
    """The run from `reader`: mcap's reader of a finished file, or a Salvage (iter_metadata, iter_attachments,
    iter_messages yielding (schema, channel, message))."""
    metadata, target_meta, scores, scored, timing = {}, {}, {}, None, {}
    for record in reader.iter_metadata():
        if record.name == "run":
            metadata = decode_metadata(record.metadata)
        elif record.name == "fidelity":
            scores = _scores(record.metadata)
            scored = record.metadata.get("fidelity_gesture")
        elif record.name == "timing":
            timing = _scores(record.metadata)
        elif record.name.startswith("target/"):
            target_meta[f"{record.name}.png"] = decode_metadata(record.metadata)
    ids = metadata.get("agent_ids", [])
    if not isinstance(ids, list) or not all(_id(a, "run metadata agent_ids") is not None for a in ids):
        raise ValueError(f"run metadata agent_ids is not a list of ids: {ids!r:.40}")
    run = Recording(
        path=path,
        name=str(metadata.get("run", path.stem)),
        metadata=metadata,
        fidelity=scores,
        fidelity_gesture=scored,
        timing=timing,
    )
    for att in reader.iter_attachments():
        meta = target_meta.get(att.name)
        if meta is None:
            continue
        _check_png(att.name, att.data)
        try:
            mask = cv2.imdecode(np.frombuffer(att.data, np.uint8), cv2.IMREAD_GRAYSCALE)
        except cv2.error:  # OpenCV asserts on an empty buffer (found by fuzzing); other garbage gives None
            mask = None
        if mask is None:
            raise ValueError(f"attachment {att.name} is not a PNG")
        tf = ImageToDomain(scale=float(meta["scale"]), x0=float(meta["x0"]), y0=float(meta["y0"]))
        # np.greater, not `>`: atheris (the fuzz target) keeps every array an instrumented comparison returns
        run.targets.append(Target(t=float(meta["t"]), mask=np.greater(mask, 0), transform=tf))
    run.targets.sort(key=lambda tg: tg.t)

    for schema, channel, message in reader.iter_messages():
        leaf = channel.topic.split("/", 2)[-1] if channel.topic.startswith("fluidswarm/") else channel.topic
        run.schemas[channel.topic] = schema.name if schema else ""
        if leaf == sc.IMAGE and not want_images:
            continue
        msg = _object(json.loads(message.data), f"a message on {channel.topic}")
        t = message.log_time / 1e9
        if leaf == sc.STATE:
            run.frames.append(_frame(msg, message.log_time, message.sequence))
        elif leaf == sc.EVENTS:
            extra = _object(msg.get(sc.EXTRA_KEY, {}), "an event's extra")
            run.events.append(
                Event(
                    t=t,
                    level=int(msg.get("level", 0)),
                    name=msg.get("name", ""),
                    message=msg.get("message", ""),
                    kind=extra.get("kind"),
                    agent=_id(extra.get("agent"), "an event's agent"),
                    step=_id(extra.get("step"), "an event's step"),
                )
            )
        elif leaf == sc.SCENE:
            extra = msg.get(sc.EXTRA_KEY)
            if extra is not None:  # target outlines carry no waypoints/ellipses
                extra = _object(extra, "a scene's extra")
                run.scenes.append(
                    Scene(
                        t=t,
                        waypoints=[tuple(w) for w in extra.get("waypoints", [])],
                        ellipses=[tuple(e) for e in extra.get("ellipses", [])],
                    )
                )
        elif leaf == sc.COMMAND:
            run.commands.append((t, msg))
        elif leaf == sc.IMAGE:
            run.images.append(
                Image(
                    t=t,
                    frame_id=msg.get("frame_id", ""),
                    format=msg.get("format", ""),
                    data=base64.b64decode(msg.get("data", "")),
                )
            )
    run.frames.sort(key=lambda f: f.step)
    return run


@dataclass(frozen=True)
class Completeness:
    complete: bool
    steps: int  # recorded steps
    missing_states: int  # (step, alive agent) pairs with no state, lost steps included

    def lines(self) -> str:
        return (
            f"complete={'true' if self.complete else 'false'}\nsteps={self.steps}\nmissing_states={self.missing_states}"
        )


def salvage_lines(run: Recording) -> str:
    """For a file whose writer died: `truncated=true` and what was kept and dropped ("" for a finished file)."""
    if run.salvage is None:
        return ""
    return f"truncated=true\n{run.salvage.lines()}"


# The events after which an agent has no more states, as the recorder's step assembly writes them at the first
# step it lacks: a death, and the leaving of one that reported (steps.LEFT's kinds: finished, stopped).
ENDS = ("died", *(kind for kind, _words in LEFT.values()))


def completeness(run: Recording) -> Completeness:
    """Apply the completeness rule (module docstring) to a loaded run."""
    if not run.frames:
        return Completeness(complete=False, steps=0, missing_states=0)
    rec_steps, rec_times = run.steps, run.times
    all_steps = np.arange(rec_steps.min(), rec_steps.max() + 1)
    all_times = np.interp(all_steps, rec_steps, rec_times)  # times of lost steps, interpolated
    present: dict[int, set[int]] = {}
    for f in run.frames:
        present.setdefault(f.step, set()).update(f.ids.tolist())

    roster = set().union(*present.values())
    roster.update(int(a) for a in run.metadata.get("agent_ids", []))
    start: dict[int, np.ndarray] = {}  # agent -> steps at or after its start
    end: dict[int, np.ndarray] = {}  # agent -> steps before its death
    for ev in run.events:
        if ev.agent is None or ev.kind not in ("started", *ENDS):
            continue
        # np.greater_equal, not `>=`: as for the target masks in _read (the fuzz target under atheris)
        holds = np.greater_equal(all_steps, ev.step) if ev.step is not None else np.greater_equal(all_times, ev.t)
        roster.add(ev.agent)
        if ev.kind == "started":
            start[ev.agent] = start.get(ev.agent, True) & holds
        else:
            end[ev.agent] = end.get(ev.agent, True) & ~holds

    missing = 0
    for agent in roster:
        alive = start.get(agent, True) & end.get(agent, True)
        for k in np.nonzero(np.broadcast_to(alive, all_steps.shape))[0]:
            s = int(all_steps[k])
            if agent not in present.get(s, ()):
                missing += 1
    return Completeness(complete=missing == 0, steps=len(present), missing_states=missing)


def check(path: str | os.PathLike) -> tuple[bool, int, int]:
    """(complete, steps, missing_states) of the run at `path`; see the module docstring."""
    c = completeness(load_run(path, images=False))
    return c.complete, c.steps, c.missing_states
