"""A live source for the coordinator: a person or a hand watched by a camera, a network stream or a video file.

`subject` "hand": each observed frame is read on its own (perception/hand.py: a hand in front of a plain
background, its silhouette and the classifier's class; a hand moves, so no static-body assumption).
"person": as below. "auto": the first AUTO_FRAMES observed frames decide (a hand in most of them: hand).

Frames are taken as they come (perception/stream.py, at most `--fps` per second). Each observed frame is
read with the last `window` observed frames as a static-camera clip (perception/segmentation.py: the person's
silhouette, arms and recognised pose), or alone (perception/selfie.py) when they are no static camera's clip; the
person's box is tracked with the Kalman filter of
perception/tracking.py. A new command (next sequence number) is issued only when the recognised gesture
changed and held for `label_hold` observations, or the silhouette changed beyond a threshold (its IoU with
the last commanded one, or the tracked box moving or resizing, no sooner than `min_seconds` after the last
command) -- not every frame.

The first observation fixes the image -> domain map (coordinator/control/imitation_setup.py `transform_for`)
and each command is built in it (`build_command`). What happened goes out as notes on the run's bus (`say`:
agent/protocol/imitation.py, put on `fluidswarm/<run>/imitation/note`): the subject chosen, the first
command's observation (its silhouette, parts and picture: the launcher places the swarm from it,
fluidswarm/imitate_camera.py), each command (seq, gesture, why, its silhouette: the recorder's targets,
fluidswarm/recording/coordinator_events.py, and the launcher's score), each time the subject was not found
(what, said once until it was found again or the reason changed) and the end of a video file. A video file
ends normally at its last frame; a device or URL that ends or stalls is a StreamError.
"""

from __future__ import annotations

import contextlib
import itertools
import re
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from agent.protocol.imitation import Commanded, End, Missing, Note, Seen, Subject
from coordinator.control.fill import ShapeError
from coordinator.control.imitation_setup import build_command, controller_of, transform_for
from coordinator.control.observe import Observation, body_observation
from perception.segmentation import MAX_MOVING_AWAY, SegmentationError, moving_away, person_regions
from perception.stream import FrameStream, StreamEnded, StreamError
from perception.tracking import BoxKalman, box_to_centre

PARTS = ("torso", "left_arm", "right_arm")
SUBJECTS = ("hand", "person", "auto")
AUTO_FRAMES = 3  # observed frames that decide --subject auto
HOLD_SECONDS = 300.0  # s a video file waits for its swarm to start (a 1000-agent start on 2 cores: minutes)


@dataclass(frozen=True)
class ChangeRule:
    """window [frames]: observed frames read together (their median is the background); label_hold
    [observations]: a recognised gesture counts once seen this many times in a row; silhouette_iou: a
    silhouette whose IoU with the last commanded one is below this is a new shape; box_change: the tracked
    box moving or resizing by more than this fraction of its size is a new shape; min_seconds [s]: at least
    this long after a command before a new shape counts (the swarm needs time to follow; a new gesture
    does not wait). Measured on the shared wave2 clip (person 0, 64 x 64): a window of 6 frames observed
    at half the clip's rate gives the whole clip's labels on every frame; within one pose the waving arms
    move the silhouette by IoU 0.54-0.93 and the box by up to 0.44 of its size between observations."""

    window: int = 6
    label_hold: int = 2
    silhouette_iou: float = 0.5
    box_change: float = 0.5
    min_seconds: float = 1.0


class LiveObserver:
    """The newest frame read with the ones before it (background subtraction: a static camera, the reading
    that sees the arms move); when they cannot be read so (nothing moves, no person-sized silhouette, or
    the camera or the room moves: `moving_away`), the newest frame read alone (perception/selfie.py `person_in_frame`: a
    person in front of any background); None while there is nothing to see yet."""

    subject = "person"

    def __init__(self, window: int):
        self.frames: deque = deque(maxlen=max(3, window))
        self.missing: str | None = None  # why the last frame showed no person
        self.reading: str | None = None  # how the last person was read: "clip" | "frame"

    def observe(self, frame: np.ndarray) -> Observation | None:
        if self.frames and self.frames[-1].shape != frame.shape:
            self.frames.clear()  # the source changed its picture size: start again
        self.frames.append(frame)
        if len(self.frames) < 3:
            return None
        frames = list(self.frames)
        try:
            # the background comes from the whole window, the silhouette only for the newest frame (the one
            # commanded): GrabCut on every frame of the window cost 6 times as much (1.4 s each at 640x480)
            obs = body_observation(frame, person_regions(frames, only=[len(frames) - 1])[0], len(frames) - 1)
        except SegmentationError as exc:
            return self.one_frame(frame, str(exc))
        # background subtraction takes what changes for the person: where much changes away from the
        # person it found, the camera or the room moves and its silhouette is not to be trusted
        away = moving_away(frames, obs.mask)
        if away > MAX_MOVING_AWAY:
            return self.one_frame(
                frame,
                f"no person found: the room moves ({away:.0%} of the picture away from the person changes, a "
                f"static camera's at most {MAX_MOVING_AWAY:.0%})",
            )
        self.reading = "clip"
        self.missing = None if obs.mask.any() else "no person found: an empty silhouette"
        return obs if obs.mask.any() else None

    def one_frame(self, frame: np.ndarray, clip_why: str) -> Observation | None:
        """`frame` read alone; None (the swarm keeps its command), with both readings' reasons, if it
        shows no person either."""
        from perception.selfie import person_in_frame  # the model loads on first use

        try:
            regions = person_in_frame(frame)
        except SegmentationError as exc:
            self.missing = f"{clip_why}; {str(exc).removeprefix('no person found: ')}"
            return None
        self.missing, self.reading = None, "frame"
        return body_observation(frame, regions)


class HandObserver:
    """Each frame read on its own (perception/hand.py `find_hand`), and its foreground watched across frames
    for a hand leaving the picture (`ExitWatch`); None, with `missing` saying why, when it shows no hand or
    one leaving (then the same note all along: the swarm keeps its command)."""

    subject = "hand"

    def __init__(self, classifier=None):
        from perception.eigen import default_model
        from perception.hand import ExitWatch

        self.classifier = classifier or default_model()
        self.exits = ExitWatch()
        self.missing: str | None = None

    def observe(self, frame: np.ndarray) -> Observation | None:
        from perception.hand import NoHandError, find_hand, leaving_note

        hand, why = None, None
        try:
            hand = find_hand(frame, self.classifier)
            mask = hand.mask
        except NoHandError as exc:
            mask, why = exc.mask, str(exc)
        border = self.exits.update(mask, hand is not None)
        if border is not None:
            self.missing = leaving_note(border)
            return None
        if hand is None:
            self.missing = why
            return None
        self.missing = None
        return Observation("hand", hand.mask, f"hand_{hand.label}", frame, {})


def choose_subject(frames: list[np.ndarray], hands: HandObserver) -> str:
    """'hand' if most of `frames` show a hand in front of a plain background, else 'person'."""
    seen = sum(hands.observe(f) is not None for f in frames)
    return "hand" if 2 * seen > len(frames) else "person"


class EventLog:
    """The coordinator's notes, each handed to `say` (its put on the bus; None: nowhere); 'missing' said once
    per reason."""

    def __init__(self, say: Callable[[Note], None] | None):
        self.say = say
        self._said: str | None = None
        self.last: str | None = None  # the last reason the subject was not found (None once it was found)

    def write(self, note: Note) -> None:
        if self.say is not None:
            self.say(note)

    def missing(self, what: str | None) -> None:
        kind = None if what is None else re.sub(r"[0-9.]+", "#", what)  # the reason, not its figures
        self.last = what
        if what is not None and kind != self._said:
            self.write(Missing(what))
        self._said = kind


def _box(mask: np.ndarray) -> np.ndarray:
    ys, xs = np.nonzero(mask)
    return box_to_centre((xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1))


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    union = np.logical_or(a, b).sum()
    return float(np.logical_and(a, b).sum() / union) if union else 1.0


class CommandSwitch:
    """Decides when an observation deserves a new command (ChangeRule)."""

    def __init__(self, rule: ChangeRule = ChangeRule()):
        self.rule = rule
        self.kalman = BoxKalman()
        self.candidate: str | None = None
        self.seen = 0
        self.label: str | None = None  # of the last command
        self.mask: np.ndarray | None = None
        self.box: np.ndarray | None = None  # tracked (cx, cy, w, h) at the last command
        self.at = -np.inf

    def update(self, obs: Observation, now: float) -> str | None:
        """Why a new command is due ('first' | 'gesture' | 'silhouette'), or None."""
        self.kalman.predict()
        tracked = self.kalman.update(_box(obs.mask))
        if obs.label == self.candidate:
            self.seen += 1
        else:
            self.candidate, self.seen = obs.label, 1
        if self.label is None:
            return "first"
        if self.candidate != self.label and self.seen >= self.rule.label_hold:
            return "gesture"
        if now - self.at < self.rule.min_seconds:
            return None
        assert self.mask is not None and self.box is not None  # set with the label, by commit()
        if obs.mask.shape == self.mask.shape and _iou(obs.mask, self.mask) < self.rule.silhouette_iou:
            return "silhouette"
        size = max(self.box[2], self.box[3], 1.0)
        if np.abs(tracked - self.box).max() > self.rule.box_change * size:
            return "silhouette"
        return None

    def commit(self, obs: Observation, now: float) -> None:
        """A command for `obs` went out."""
        self.label, self.mask, self.at = obs.label, obs.mask, now
        assert self.kalman.x is not None  # update() has run on this observation
        self.box = self.kalman.x[:4].copy()


def seen_note(obs: Observation, seq: int) -> Seen:
    """Command `seq`'s observation as the note the launcher places the swarm from: the parts it plans with,
    the picture as the JPEG the recorder is given (what cv2.imwrite would write)."""
    assert obs.frame is not None  # a camera's observation carries its picture
    ok, jpeg = cv2.imencode(".jpg", obs.frame)
    if not ok:
        raise ValueError("the frame could not be encoded as JPEG")
    parts = {k: obs.parts[k] for k in PARTS if k in obs.parts}
    return Seen(seq, obs.kind, obs.label, obs.index, obs.mask, parts, jpeg.tobytes())


def open_stream(source: str, params, ros2_router: str = ""):
    """The frames of `source`: a device, URL or file (perception/stream.py), or a ROS 2 image topic `ros2:/...`
    through the router at `ros2_router` on the domain of ROS_DOMAIN_ID (ros2link/camera.py)."""
    from ros2link.camera import Ros2FrameStream, is_ros2_source

    if not is_ros2_source(source):
        return FrameStream(source, params)
    from ros2link.rmw import DEFAULT_ROUTER, domain_from_env

    try:
        domain = domain_from_env()
    except ValueError as exc:
        raise StreamError(f"camera {source}: {exc}") from None
    return Ros2FrameStream(source, params, ros2_router or DEFAULT_ROUTER, domain)


def run_camera(
    source: str,
    stream_params,
    n_agents: int,
    controller: str,
    secret: bytes,
    pub,
    stop: threading.Event,
    period: float,
    say: Callable[[Note], None] | None,
    rule: ChangeRule = ChangeRule(),
    subject: str = "person",
    started: threading.Event | None = None,
    ros2_router: str = "",
) -> None:
    """Observe `source` until `stop` or the end of a video file, publishing signed commands on `pub`
    (republished every `period` s by a side thread, so late joiners get one while a frame is being read)
    and handing its notes to `say` (EventLog). A video file is held after its first command until `started`
    (the swarm runs), so that what it shows is seen by the swarm as it was recorded, however long the swarm
    took to start (at most HOLD_SECONDS). Raises StreamError (a file that ends before anything was commanded, too)."""
    if subject not in SUBJECTS:
        raise ValueError(f"subject must be one of {', '.join(SUBJECTS)}, got {subject!r}")
    log = EventLog(say)
    with _said_how_a_file_ended(source, log):
        current: list[bytes] = []
        # The republisher ends with this function (`done`) and is joined: the caller undeclares `pub` next, and a put
        # still running on it made that undeclare fail ("Already borrowed": test_camera in a fresh-clone CI).
        done = threading.Event()

        def republish() -> None:
            while not done.wait(period) and not stop.is_set():
                if current:
                    pub.put(current[-1])

        republisher = threading.Thread(target=republish, name="republish", daemon=True)
        republisher.start()
        try:
            switch = CommandSwitch(rule)
            transform = None
            seq = 0
            observer = None
            # The hand observer (its classifier and the modules it loads, ~0.2 s) is ready before the stream opens: a
            # video file plays in real time from its open, and what loads after that is frames lost before the swarm's
            # first command, and time the swarm does not get to form the later gestures.
            hands = HandObserver() if subject in ("hand", "auto") else None
            with open_stream(source, stream_params, ros2_router) as stream:

                def frames():
                    try:
                        while not stop.is_set():
                            yield stream.next()
                    except StreamEnded as exc:
                        exc.is_file, exc.frames, exc.commanded = stream.is_file, stream.frames_read, seq > 0
                        exc.subject = observer.subject if observer is not None else None
                        raise

                source_frames = frames()
                first: list[np.ndarray] = []
                if subject == "auto":
                    assert hands is not None  # made above for "auto"
                    for f in source_frames:
                        first.append(f)
                        if len(first) == AUTO_FRAMES:
                            break
                    subject = choose_subject(first, hands)
                    observer = hands if subject == "hand" else LiveObserver(rule.window)
                    log.write(Subject(subject, "auto", len(first)))
                else:
                    observer = hands if hands is not None else LiveObserver(rule.window)
                    log.write(Subject(subject, "given"))
                for frame in itertools.chain(first, source_frames):
                    obs = observer.observe(frame)
                    log.missing(observer.missing)
                    if obs is None:
                        continue
                    now = time.monotonic()
                    why = switch.update(obs, now)
                    if why is None:
                        continue
                    try:  # the first observation fixes the image -> domain map (the launcher places the swarm from it)
                        shown = transform or transform_for(obs.mask, n_agents, controller_of(controller))
                        cmd = build_command(obs, shown, n_agents, controller, seq=seq + 1)
                        seen = seen_note(obs, seq + 1) if transform is None else None
                    except (ShapeError, ValueError) as exc:  # a silhouette the swarm cannot take: wait
                        log.missing(f"no shape the swarm can take: {exc}")
                        continue
                    transform = shown
                    seq += 1
                    switch.commit(obs, now)
                    payload = cmd.encode(secret)
                    current.append(payload)
                    del current[:-1]
                    pub.put(payload)
                    if seen is not None:  # before its command's note: the launcher waits for it to place the swarm
                        log.write(seen)
                    log.write(Commanded(seq, obs.label, why, obs.mask))
                    if seq == 1 and started is not None and stream.is_file:
                        stream.hold()
                        started.wait(HOLD_SECONDS)
                        stream.play()
        finally:
            done.set()
            republisher.join()


@contextlib.contextmanager
def _said_how_a_file_ended(source: str, log: EventLog) -> Iterator[None]:
    """A video file's end inside: its End note, and a StreamError saying why when it ended before anything was
    commanded (the last reason logged, "no hand found: ..."). A live stream's end goes on as it is."""
    try:
        yield
    except StreamEnded as exc:
        if not getattr(exc, "is_file", False):
            raise
        log.write(End(exc.frames))
        if not exc.commanded:  # say why: the last reason logged ("no hand found: ...")
            raise StreamError(
                f"camera {source}: the video ended after {exc.frames} frames without a "
                f"{exc.subject or 'hand or person'} seen" + (f" ({log.last})" if log.last else "")
            ) from None
