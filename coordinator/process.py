"""The coordinator process: observe, recognise, broadcast the signed gesture command. Nothing else.

It observes and commands on the bus; the swarm's set-up is planned by the process that runs the swarm.
Launched by `imitate` for a file (`--plan`), it broadcasts the launcher's plan, heard on the bus
(coordinator/handover.py `await_plan`: commands signed with the run's key, verified here); for a camera
(`--camera`) it observes frames as they come and builds each command, and puts its notes on the bus
(coordinator/camera.py; the launcher places the swarm from the first command's observation). Alone
(`--input`, `fluidswarm coordinator`) it observes a file and builds its commands itself. It declares the
command's publisher, the notes' and one liveliness token, and never subscribes to agent states. It
republishes the current command every `period` s so an agent that starts late has it within one period, and
publishes a new command (next sequence number) when the observed gesture changes between frames (thesis
ch. 5, gesture sequences).

`python -m coordinator --connect tcp/HOST:PORT --run NAME --input IMAGE|FOLDER|VIDEO --agents N`
with the run's secret (hex) in the environment variable FLUIDSWARM_SECRET. With `--camera DEVICE|URL|FILE`
instead of `--input` it observes frames as they come (coordinator/camera.py): a video file until its last
frame (exit 0), a device or URL until it ends or stalls (then a one-line error, exit 1). With `--plan`
(no --agents) it waits for the launcher's plan instead.
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
from contextlib import contextmanager

import zenoh

from agent.protocol import keys
from agent.protocol.ctl import Clock, decode_ctl
from agent.protocol.imitation import encode_note, note_key
from agent.protocol.session import client_config
from agent.protocol.stopping import stop_on_signals
from coordinator import handover
from coordinator.camera import run_camera
from coordinator.control.fill import ShapeError
from coordinator.control.imitation_setup import CONTROLLERS, DEFAULT_CONTROLLER, imitation_of_input
from perception.io import InputError
from perception.segmentation import SegmentationError
from perception.stream import StreamError, StreamParams

PLAN_SECONDS = 120.0  # s a --plan coordinator waits for its launcher's plan (the launcher puts it as it starts us)


class SwarmClock:
    """The run's pacing clock (ctl/clock: the slowest live agent's step, published by the launcher).

    A gesture sequence scenario shows frame k from clock step k * frame_steps, so what the swarm sees does
    not depend on how fast this machine steps. The payload is untrusted: a valid clock record
    (agent/protocol/ctl.py) on the exact key, or ignored."""

    def __init__(self, run: str):
        self.run = run
        self.step = 0
        self.started = threading.Event()  # a clock was heard: the swarm runs

    def on_sample(self, sample) -> None:
        msg = decode_ctl(keys.ctl_what(self.run, str(sample.key_expr)), sample.payload.to_bytes())
        if isinstance(msg, Clock):
            self.step = max(self.step, msg.step)
            self.started.set()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fluidswarm coordinator", description=__doc__.splitlines()[0])
    ap.add_argument("--connect", required=True)
    ap.add_argument("--run", required=True)
    ap.add_argument("--input", help="image, folder of frames, or video")
    ap.add_argument("--camera", help="DEVICE|URL|FILE: a live source, frames observed as they come")
    ap.add_argument(
        "--fps", type=float, default=StreamParams.fps, help="camera: at most this many frames observed per second"
    )
    ap.add_argument(
        "--stall-seconds",
        type=float,
        default=StreamParams.stall_seconds,
        help="camera: no frame for this long is a stall",
    )
    ap.add_argument(
        "--subject",
        default="person",
        choices=["hand", "person", "auto"],
        help="camera: what it watches (auto: decided from the first frames)",
    )
    ap.add_argument(
        "--ros2-router", default="", help="camera ros2:TOPIC: the ROS 2 system's router (default tcp/localhost:7447)"
    )
    ap.add_argument(
        "--plan",
        action="store_true",
        help="broadcast the launcher's plan, heard on the run's imitation/plan key (agent/protocol/imitation.py)",
    )
    ap.add_argument("--agents", type=int, default=None, help="--input, --camera: the swarm's size")
    ap.add_argument("--controller", default=DEFAULT_CONTROLLER, choices=CONTROLLERS)
    ap.add_argument("--frame", type=int, default=None, help="show only this frame of a clip/folder (default: all)")
    ap.add_argument("--period", type=float, default=0.2, help="s between republications (late joiners)")
    ap.add_argument("--frame-seconds", type=float, default=5.0, help="s each frame of a sequence is shown")
    ap.add_argument(
        "--frame-steps",
        type=int,
        default=0,
        help="show each frame of a sequence for this many swarm steps (the run's ctl/clock) instead",
    )
    args = ap.parse_args(argv)
    secret_hex = os.environ.get("FLUIDSWARM_SECRET", "")
    try:
        secret = bytes.fromhex(secret_hex)
    except ValueError:
        secret = b""
    if not secret:
        print("fluidswarm coordinator: error: FLUIDSWARM_SECRET (hex) must hold the run's command key", file=sys.stderr)
        return 2
    if (
        not keys.valid_run_name(args.run)
        or (args.agents is not None and args.agents < 1)
        or args.period <= 0
        or args.frame_steps < 0
        or not args.frame_seconds > 0
    ):
        print(
            "fluidswarm coordinator: error: bad --run, --agents, --period, --frame-steps or --frame-seconds",
            file=sys.stderr,
        )
        return 2
    if (args.input is not None) + (args.camera is not None) + args.plan != 1:
        print("fluidswarm coordinator: error: give --input, --camera or --plan (one of them)", file=sys.stderr)
        return 2
    if args.plan:
        return _planned(args, secret)
    if args.agents is None:
        print("fluidswarm coordinator: error: --input and --camera need --agents", file=sys.stderr)
        return 2
    if args.camera:
        return _camera(args, secret)

    try:
        im = imitation_of_input(args.input, args.agents, args.controller, args.frame)
    except (InputError, SegmentationError, ShapeError) as exc:
        problem = str(exc) if str(args.input) in str(exc) else f"{args.input}: {exc}"
        print(f"fluidswarm coordinator: error: {problem}", file=sys.stderr)
        return 1
    with _command_channel(args) as (session, pub, stop):
        _broadcast(args, session, pub, stop, [(first, c.encode(secret)) for first, c in im.commands], args.frame_steps)
    return 0


def _planned(args, secret: bytes) -> int:
    """The launcher's plan (coordinator/handover.py await_plan: signed commands, verified here too), broadcast."""
    with _command_channel(args) as (session, pub, stop):
        plan = handover.await_plan(session, args.run, secret, stop, PLAN_SECONDS)
        if plan is None:
            if stop.is_set():
                return 0
            print(f"fluidswarm coordinator: error: no valid plan heard in {PLAN_SECONDS:.0f} s", file=sys.stderr)
            return 1
        _broadcast(args, session, pub, stop, list(plan.commands), plan.frame_steps)
    return 0


def _broadcast(args, session, pub, stop, payloads: list[tuple[int, bytes]], frame_steps: int) -> None:
    """Put the signed command of the frame shown every `--period` s until `stop`: frame k from the run's
    clock step k * frame_steps (frame_steps 0: every --frame-seconds; one command: that one all along)."""
    clock = None
    if frame_steps:
        clock = SwarmClock(args.run)  # the exact key only: a put on `fluidswarm/**` reaches it too
        session.declare_subscriber(keys.ctl_key(args.run, "clock"), clock.on_sample)
    ticks_per_frame = max(1, int(round(args.frame_seconds / args.period)))
    tick = 0
    while not stop.is_set():
        shown = clock.step // frame_steps if clock is not None else tick // ticks_per_frame
        current = [p for first, p in payloads if first <= shown][-1]
        pub.put(current)
        tick += 1
        stop.wait(args.period)


@contextmanager
def _command_channel(args):
    """(session, command publisher, stop event) while the coordinator publishes: its liveliness token is
    declared (docs/protocol.md), SIGTERM/SIGINT set `stop`, and the session closes however the loop ends."""
    stop = stop_on_signals()
    # credentials come from the environment the launcher sets, never from argv (docs/security.md)
    session = zenoh.open(client_config([args.connect]))
    try:
        pub = session.declare_publisher(keys.command_key(args.run))
        token = session.liveliness().declare_token(f"{keys.PREFIX}/{args.run}/coordinator")
        yield session, pub, stop
        token.undeclare()
        pub.undeclare()
    finally:
        stop.set()
        session.close()


def _camera(args, secret: bytes) -> int:
    """The live source (coordinator/camera.py): commands as the observed gesture changes."""
    try:
        params = StreamParams(fps=args.fps, stall_seconds=args.stall_seconds)
    except ValueError as exc:
        print(f"fluidswarm coordinator: error: {exc}", file=sys.stderr)
        return 2
    try:
        with _command_channel(args) as (session, pub, stop):
            clock = SwarmClock(args.run)  # a video file is held until the swarm steps (its first clock)
            session.declare_subscriber(keys.ctl_key(args.run, "clock"), clock.on_sample)
            # each note once, none dropped on a busy link (the first observation is what the launcher waits for)
            notes = session.declare_publisher(note_key(args.run), congestion_control=zenoh.CongestionControl.BLOCK)
            run_camera(
                args.camera,
                params,
                args.agents,
                args.controller,
                secret,
                pub,
                stop,
                args.period,
                lambda note: notes.put(encode_note(note)),
                subject=args.subject,
                started=clock.started,
                ros2_router=args.ros2_router,
            )
    except StreamError as exc:
        print(f"fluidswarm coordinator: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
