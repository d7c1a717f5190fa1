"""`--ros2`: the run as a ROS 2 node, inside the recorder process (docs/ros2.md).

The recorder already has every step whole (fluidswarm/recording/steps.py) and every target, command and event
(fluidswarm/recording/writer.py): it hands each to `Bridge` (its `tap`), which queues it and returns at once.
One thread of the bridge turns them into ROS 2 messages (fluidswarm/recording/ros2_messages.py) and publishes them from
the node `/fluidswarm` (ros2link/node.py) on the ROS 2 system's router.

A router that is absent at start or lost mid-run is one line (`note`); the recording never waits for the ROS 2
side: a full queue drops the newest item (counted), a lost router's puts go nowhere, closing takes at most a
few seconds.
"""

from __future__ import annotations

import json
import queue
import threading
from collections.abc import Callable

import numpy as np

from agent.sph.obstacles import Obstacle
from agent.sph.particle import HEADING, RHO, VX, VY, P, X, Y
from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording import ros2_messages as m
from ros2link import cdr
from ros2link.node import Node

# How far the recorder may be ahead of the bridge before what it hands over is dropped (counted): steps (one
# item a step, N rows: the memory) and everything (events are many and small: 300 `started` at a run's start)
STEPS_AHEAD = 64
QUEUE = 4096
OPEN_SECONDS = 5.0  # s to reach the ROS 2 router at start
WATCH_SECONDS = 1.0  # s between two looks at the router connection
_STOP = ("stop",)


class Bridge:
    """Publish a run on ROS 2. `unicycle`: the agents' state rows carry a heading (agent/sph/robot.py);
    `note(line)`: says what the user must know (an absent or lost router), one line each time."""

    def __init__(self, endpoint: str, domain: int, unicycle: bool, note: Callable[[str], None]):
        self.endpoint, self.domain, self.unicycle, self.note = endpoint, domain, unicycle, note
        self.node = Node(endpoint, domain)
        self.inbox: queue.Queue = queue.Queue(QUEUE)
        self.dropped = 0
        self.published = 0
        self._target: list[np.ndarray] = []
        self._obstacles: list[np.ndarray] = []
        # steps handed over and steps taken off the queue: each counted by one thread only (no lock needed)
        self._handed = self._taken = 0
        self._thread = threading.Thread(target=self._run, name="ros2-bridge", daemon=True)

    def start(self) -> None:
        self._thread.start()

    # --- what the recorder hands over (its thread; never blocks) ------------------------------------------

    def _put(self, item: tuple) -> bool:
        try:
            self.inbox.put_nowait(item)
            return True
        except queue.Full:
            self.dropped += 1
            return False

    def states(self, step: int, t: float, ids: np.ndarray, vals: np.ndarray) -> None:
        """One step's rows (agent/sph/particle.py layout), in `ids` order."""
        if self._handed - self._taken >= STEPS_AHEAD:
            self.dropped += 1
        elif self._put(("states", step, t, np.array(ids, dtype=np.int64), np.array(vals, dtype=float))):
            self._handed += 1

    def target(self, t: float, mask: np.ndarray, transform: ImageToDomain) -> None:
        self._put(("target", t, m.outline_loops(mask, transform)))

    def obstacles(self, t: float, obstacles: tuple[Obstacle, ...]) -> None:
        self._put(("obstacles", t, m.obstacle_loops(tuple(obstacles))))

    def command(self, t: float, text: str) -> None:
        self._put(("command", t, m.command_text(json.loads(text))))

    def image(self, t: float, data: bytes, fmt: str, frame: str) -> None:
        self._put(("image", t, m.compressed_image(t, data, fmt, frame)))

    def event(self, t: float, level, name: str, message: str, kind=None, agent=None, step=None) -> None:
        if name != "ros2":  # its own notes are for the MCAP and the user, not echoed onto ROS 2
            self._put(("event", t, m.event_text(level, name, message, kind, agent, step)))

    def close(self, timeout: float = 5.0) -> None:
        """Publish what is queued (within `timeout` s), withdraw the node, close the session."""
        try:
            self.inbox.put(_STOP, timeout=timeout)
        except queue.Full:
            pass
        if self._thread.is_alive():
            self._thread.join(timeout)
        if self.dropped:
            self.note(f"ros2: {self.dropped} items not published (the ROS 2 side fell behind the recorder)")

    # --- the bridge's thread -------------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            self.node.open(OPEN_SECONDS)
            pubs = {t.name: self.node.publisher(t.name, t.msgtype, cdr.type_hash(t.msgtype), t.qos) for t in m.TOPICS}
        except Exception as exc:  # noqa: BLE001  # zenoh's error for an unreachable router; the run goes on
            self.node.close()
            self.note(f"ros2: no ROS 2 router at {self.endpoint} ({exc}); the run goes on without ROS 2")
            while (item := self.inbox.get()) is not _STOP:  # keep the recorder's hand-overs from filling the queue
                if item[0] == "states":
                    self._taken += 1
            return
        try:
            connected = True
            while True:
                try:
                    item = self.inbox.get(timeout=WATCH_SECONDS)
                except queue.Empty:
                    item = None
                if item is _STOP:
                    break
                now = self.node.connected()
                if now != connected:
                    connected = now
                    self.note(
                        f"ros2: the ROS 2 router at {self.endpoint} is back"
                        if now
                        else f"ros2: lost the ROS 2 router at {self.endpoint}; the run goes on"
                    )
                if item is not None:
                    self._publish(pubs, item)
        finally:
            self.node.close()

    def _publish(self, pubs: dict, item: tuple) -> None:
        kind, t = item[0], item[2] if item[0] == "states" else item[1]
        if kind == "states":
            self._taken += 1
            _, _step, t, ids, vals = item
            xy = vals[:, [X, Y]]
            yaw = m.headings(vals[:, [VX, VY]], vals[:, HEADING] if self.unicycle else None)
            pubs[m.CLOCK].put(m.clock(t))
            pubs[m.POSES].put(m.poses(t, ids, xy, yaw))
            pubs[m.TF].put(m.transforms(t, ids, xy, yaw))
            pubs[m.PARTICLES].put(m.particles(t, ids, xy, vals[:, RHO], vals[:, P]))
        elif kind in ("target", "obstacles"):
            if kind == "target":
                self._target = item[2]
            else:
                self._obstacles = item[2]
            pubs[m.TARGET].put(m.markers(t, self._target, self._obstacles))
        elif kind == "command":
            pubs[m.COMMAND].put(m.text(item[2]))
        elif kind == "event":
            pubs[m.EVENTS].put(m.text(item[2]))
        elif kind == "image":
            pubs[m.IMAGE].put(item[2])
        self.published += 1
