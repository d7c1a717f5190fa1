"""`RunWriter`: the one thin MCAP writer of a run (chunked, zstd-compressed, indexed, Foxglove-ready).

The recorder process calls it; so can a centralised simulation. Topics mirror the Zenoh key expressions
(`fluidswarm/<run>/state`, ...); see docs/recording.md for every topic, schema and metadata record.

Times `t` are the run's simulated time in seconds (>= 0): they become the MCAP log time (ns) and the
Foxglove timestamps, and `check` compares event and state times on that one clock.

Interruption: `write_*` validate and encode in the caller's thread, then queue the record for one
writer thread, the only code that touches the MCAP writer. So a KeyboardInterrupt or SystemExit raised
by a signal handler can never leave a chunk half-written; `close()` (idempotent, safe from signal
handlers and any thread) queues the end and waits until the summary and footer are on disk. If the
program exits without `close()`, the writer thread finishes the file when the main thread is gone.
Writes after `close()` are dropped and return False (late subscriber callbacks during shutdown).
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import queue
import subprocess
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Self

import numpy as np
from mcap.writer import CompressionType, IndexType, Writer

from agent.protocol.errors import SwarmFailed
from agent.sph.obstacles import Obstacle
from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording import messages as msg
from fluidswarm.recording import schemas as sc

JSON_KEYS = "fluidswarm.json_keys"  # metadata entry listing the keys whose values are JSON text
_STOP = object()  # end of the writer thread's queue
# s: the longest a written message waits in the chunk in progress before the chunk reaches the file. A chunk per
# 0.5 s costs some compression (zstd works per chunk) and one small write; a killed recorder keeps all but the last
# ~0.5 s it had written (plus what it had not yet written: steps wait for their last agent, recording/steps.py).
FLUSH_SECONDS = 0.5


def code_version() -> str:
    """`git describe --always --dirty --tags` of the source tree, else the installed package version."""
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(
            ["git", "-C", str(here), "describe", "--always", "--dirty", "--tags"],
            capture_output=True,
            text=True,
            timeout=5,
            check=True,
        )
        if out.stdout.strip():
            return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    try:
        return importlib.metadata.version("fluidswarm")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def encode_metadata(values: dict) -> dict[str, str]:
    """MCAP metadata is str -> str: strings are kept, anything else is JSON text listed under JSON_KEYS."""
    out, json_keys = {}, []
    for key, value in values.items():
        if not isinstance(key, str) or not key:
            raise ValueError(f"metadata keys must be non-empty strings, got {key!r}")
        if isinstance(value, str):
            out[key] = value
        else:
            out[key] = json.dumps(value, sort_keys=True)
            json_keys.append(key)
    if json_keys:
        out[JSON_KEYS] = json.dumps(json_keys)
    return out


def _dumps(obj: dict) -> bytes:
    return json.dumps(obj, separators=(",", ":"), allow_nan=False).encode()


class RunWriter:
    """Write one run to `path`. `metadata` goes to the MCAP metadata record `run` (see `encode_metadata`);
    its `run` entry names the run in the topics (default: the file's stem); `code_version` is added."""

    def __init__(
        self,
        path: str | os.PathLike,
        metadata: dict,
        *,
        chunk_size: int = 512 * 1024,
        live=None,
        flush_seconds: float = FLUSH_SECONDS,
        tap=None,
    ):
        """`live` (recording.live.LiveServer or None): also gets every message, as it is written;
        `flush_seconds`: the chunk in progress reaches the file at least this often (FLUSH_SECONDS); `tap`
        (ros2_bridge.Bridge or None): also handed each target, obstacle set, command, event and image
        (and, by the recorder, each step)."""
        meta = dict(metadata)
        self.run = str(meta.get("run") or Path(path).stem)
        if not self.run or any(c in self.run for c in "/*$?#") or self.run.strip() != self.run:
            raise ValueError(f"run name {self.run!r} cannot be a Zenoh key chunk")
        meta["run"] = self.run
        meta.setdefault("code_version", code_version())
        self.path = Path(path)
        self._queue: queue.SimpleQueue = queue.SimpleQueue()  # put() is reentrant: safe in signal handlers
        self._closing = False
        self._error: BaseException | None = None
        self._stream = open(self.path, "wb")  # noqa: SIM115  # closed by the writer thread when it ends
        self._mcap = Writer(
            self._stream,
            chunk_size=chunk_size,
            compression=CompressionType.ZSTD,
            index_types=IndexType.ALL,
            use_chunking=True,
            use_statistics=True,
            use_summary_offsets=True,
        )
        self._mcap.start(profile="", library=f"fluidswarm {meta['code_version']}")
        self._channels: dict[str, int] = {}
        self._schema_ids: dict[str, int] = {}
        self._targets = 0
        self._live = live
        self.tap = tap
        self._mcap.add_metadata("run", encode_metadata(meta))
        self._flush_seconds = float(flush_seconds)
        self._mcap.flush()  # the header and the run's metadata: a file killed at once is still an MCAP file
        self._unflushed = False
        self._thread = threading.Thread(target=self._drain, name=f"RunWriter[{self.path.name}]", daemon=False)
        self._thread.start()

    # --- life cycle ---------------------------------------------------------------------------------

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def closed(self) -> bool:
        """True once the file is finished."""
        return not self._thread.is_alive()

    def close(self) -> None:
        """Finish the file (summary, indexes, footer) and wait for it. Idempotent; safe to call from a
        signal handler or any thread. Raises RuntimeError if writing the file failed."""
        if not self._closing:
            self._closing = True
            self._queue.put(_STOP)
        if threading.current_thread() is not self._thread:
            self._thread.join()
        self._raise_if_failed()

    def _raise_if_failed(self) -> None:
        if self._error is not None:
            raise SwarmFailed(f"recording to {self.path} failed: {self._error}") from self._error

    def _drain(self) -> None:
        """The writer thread: the only code that touches the MCAP writer, so an exception raised in the
        main thread by a signal handler can never leave a chunk half-written."""
        try:
            flushed = time.monotonic()
            while True:
                left = flushed + self._flush_seconds - time.monotonic()
                try:
                    op = self._queue.get(timeout=max(0.0, min(left, 0.2)) if self._unflushed else 0.2)
                except queue.Empty:
                    op = None
                    if not threading.main_thread().is_alive():  # interpreter exiting without close()
                        break
                if op is _STOP:
                    break
                if op is not None:
                    if not self._unflushed:
                        # the flush period runs from the oldest unflushed record, not from the last idle
                        # wake-up (up to 0.2 s stale): else a record arriving after a quiet spell was
                        # flushed alone at once, and the chunk's contents depended on the idle timer
                        flushed = time.monotonic()
                    op()
                    self._unflushed = True
                if self._unflushed and time.monotonic() - flushed >= self._flush_seconds:
                    # the chunk in progress (if any) and every record before it, into the kernel's hands
                    self._mcap.flush()
                    self._unflushed = False
                    flushed = time.monotonic()
        except BaseException as exc:  # noqa: BLE001  # reported by close() and the next write
            self._error = exc
        finally:
            try:
                self._mcap.finish()
                self._stream.flush()
                os.fsync(self._stream.fileno())
            except BaseException as exc:  # noqa: BLE001  # reported by close(), as the first error is
                self._error = self._error or exc
            finally:
                self._stream.close()

    def _submit(self, op: Callable[[], None]) -> bool:
        if self._closing:
            return False
        self._raise_if_failed()
        self._queue.put(op)
        return True

    def _write(self, leaf: str, t: float, payload: dict, sequence: int = 0, latch: str | None = None) -> bool:
        log_time = sc.seconds_to_ns(t)
        data = _dumps(payload)

        def op() -> None:
            self._mcap.add_message(
                self._channel(leaf), log_time=log_time, data=data, publish_time=log_time, sequence=sequence & 0xFFFFFFFF
            )

        if not self._submit(op):
            return False
        if self._live is not None:  # latch: kept for viewers that connect later (recording/live.py)
            self._live.publish(leaf, data, log_time, latch)
        return True

    def _channel(self, leaf: str) -> int:
        if leaf not in self._channels:
            name = sc.TOPIC_SCHEMAS[leaf]
            if name not in self._schema_ids:
                self._schema_ids[name] = self._mcap.register_schema(name, sc.SCHEMA_ENCODING, sc.schema_bytes(name))
            self._channels[leaf] = self._mcap.register_channel(
                sc.topic(self.run, leaf), sc.MESSAGE_ENCODING, self._schema_ids[name]
            )
        return self._channels[leaf]

    # --- messages (built in messages.py) -------------------------------------------------------------

    def write_states(
        self, step: int, t: float, ids, positions, velocities, density, pressure, class_ids, alive=None
    ) -> bool:
        """All particle states of one step on `fluidswarm/<run>/state` (messages.state_cloud); the step
        number is the MCAP message sequence."""
        return self._write(
            sc.STATE,
            t,
            msg.state_cloud(step, t, ids, positions, velocities, density, pressure, class_ids, alive),
            sequence=int(step),
        )

    def write_scene(
        self, t: float, waypoints: Iterable[Sequence[float]] = (), ellipses: Iterable[Sequence[float]] = ()
    ) -> bool:
        """Waypoints and ellipses on `fluidswarm/<run>/scene` (messages.scene_update), replacing the last."""
        return self._write(sc.SCENE, t, msg.scene_update(t, waypoints, ellipses))

    def write_target(self, t: float, mask: np.ndarray, transform: ImageToDomain) -> bool:
        """Store the target silhouette `mask` (image pixels) and the `transform` the controller uses, as
        attachment `target/<k>.png` plus metadata record `target/<k>`, and draw its outline in the scene.
        The last target written is the one `replay` scores fidelity against."""
        payload, png = msg.target_outline(t, mask, transform)
        mask = np.asarray(mask).astype(bool)
        log_time = sc.seconds_to_ns(t)

        def op() -> None:
            name = f"target/{self._targets}"
            self._targets += 1
            self._mcap.add_attachment(
                create_time=log_time, log_time=log_time, name=f"{name}.png", media_type="image/png", data=png
            )
            self._mcap.add_metadata(
                name,
                encode_metadata(
                    {
                        "t": float(t),
                        "attachment": f"{name}.png",
                        "rows": mask.shape[0],
                        "cols": mask.shape[1],
                        **transform.as_dict(),
                    }
                ),
            )

        if not self._submit(op):
            return False
        if self.tap is not None:
            self.tap.target(t, mask, transform)
        return self._write(sc.SCENE, t, payload, latch="target")

    def write_obstacles(self, t: float, obstacles: Sequence[Obstacle]) -> bool:
        """The domain's obstacles as the scene's entity `obstacles` (messages.obstacle_outlines), sent again
        to a live viewer that connects later."""
        if self.tap is not None:
            self.tap.obstacles(t, tuple(obstacles))
        return self._write(sc.SCENE, t, msg.obstacle_outlines(t, obstacles), latch="obstacles")

    def write_bodies(self, t: float, centres, headings, radius: float) -> bool:
        """The robots' bodies (and headings) as the scene's entity `bodies` (messages.body_entities), replacing
        the last."""
        return self._write(sc.SCENE, t, msg.body_entities(t, centres, headings, radius))

    def write_fidelity(self, fidelity, gesture: str | None = None) -> bool:
        """The final formation's score (fidelity_iou, fidelity_inside, fidelity_coverage, nn_cv) as metadata
        record `fidelity`, so a file carries its own verdict (issue 15) without re-scoring; `gesture`: the
        gesture of the target scored (the last written), as `fidelity_gesture`."""
        values: dict = {
            "fidelity_iou": float(fidelity.iou),
            "fidelity_inside": float(fidelity.inside),
            "fidelity_coverage": float(fidelity.coverage),
            "nn_cv": float(fidelity.nn_cv),
        }
        if gesture is not None:
            values["fidelity_gesture"] = str(gesture)
        return self._submit(lambda: self._mcap.add_metadata("fidelity", encode_metadata(values)))

    def write_timing(self, values: dict) -> bool:
        """How the run kept time as the recorder saw it (`realtime_factor`: simulated seconds / wall seconds
        between the first and the last step it saw, steps_seen) as metadata record `timing`."""
        return self._submit(lambda: self._mcap.add_metadata("timing", encode_metadata(values)))

    def write_robots(self, figures: dict) -> bool:
        """What a robot user measures (fluidswarm/recording/contacts.py: robot, radius_m, collisions,
        min_separation_m; among obstacles also obstacles, obstacle_penetrations, min_obstacle_distance_m) as
        metadata record `robots`."""
        return self._submit(lambda: self._mcap.add_metadata("robots", encode_metadata(figures)))

    def write_command(self, t: float, command_json: str) -> bool:
        """A gesture command (a JSON object, as published) on `fluidswarm/<run>/command`."""
        try:
            command = json.loads(command_json)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"command is not JSON: {exc}") from None
        if not isinstance(command, dict):
            raise ValueError("command must be a JSON object")  # noqa: TRY004  # one error type for bad commands
        if self.tap is not None:
            self.tap.command(t, command_json)
        return self._write(sc.COMMAND, t, command)

    def write_image(self, t: float, jpeg_bytes: bytes, frame_id: str = "camera", fmt: str = "jpeg") -> bool:
        """The perception input on `fluidswarm/<run>/perception/image` (messages.compressed_image)."""
        if self.tap is not None:
            self.tap.image(t, jpeg_bytes, fmt, frame_id)
        return self._write(sc.IMAGE, t, msg.compressed_image(t, jpeg_bytes, frame_id, fmt), latch=f"image/{frame_id}")

    def write_event(
        self,
        t: float,
        level: int | str,
        name: str,
        message: str,
        *,
        kind: str | None = None,
        agent: int | None = None,
        step: int | None = None,
    ) -> bool:
        """A `foxglove.Log` on `fluidswarm/<run>/event` (messages.event_log: level, kind, agent, step)."""
        payload = msg.event_log(t, level, name, message, kind=kind, agent=agent, step=step)
        if self.tap is not None:
            self.tap.event(t, level, name, message, kind, agent, step)
        return self._write(sc.EVENTS, t, payload)
