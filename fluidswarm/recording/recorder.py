"""The recorder: a passive Zenoh process that writes a run to one MCAP file (docs/recording.md).

It subscribes to the run's keys — every state (`state/**`), the agents' liveliness (`alive/*`) and events,
the gesture command — and never publishes anything but its own readiness token. States are grouped by
step and a step is written as one message once every agent alive at that step has reported, or once the
run is far enough past it (then the missing agents get a `froze` event and count as stopped; a later
state of theirs gives a `started` event). A killed agent's last state is written before its `died` event.
SIGINT/SIGTERM finish the file (pending steps flushed, MCAP footer written).

With `--live HOST:PORT` it also serves the run to Foxglove as it happens (recording/live.py).

`python -m fluidswarm.recording.recorder --connect tcp/... --run NAME --out FILE.mcap [--metadata JSON] [--live H:P]`
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import signal
import sys
import time

import numpy as np
import zenoh

from agent.protocol import keys
from agent.protocol.session import client_config
from agent.sph.particle import P, RHO, VX, VY, X, Y
from agent.protocol.wire import decode_state
from coordinator.control.fidelity import fidelity
from fluidswarm.recording.writer import RunWriter
from agent.protocol.errors import UserError
from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording.live import LiveServer, parse_address

RELEASE_SECONDS = 10.0  # a step is written this long after its first state even if some agent never reported
QUIET_SECONDS = 3.0  # ... or once nothing new came for this long


class Recorder:
    def __init__(self, run: str, writer: RunWriter, dt: float):
        self.run = run
        self.writer = writer
        self.dt = dt
        self.inbox: queue.SimpleQueue = queue.SimpleQueue()
        self.pending: dict[int, dict[int, tuple]] = {}
        self.alive: set[int] = set()
        self.stopped: set[int] = set()  # alive but not reporting (frozen): waiting for them is pointless
        # Late joiners: alive after the run began; they start at the step of their first state (they adopt
        # the swarm's step when they hear it), so the recorder expects them only from then on.
        self.joining: set[int] = set()
        self.last_step: dict[int, int] = {}
        self.last_positions: np.ndarray | None = None  # of the last step written (scored at the end)
        self.first_seen: dict[int, float] = {}
        self.dead_at: dict[int, int] = {}  # agent -> first step without its state (event not yet written)
        self.next_step = 0
        self.newest = -1
        self.rejected = 0
        self.last_message = time.monotonic()

    # callbacks: decode nothing, enqueue
    def on_state(self, sample) -> None:
        self.inbox.put((0, (sample.payload.to_bytes(), str(sample.key_expr))))

    def on_alive(self, sample) -> None:
        self.inbox.put((1, (str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)))

    def on_event(self, sample) -> None:
        self.inbox.put((2, (sample.payload.to_bytes(), str(sample.key_expr))))

    def on_command(self, sample) -> None:
        self.inbox.put((3, sample.payload.to_bytes()))

    def t(self, step: int) -> float:
        return max(step, 0) * self.dt

    def handle(self, item) -> None:
        kind, data = item
        self.last_message = time.monotonic()
        if kind == 0:
            data, key = data
            decoded, _reason = decode_state(data)
            # The key's id is the publisher's (the router's access control, docs/security.md); a record
            # naming another agent is a forgery.
            if decoded is None or decoded[0] != keys.id_from_key(key):
                self.rejected += 1
                return
            j, step, cls, values = decoded
            if step < self.next_step or step > self.newest + 100000:
                return  # already written (a late straggler) or absurd
            if j in self.joining:
                self.joining.discard(j)
                self.alive.add(j)
                self.writer.write_event(self.t(step), "info", f"agent/{j}", f"agent {j} joined at step {step}",
                                        kind="started", agent=j, step=step)
            if step not in self.pending:
                self.first_seen[step] = time.monotonic()
            self.pending.setdefault(step, {})[j] = (cls, values)
            self.newest = max(self.newest, step)
            self.last_step[j] = max(self.last_step.get(j, -1), step)
            if j in self.stopped:
                self.stopped.discard(j)
                self.writer.write_event(self.t(step), "info", f"agent/{j}", f"agent {j} reports again",
                                        kind="started", agent=j, step=step)
        elif kind == 1:
            key, up = data
            j = keys.id_from_key(key)
            if j is None:
                return
            if up:
                if j not in self.alive and self.newest >= 0 and j not in self.last_step:
                    self.joining.add(j)
                elif j not in self.alive:
                    self.alive.add(j)
                    self.writer.write_event(self.t(self.next_step), "info", f"agent/{j}", f"agent {j} started",
                                            kind="started", agent=j, step=self.next_step if self.newest >= 0 else 0)
            elif j in self.joining:
                self.joining.discard(j)
            elif j in self.alive:
                self.alive.discard(j)
                self.stopped.discard(j)
                # Its last state must be written before its death: the event waits for that step.
                self.dead_at[j] = self.last_step.get(j, self.next_step - 1) + 1
                self._write_deaths()
        elif kind == 2:
            data, key = data
            try:
                ev = json.loads(data)
                j, step, what = int(ev["id"]), int(ev["step"]), str(ev["event"])[:64]
            except (ValueError, KeyError, TypeError):
                self.rejected += 1
                return
            if j != keys.id_from_key(key):
                self.rejected += 1
                return
            if what != "started":  # lifecycle 'started' comes from liveliness, with its step
                level = "warning" if what in ("neighbour_timeout", "fell_behind") else "info"
                self.writer.write_event(self.t(step), level, f"agent/{j}", json.dumps(ev)[:2000], kind=what, agent=None)
        elif kind == 3:
            try:
                text = data.decode("utf-8")
                json.loads(text)
            except (UnicodeDecodeError, ValueError):
                self.rejected += 1
                return
            self.writer.write_command(self.t(self.next_step), text)

    def _write_deaths(self) -> None:
        for j, first_missing in list(self.dead_at.items()):
            if first_missing <= self.next_step:
                del self.dead_at[j]
                self.writer.write_event(self.t(first_missing), "warning", f"agent/{j}", f"agent {j} died",
                                        kind="died", agent=j, step=first_missing)

    def _expected_at(self, step: int) -> set[int]:
        dying = {j for j, s in self.dead_at.items() if step < s}
        return (self.alive | dying) - self.stopped

    def _ready(self, step: int) -> bool:
        have = self.pending.get(step, {})
        waiting = self._expected_at(step) - set(have)
        now = time.monotonic()
        return (not waiting or now - self.first_seen.get(step, now) >= RELEASE_SECONDS
                or now - self.last_message > QUIET_SECONDS)

    def _write_step(self, step: int) -> None:
        have = self.pending.pop(step, {})
        self.first_seen.pop(step, None)
        for j in self._expected_at(step) - set(have):
            if self.last_step.get(j, -1) < step:  # it stopped reporting: frozen or cut off
                self.stopped.add(j)
                self.writer.write_event(self.t(step), "warning", f"agent/{j}", f"agent {j} stopped reporting (frozen?)",
                                        kind="died", agent=j, step=step)
        if not have:
            return
        ids = np.array(sorted(have), dtype=np.int64)
        vals = np.array([have[j][1] for j in ids])
        cls = np.array([have[j][0] for j in ids], dtype=np.int64)
        self.writer.write_states(step, self.t(step), ids, vals[:, [X, Y]], vals[:, [VX, VY]], vals[:, RHO], vals[:, P], cls)
        self.last_positions = vals[:, [X, Y]]

    def _flush(self, upto: int | None = None, force: bool = False) -> None:
        while self.next_step <= self.newest:
            if upto is not None and self.next_step > upto:
                return
            if not force and upto is None and not self._ready(self.next_step):
                return
            self._write_step(self.next_step)
            self.next_step += 1
            self._write_deaths()

    def pump(self, timeout: float) -> None:
        try:
            item = self.inbox.get(timeout=timeout)
        except queue.Empty:
            self._flush()
            return
        self.handle(item)
        while True:
            try:
                self.handle(self.inbox.get_nowait())
            except queue.Empty:
                break
        self._flush()

    def finish(self) -> None:
        while True:
            try:
                self.handle(self.inbox.get_nowait())
            except queue.Empty:
                break
        self._flush(force=True)
        self.next_step = max(self.next_step, max(self.dead_at.values(), default=0))
        self._write_deaths()


class _Stop(Exception):
    pass


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fluidswarm record", description=__doc__.splitlines()[0])
    ap.add_argument("--connect", required=True)
    ap.add_argument("--run", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--dt", type=float, default=0.01)
    ap.add_argument("--metadata", default="{}", help="JSON object stored as the run's MCAP metadata")
    ap.add_argument("--target", help="npz with the target silhouette (mask, scale, x0, y0) for fidelity/replay")
    ap.add_argument("--image", help="the perception input picture, recorded as foxglove.CompressedImage")
    ap.add_argument("--user", default="")
    ap.add_argument("--password", default="")
    ap.add_argument("--live", default="", metavar="HOST:PORT", help="also serve the run over Foxglove WebSocket")
    args = ap.parse_args(argv)
    if not keys.valid_run_name(args.run):
        print(f"fluidswarm record: error: --run {args.run!r} is not a valid run name", file=sys.stderr)
        return 2
    try:
        metadata = json.loads(args.metadata)
        assert isinstance(metadata, dict)
    except (ValueError, AssertionError):
        print("fluidswarm record: error: --metadata must be a JSON object", file=sys.stderr)
        return 2
    metadata.setdefault("run", args.run)

    def stop(signum, frame):
        raise _Stop()

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    live = None
    if args.live:
        try:
            live = LiveServer(parse_address(args.live), args.run)
        except (UserError, RuntimeError) as exc:
            print(f"fluidswarm record: error: --live {args.live}: {exc}", file=sys.stderr)
            return 2
    writer = RunWriter(args.out, metadata, live=live)
    target = None
    if args.target:
        with np.load(args.target) as t:
            target = (t["mask"].astype(bool), ImageToDomain(float(t["scale"]), float(t["x0"]), float(t["y0"])))
        writer.write_target(0.0, *target)
    if args.image:
        with open(args.image, "rb") as f:
            writer.write_image(0.0, f.read(), frame_id="camera")
    recorder = Recorder(args.run, writer, args.dt)
    session = zenoh.open(client_config([args.connect], args.user, args.password))
    try:
        subs = [
            # On zenoh's receiving thread (indirect=False): the callback only enqueues, and a Python thread
            # hand-over per state (N per step) was most of this process's CPU at N = 300.
            session.declare_subscriber(keys.state_all_expr(args.run), zenoh.handlers.Callback(recorder.on_state, indirect=False)),
            session.declare_subscriber(keys.event_expr(args.run), recorder.on_event),
            session.declare_subscriber(keys.command_key(args.run), recorder.on_command),
            session.liveliness().declare_subscriber(keys.alive_expr(args.run), recorder.on_alive, history=True),
        ]
        token = session.liveliness().declare_token(f"{keys.PREFIX}/{args.run}/recorder")
        while True:
            recorder.pump(0.2)
    except _Stop:
        pass
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        recorder.finish()
        if target is not None and recorder.last_positions is not None:
            writer.write_fidelity(fidelity(*target, recorder.last_positions))
        writer.close()
        try:
            session.close()
        except Exception:
            pass
        if live is not None and not live.close():
            # A stuck viewer holds the server's stop (and the SDK's exit hook) forever; the MCAP is finished
            # and synced, so leave without them.
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
