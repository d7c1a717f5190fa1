"""`imitate --camera ros2:/camera/image_raw`: a ROS 2 camera topic as the coordinator's live source (docs/ros2.md).

`Ros2FrameStream` is perception/stream.py's `FrameStream` for a topic: the same `next` (the newest frame, at most
`fps` a second, a stall after `stall_seconds` without one), the same errors (`StreamError` naming the source and
the problem). It joins the ROS 2 graph as the node `/fluidswarm_camera` (ros2link/node.py), finds the
topic's publishers by their liveliness tokens, and subscribes to the key they name, with its own subscriber
token (MS: without one `ros2 topic pub` and many drivers wait for a match forever).

Every sample is untrusted: it needs rmw_zenoh's attachment (rmw_zenoh drops a sample without one, so does this),
a CDR payload that decodes as the announced type, a supported encoding (Image: rgb8, bgr8, rgba8, bgra8, mono8;
CompressedImage: what OpenCV decodes) and a size within perception/io.py's MAX_PIXELS. A sample that fails is
counted and dropped; an unsupported encoding or a picture too large is the stream's error (the camera sends
nothing else).
"""

from __future__ import annotations

import threading
import time
from typing import Self

import cv2
import numpy as np

from perception.io import MAX_PIXELS
from perception.stream import StreamError, StreamParams
from ros2link import cdr, rmw
from ros2link.node import Node

PREFIX = "ros2:"
IMAGE, COMPRESSED = "sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage"
# encoding -> (channels, OpenCV conversion to BGR or None)
ENCODINGS = {
    "bgr8": (3, None),
    "rgb8": (3, cv2.COLOR_RGB2BGR),
    "bgra8": (4, cv2.COLOR_BGRA2BGR),
    "rgba8": (4, cv2.COLOR_RGBA2BGR),
    "mono8": (1, cv2.COLOR_GRAY2BGR),
}
# A camera driver's subscribers take sensor-data QoS (best effort, keep last 5); it matches any publisher.
CAMERA_QOS = rmw.Qos(rmw.BEST_EFFORT, rmw.VOLATILE, rmw.KEEP_LAST, 5)


def is_ros2_source(source: str) -> bool:
    return source.startswith(PREFIX)


def image_to_bgr(msg) -> np.ndarray:
    """A sensor_msgs/Image as a BGR picture; ValueError naming what is wrong with it."""
    encoding = str(msg.encoding).lower()
    if encoding not in ENCODINGS:
        raise ValueError(f"encoding {msg.encoding!r} is not supported ({', '.join(ENCODINGS)})")
    channels, conversion = ENCODINGS[encoding]
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    if h < 1 or w < 1 or h * w > MAX_PIXELS:
        raise ValueError(f"a {w} x {h} picture is empty or too large")
    data = np.asarray(msg.data, dtype=np.uint8)
    if step < w * channels or data.size < step * h:
        raise ValueError(f"{data.size} bytes do not hold {h} rows of {step} bytes ({w} x {channels} used)")
    rows = data[: step * h].reshape(h, step)[:, : w * channels].reshape(h, w, channels)
    return np.ascontiguousarray(rows) if conversion is None else cv2.cvtColor(rows, conversion)


def compressed_to_bgr(msg) -> np.ndarray:
    """A sensor_msgs/CompressedImage as a BGR picture; ValueError if it is not one OpenCV decodes."""
    data = np.asarray(msg.data, dtype=np.uint8)
    frame = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    if frame is None:
        raise ValueError(f"its {data.size} bytes ({msg.format!r}) are not a picture")
    if frame.shape[0] * frame.shape[1] > MAX_PIXELS:
        raise ValueError(f"a {frame.shape[1]} x {frame.shape[0]} picture is too large")
    return frame


class Ros2FrameStream:
    """The newest picture on the ROS 2 topic of `source` (`ros2:/a/b`), through the router at `router` on domain
    `domain`. Use as a context manager."""

    def __init__(self, source: str, params: StreamParams, router: str, domain: int):
        self.source, self.params = source, params
        self.topic = source[len(PREFIX) :]
        if not rmw.valid_topic(self.topic):
            raise StreamError(
                f"camera {source}: {self.topic!r} is not a ROS 2 topic name (e.g. ros2:/camera/image_raw)"
            )
        self._lock = threading.Condition()
        self._frame: np.ndarray | None = None
        self._count = self._taken = 0
        self._error: str | None = None
        self.rejected = 0
        self._last_arrival = time.monotonic()
        self._next_due = 0.0
        self.node = Node(router, domain, name="fluidswarm_camera")
        try:
            self._open(router, domain)
        except BaseException:
            self.node.close()
            raise

    def _open(self, router: str, domain: int) -> None:
        try:
            self.node.open(self.params.open_seconds)
        except Exception as exc:  # noqa: BLE001  # zenoh's error for an unreachable router
            raise StreamError(f"camera {self.source}: no ROS 2 router at {router} ({exc})") from None
        deadline = time.monotonic() + self.params.open_seconds
        publishers = self.node.publishers_of(self.topic, 1.0)
        while not publishers and time.monotonic() < deadline:
            time.sleep(0.2)
            publishers = self.node.publishers_of(self.topic, 1.0)
        if not publishers:
            raise StreamError(
                f"camera {self.source}: nobody publishes {self.topic} on ROS 2 domain {domain} (router {router}, "
                f"{self.params.open_seconds:.0f} s)"
            )
        types = sorted({p.msgtype for p in publishers})
        usable = [p for p in publishers if p.msgtype in (IMAGE, COMPRESSED)]
        if not usable:
            raise StreamError(
                f"camera {self.source}: {self.topic} carries {', '.join(types)}, not {IMAGE} or {COMPRESSED}"
            )
        self.msgtype = usable[0].msgtype
        # the key its publishers name (their type hash: a camera of another ROS 2 release still matches)
        for type_hash in sorted({p.type_hash for p in usable if p.msgtype == self.msgtype}):
            self.node.subscriber(self.topic, self.msgtype, type_hash, CAMERA_QOS, self._on_sample)
        self._last_arrival = time.monotonic()

    def _on_sample(self, sample) -> None:
        """Zenoh's thread: check and decode one sample; the newest good picture is kept."""
        attachment = sample.attachment.to_bytes() if sample.attachment is not None else None
        try:
            if rmw.parse_attachment(attachment) is None:
                raise ValueError("no rmw_zenoh attachment")
            msg = cdr.deserialize(sample.payload.to_bytes(), self.msgtype)
        except Exception:  # noqa: BLE001  # untrusted bytes: anything that does not decode is dropped, counted
            with self._lock:
                self.rejected += 1
            return
        try:
            frame = image_to_bgr(msg) if self.msgtype == IMAGE else compressed_to_bgr(msg)
        except ValueError as exc:
            with self._lock:
                self._error = f"camera {self.source}: {exc}"
                self._lock.notify_all()
            return
        with self._lock:
            self._frame, self._count, self._last_arrival = frame, self._count + 1, time.monotonic()
            self._lock.notify_all()

    # --- FrameStream's interface -------------------------------------------------------------------------

    @property
    def is_file(self) -> bool:
        return False

    @property
    def frames_read(self) -> int:
        return self._count

    def hold(self) -> None:
        """A live source: nothing to hold."""

    def play(self) -> None:
        with self._lock:
            self._last_arrival = time.monotonic()

    def next(self) -> np.ndarray:
        """The newest picture not handed out yet, no sooner than 1/fps s after the previous one. Raises
        StreamError for a picture it cannot use or a stall."""
        now = time.monotonic()
        if now < self._next_due:
            time.sleep(self._next_due - now)
        with self._lock:
            while self._count == self._taken:
                if self._error is not None:
                    raise StreamError(self._error)
                silent = time.monotonic() - self._last_arrival
                if silent >= self.params.stall_seconds:
                    raise StreamError(
                        f"camera {self.source}: the stream stalled (no picture for {silent:.1f} s"
                        + (f", {self.rejected} samples dropped as malformed" if self.rejected else "")
                        + ")"
                    )
                self._lock.wait(min(0.1, self.params.stall_seconds - silent))
            self._taken = self._count
            frame = self._frame
            assert frame is not None
        self._next_due = max(now, self._next_due) + 1.0 / self.params.fps
        return frame

    def close(self) -> None:
        self.node.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
