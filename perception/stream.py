"""Frames as they come from a camera, a network stream or a video file (OpenCV VideoCapture).

A reader thread takes frames off the source as fast as it delivers them (a video file: at its own frame
rate, as a camera would) and keeps only the newest; `FrameStream.next` hands that one out, at most `fps`
times per second, so a slow observer skips frames instead of falling behind the person it watches.

Every problem is a `StreamError` naming the source: it cannot be opened, it ended, or it stalled (no new
frame for `stall_seconds`).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Self

import cv2
import numpy as np

from perception.io import MAX_PIXELS, InputError

FILE_FPS_DEFAULT = 25.0  # a video file that does not say its frame rate is played at this


class StreamError(InputError):
    """The camera / stream cannot be used any more; the message names it and says why."""


class StreamEnded(StreamError):
    """The source ended. A video file ends so at its last frame (`FrameStream.is_file`): a normal end.
    The camera's coordinator adds what it had seen (coordinator/camera.py) before it re-raises."""

    is_file: bool = False
    frames: int = 0
    commanded: bool = False
    subject: str | None = None


@dataclass(frozen=True)
class StreamParams:
    """fps [1/s]: at most this many frames observed per second; stall_seconds [s]: no new frame for this
    long is a stalled stream; open_seconds [s]: how long opening a network stream may take."""

    fps: float = 5.0
    stall_seconds: float = 5.0
    open_seconds: float = 10.0

    def __post_init__(self) -> None:
        if not 0 < self.fps <= 120:
            raise ValueError(f"fps must be in (0, 120], got {self.fps}")
        if not 0 < self.stall_seconds < 3600 or not 0 < self.open_seconds < 3600:
            raise ValueError("stall_seconds and open_seconds must be in (0, 3600)")


def _is_url(source: str) -> bool:
    return "://" in source


def open_capture(source: str, params: StreamParams) -> tuple[cv2.VideoCapture, bool]:
    """(the opened capture, whether it is a file). DEVICE is a number or /dev/videoN; URL has a scheme."""
    ms = int(params.open_seconds * 1000)
    if source.isdigit():
        cap, is_file = cv2.VideoCapture(int(source)), False
    elif _is_url(source):
        cap = cv2.VideoCapture(
            source, cv2.CAP_FFMPEG, [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, ms, cv2.CAP_PROP_READ_TIMEOUT_MSEC, ms]
        )
        is_file = False
    else:
        path = Path(source)
        if not path.exists():
            raise StreamError(f"camera {source}: no such device or file")
        is_file = path.is_file()
        cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        cap.release()
        raise StreamError(f"camera {source}: cannot be opened (unreachable, busy or not a video)")
    w, h = cap.get(cv2.CAP_PROP_FRAME_WIDTH), cap.get(cv2.CAP_PROP_FRAME_HEIGHT)
    if w * h > MAX_PIXELS:
        cap.release()
        raise StreamError(f"camera {source}: frames too large ({int(w)} x {int(h)})")
    return cap, is_file


class FrameStream:
    """The newest frame of `source`, at most `params.fps` times per second. Use as a context manager."""

    def __init__(self, source: str, params: StreamParams = StreamParams()):
        self.source, self.params = str(source), params
        self._cap, self._is_file = open_capture(self.source, params)
        self._lock = threading.Condition()
        self._frame: np.ndarray | None = None
        self._count = 0  # frames read off the source
        self._taken = 0  # the count at the last frame handed out
        self._ended = False
        self._last_arrival = time.monotonic()
        self._closing = threading.Event()
        self._playing = threading.Event()  # a file's playback runs while set (hold / play)
        self._playing.set()
        self._next_due = 0.0
        self._thread = threading.Thread(target=self._read, name=f"FrameStream[{self.source}]", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        period = 0.0
        if self._is_file:  # a file plays at its own rate, as the camera that recorded it did
            fps = self._cap.get(cv2.CAP_PROP_FPS)
            period = 1.0 / (fps if 0 < fps <= 1000 else FILE_FPS_DEFAULT)
        t0 = time.monotonic()
        while not self._closing.is_set():
            if not self._playing.is_set():  # held: the file's clock stops with it
                held = time.monotonic()
                while not self._playing.wait(0.1) and not self._closing.is_set():
                    pass
                t0 += time.monotonic() - held
                with self._lock:
                    self._last_arrival = time.monotonic()
            ok, frame = self._cap.read()
            now = time.monotonic()
            with self._lock:
                if not ok or frame is None:
                    self._ended = True
                    self._lock.notify_all()
                    return
                self._frame, self._count, self._last_arrival = frame, self._count + 1, now
                self._lock.notify_all()
            if period:
                self._closing.wait(max(0.0, t0 + self._count * period - time.monotonic()))

    def hold(self) -> None:
        """A video file stops playing (e.g. until the swarm it drives has started); no-op for live sources."""
        if self._is_file:
            self._playing.clear()

    def play(self) -> None:
        """A held video file plays on from where it stopped."""
        with self._lock:
            self._last_arrival = time.monotonic()  # held is not stalled
        self._playing.set()

    @property
    def is_file(self) -> bool:
        return self._is_file

    @property
    def frames_read(self) -> int:
        return self._count

    def next(self) -> np.ndarray:
        """The newest frame not handed out yet, no sooner than 1/fps s after the previous one. Raises
        StreamError when the source ended or stalled."""
        now = time.monotonic()
        if now < self._next_due:
            self._closing.wait(self._next_due - now)
        with self._lock:
            while self._count == self._taken:
                if self._ended:
                    raise StreamEnded(f"camera {self.source}: the stream ended after {self._count} frames")
                silent = time.monotonic() - self._last_arrival
                if silent >= self.params.stall_seconds:
                    raise StreamError(f"camera {self.source}: the stream stalled (no frame for {silent:.1f} s)")
                self._lock.wait(min(0.1, self.params.stall_seconds - silent))
            self._taken = self._count
            frame = self._frame
            assert frame is not None  # a frame arrived (_count moved past _taken)
        self._next_due = max(now, self._next_due) + 1.0 / self.params.fps
        return frame

    def close(self) -> None:
        self._closing.set()
        self._playing.set()
        # A read blocked on a stalled network stream cannot be interrupted; the thread is a daemon.
        self._thread.join(1.0)
        if not self._thread.is_alive():
            self._cap.release()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
