"""The recorder: a passive Zenoh process that writes a run to one MCAP file (docs/recording.md).

It subscribes to the run's keys — every state (`state/**`), the agents' liveliness (`alive/*`), events and
final reports, the gesture command — and never publishes anything but its own readiness token. States are grouped by
step and a step is written as one message once every agent alive at that step has reported, or once the
run is far enough past it (then the missing agents get a `froze` event and count as stopped; a later
state of theirs gives a `started` event). A killed agent's last state is written before its `died` event.
SIGINT/SIGTERM finish the file (pending steps flushed, MCAP footer written).

With `--live HOST:PORT` it also serves the run to Foxglove as it happens (recording/live.py). This module is
the process (arguments, subscriptions, signals) and `Recorder`, the zenoh shell of the step assembly: what it
does with each message is steps.py's `StepAssembly`, which has no I/O of its own.

`python -m fluidswarm.recording.recorder --connect tcp/... --run NAME --out FILE.mcap [--metadata JSON] [--live H:P]`
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import signal
import sys
import threading
import time

import numpy as np
import zenoh

from agent.protocol import keys
from agent.protocol.errors import UserError
from agent.protocol.session import client_config
from agent.protocol.stopping import stop_on_signals
from agent.sph.obstacles import Obstacle, obstacles_from
from agent.sph.robot import POINT, RobotKind, RobotModel
from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording.coordinator_events import CoordinatorNotes, LauncherEvents
from fluidswarm.recording.live import LiveServer, parse_address
from fluidswarm.recording.preload import preload
from fluidswarm.recording.steps import BATCH_GRACE_SECONDS, FINISH_LIMIT_SECONDS, FINISH_QUIET_SECONDS, StepAssembly
from fluidswarm.recording.writer import RunWriter


class Recorder(StepAssembly):
    """The step assembly in the recorder process: zenoh's callbacks decode nothing and only enqueue (on zenoh's
    receiving thread); the main thread drains the queue into the core, each message with the time it is taken
    (`pump`), and at the end takes what is still on its way (`finish`)."""

    def __init__(self, run: str, writer: RunWriter, dt: float, contacts=None):
        super().__init__(run, writer, dt, contacts, time.monotonic())
        # queue.Queue, not SimpleQueue: CPython 3.11's SimpleQueue.get(timeout) can block for ever. When it takes
        # its lock with the queue empty (a put released it for an item get_nowait took) after its deadline passed
        # (the thread preempted that long), it waits again with a negative, i.e. infinite, timeout
        # (Modules/_queuemodule.c, "Adjust timeout for next iteration"): a signal's handler runs and the wait
        # resumes, so the recorder never saw its stop and was killed without its footer (CI of 1fd0e6b; gdb:
        # sem_wait with no deadline, the SIGTERM handled). ~3 us a message more: one per batch of the relays. (The
        # writer keeps SimpleQueue: close() and its puts must be safe in signal handlers, and close()'s put ends
        # any such wait.)
        self.inbox: queue.Queue = queue.Queue()

    # callbacks: decode nothing, enqueue
    def on_state(self, sample) -> None:
        self.inbox.put((0, (sample.payload.to_bytes(), str(sample.key_expr))))

    def on_batch(self, sample) -> None:
        self.inbox.put((5, (sample.payload.to_bytes(), str(sample.key_expr))))

    def on_alive(self, sample) -> None:
        self.inbox.put((1, (str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)))

    def on_event(self, sample) -> None:
        self.inbox.put((2, (sample.payload.to_bytes(), str(sample.key_expr))))

    def on_final(self, sample) -> None:
        self.inbox.put((4, (sample.payload.to_bytes(), str(sample.key_expr))))

    def on_command(self, sample) -> None:
        # the exact key only: a put on a wildcard key (`fluidswarm/**`) reaches this subscriber too
        if str(sample.key_expr) == keys.command_key(self.run):
            self.inbox.put((3, sample.payload.to_bytes()))

    def handle(self, item) -> None:
        """One queued message into the core, with the time it is taken."""
        kind, data = item
        now = time.monotonic()
        if kind == 0:
            self.heard_state(data[0], data[1], now)
        elif kind == 5:
            self.heard_batch(data[0], data[1], now)
        elif kind == 1:
            self.heard_alive(data[0], data[1], now)
        elif kind == 2:
            self.heard_event(data[0], data[1], now)
        elif kind == 3:
            self.heard_command(data, now)
        elif kind == 4:
            self.heard_final(data[0], data[1], now)

    def pump(self, timeout: float) -> None:
        """What came within `timeout` s (less while an agent is leaving), then what is due."""
        try:
            item = self.inbox.get(timeout=timeout if not self.leaving else min(timeout, BATCH_GRACE_SECONDS))
        except queue.Empty:
            self.tick(time.monotonic())
            return
        self.handle(item)
        while True:
            try:
                self.handle(self.inbox.get_nowait())
            except queue.Empty:
                break
        self.tick(time.monotonic())

    def finish(self, quiet: float = FINISH_QUIET_SECONDS, limit: float = FINISH_LIMIT_SECONDS) -> None:
        """Write everything heard, the last states still in flight included: told to stop once the agents have
        reported, the recorder still has their last steps on the way (it runs a step or two behind at
        N = 300), so it takes what arrives until `quiet` s pass without a message (at most `limit` s), or until
        every agent has left with its report and every step is written (all_left: a run that ended as planned
        has nothing more on its way, and its recorder need not wait out the quiet)."""
        last = time.monotonic()
        deadline = last + limit
        while (now := time.monotonic()) < deadline and now - last < quiet:
            self.tick(now)  # agents whose token went leave once their batches' grace is over, as in pump
            if self.all_left():
                break
            try:
                # woken at least every BATCH_GRACE_SECONDS: a leaver's grace ends without a message
                self.handle(
                    self.inbox.get(timeout=max(0.0, min(BATCH_GRACE_SECONDS, deadline - now, last + quiet - now)))
                )
                last = time.monotonic()
            except queue.Empty:
                pass
        for _ in range(self.inbox.qsize()):  # a run stopped mid-stream: what is queued now, not what follows
            self.handle(self.inbox.get_nowait())
        self.end(time.monotonic())


def robot_of(metadata: dict) -> RobotModel:
    """The run's robots (metadata `robot`, RobotModel fields, written by the run); a point without one."""
    try:
        return RobotModel(**metadata.get("robot", {}))
    except (TypeError, ValueError):
        return POINT


def obstacles_of(metadata: dict) -> tuple[Obstacle, ...]:
    """The domain's obstacles (metadata `obstacles`, written by the run, agent/sph/obstacles.py); none without."""
    try:
        return obstacles_from(metadata.get("obstacles", []))
    except ValueError:
        return ()


def ros2_bridge(endpoint: str, robot: RobotModel):
    """The ROS 2 node of `--ros2 ENDPOINT` (fluidswarm/recording/ros2_bridge.py), on the domain of ROS_DOMAIN_ID."""
    from fluidswarm.recording.ros2_bridge import Bridge
    from ros2link.rmw import domain_from_env

    return Bridge(endpoint, domain_from_env(), robot.kind == RobotKind.UNICYCLE, print)


def noting(writer: RunWriter, now):
    """The bridge's notes: one line on stderr (the launcher shows the recorder's `ros2:` lines when it stops it)
    and a warning in the MCAP (name `ros2`)."""

    def note(line: str) -> None:
        print(line, file=sys.stderr, flush=True)
        writer.write_event(now(), "warning", "ros2", line, kind="ros2")

    return note


def record(recorder: Recorder, stop: threading.Event, poll: float = 0.2, follow: tuple = ()) -> None:
    """Take the run's messages until `stop` (agent/protocol/stopping.py) is set, within `poll` s; what is being
    written then is written whole. `follow`: what else is written between pumps (CoordinatorNotes: the camera
    coordinator's notes; LauncherEvents: the launcher's events folder)."""
    while not stop.is_set():
        recorder.pump(poll)
        for folder in follow:
            folder.poll(recorder.t(recorder.next_step))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fluidswarm record", description=__doc__.splitlines()[0])
    ap.add_argument("--connect", required=True)
    ap.add_argument("--run", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--dt", type=float, default=0.01)
    ap.add_argument("--metadata", default="{}", help="JSON object stored as the run's MCAP metadata")
    ap.add_argument("--target", help="npz with the target silhouette (mask, scale, x0, y0) for fidelity/replay")
    ap.add_argument("--image", help="the perception input picture, recorded as foxglove.CompressedImage")
    ap.add_argument(
        "--coordinator-notes",
        metavar="JSON",
        help="follow a camera coordinator's notes on the bus (log events, each command's silhouette a target); "
        "JSON: the list of its missing notes said before the recording started",
    )
    ap.add_argument(
        "--launcher-events",
        metavar="DIR",
        help="the launcher's events folder: what it learns for the record (a lost host) as log events",
    )
    ap.add_argument("--live", default="", metavar="HOST:PORT", help="also serve the run over Foxglove WebSocket")
    ap.add_argument(
        "--ros2",
        default="",
        metavar="ENDPOINT",
        help="also publish the run on ROS 2 through the router at ENDPOINT (rmw_zenoh's format; docs/ros2.md)",
    )
    ap.add_argument(
        "--state-keys",
        choices=("id", "cell"),
        default="cell",
        help="where the run's states are taken from: the agents' id keys (per-process rights) or cells",
    )
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

    stop = stop_on_signals()
    live = None
    if args.live:
        try:
            live = LiveServer(parse_address(args.live), args.run)
        except (UserError, RuntimeError) as exc:
            print(f"fluidswarm record: error: --live {args.live}: {exc}", file=sys.stderr)
            return 2
    robot, obstacles = robot_of(metadata), obstacles_of(metadata)
    bridge = ros2_bridge(args.ros2, robot) if args.ros2 else None
    try:
        writer = RunWriter(args.out, metadata, live=live, tap=bridge)
    except OSError as exc:
        print(f"fluidswarm record: error: --out {args.out}: {exc.strerror or exc}", file=sys.stderr)
        if live is not None:
            live.close()
        return 2
    target: tuple[np.ndarray, ImageToDomain] | None = None
    if args.target:
        with np.load(args.target) as t:
            target = (t["mask"].astype(bool), ImageToDomain(float(t["scale"]), float(t["x0"]), float(t["y0"])))
        writer.write_target(0.0, *target)
    if args.image:
        with open(args.image, "rb") as f:
            writer.write_image(0.0, f.read(), frame_id="camera")
    follow = None
    if args.coordinator_notes is not None:
        gesture = metadata.get("gesture")
        try:
            early = json.loads(args.coordinator_notes)
            assert isinstance(early, list) and all(isinstance(w, str) for w in early)
        except (ValueError, AssertionError):
            print("fluidswarm record: error: --coordinator-notes must be a JSON list of strings", file=sys.stderr)
            writer.close()
            return 2
        follow = CoordinatorNotes(
            args.run,
            writer,
            target[1] if target is not None else None,
            gesture if isinstance(gesture, str) else None,
            tuple(early),
        )
    launcher = LauncherEvents(args.launcher_events, writer) if args.launcher_events else None
    if obstacles:
        writer.write_obstacles(0.0, obstacles)
    contacts = None
    if not robot.is_point or obstacles:
        # imported only here: scipy.spatial's KD-tree is ~0.35 s of imports a run of point agents never uses
        from fluidswarm.recording.contacts import ContactCounter

        contacts = ContactCounter(robot, obstacles)
    recorder = Recorder(args.run, writer, args.dt, contacts)
    if bridge is not None:
        bridge.note = noting(writer, lambda: recorder.t(recorder.next_step))
        bridge.start()
    # credentials come from the environment the launcher sets, never from argv (docs/security.md)
    session = zenoh.open(client_config([args.connect]))
    try:
        _subs = [  # held (declared) until the recording ends
            # On zenoh's receiving thread (indirect=False): the callback only enqueues, and a Python thread
            # hand-over per message was most of this process's CPU at N = 300.
            # Under per-process rights the routers' relays send the states in batches (docs/protocol.md "State
            # batches"): one delivery per step, not one per state (45 µs of this process per agent-step at N = 50
            # went on those, issue 32); without them (levels none, auth: no relay) each state on its cell key.
            session.declare_subscriber(
                keys.batch_expr(args.run), zenoh.handlers.Callback(recorder.on_batch, indirect=False)
            )
            if args.state_keys == "id"
            else session.declare_subscriber(
                keys.state_observed_expr(args.run, False), zenoh.handlers.Callback(recorder.on_state, indirect=False)
            ),
            session.declare_subscriber(keys.event_expr(args.run), recorder.on_event),
            session.declare_subscriber(keys.command_key(args.run), recorder.on_command),
            *([] if follow is None else [session.declare_subscriber(follow.key, follow.on_sample)]),
            # the final reports: an agent that reports it finished (or was stopped) left, it did not die
            session.declare_subscriber(keys.final_expr(args.run), recorder.on_final),
            # Direct too: an agent's alive token comes before its first state on the link, and must be queued
            # before it. Through zenoh-python's default (a thread of its own) it could be queued after the
            # others' step-0 states, and step 0 was written without that agent (test_live, under load).
            session.liveliness().declare_subscriber(
                keys.alive_expr(args.run), zenoh.handlers.Callback(recorder.on_alive, indirect=False), history=True
            ),
        ]
        _token = session.liveliness().declare_token(f"{keys.PREFIX}/{args.run}/recorder")
        if target is not None or follow is not None:
            # needed only at the end: imported at the top (scipy.spatial, OpenCV: ~0.45 s of the ~0.7 s of imports)
            # it lengthened every recorded run's start-up, which waits for this process's token
            preload("coordinator.control.fidelity")
        record(recorder, stop, follow=tuple(f for f in (follow, launcher) if f is not None))
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        recorder.finish()
        gesture = metadata.get("gesture")
        if launcher is not None:
            launcher.poll(recorder.t(recorder.next_step))
        if follow is not None:
            follow.poll(recorder.t(recorder.next_step))  # what came since the last pump
            target, gesture = follow.target or target, follow.gesture
        if target is not None and recorder.last_positions is not None:
            from coordinator.control.fidelity import fidelity  # loaded by preload() meanwhile

            # against the last target written (the last gesture's), named
            writer.write_fidelity(
                fidelity(*target, recorder.last_positions), gesture=gesture if isinstance(gesture, str) else None
            )
        factor, span = recorder.realtime_factor(), recorder.span
        if factor is not None and span is not None:
            writer.write_timing({"realtime_factor": factor, "steps_seen": span[2] - span[0] + 1})
        if recorder.contacts is not None:
            writer.write_robots(recorder.contacts.figures())
        if bridge is not None:
            bridge.close()
        writer.close()
        try:
            session.close()
        except Exception:  # noqa: BLE001, S110  # the recording is written; a failing close loses nothing
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
