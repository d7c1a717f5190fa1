"""`fluidswarm coordinator` and `fluidswarm imitate`."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from agent.protocol.errors import UserError
from coordinator.control.imitation_setup import CONTROLLERS, DEFAULT_CONTROLLER
from fluidswarm.options import (
    add_json_argument,
    add_swarm_arguments,
    print_json,
    radio_model,
    radio_options,
    robot_model,
)
from fluidswarm.orchestration.run_config import (
    AGENTS,
    CAMERA_FPS,
    CAMERA_STALL_SECONDS,
    Access,
    Camera,
    Recording,
    RunConfig,
    check_agents,
)
from fluidswarm.recording.live import live_from_args
from fluidswarm.ros2_options import ros2_bag_from_args, ros2_from_args, write_run_bag
from fluidswarm.worker_command import add_workers_arguments, workers_options

if TYPE_CHECKING:
    from fluidswarm.orchestration.run import RunRecord


def register(sub) -> None:
    p = sub.add_parser("coordinator", help="observe an image/frames/video and broadcast signed gesture commands")
    p.add_argument("args", nargs="*", help="see `python -m coordinator --help`")
    p.set_defaults(func=_coordinator)
    p = sub.add_parser("imitate", help="perception -> coordinator -> N agent processes -> formation, MCAP, fidelity")
    p.add_argument("input", nargs="?", help="image, folder of frames, or video (or --camera)")
    p.add_argument(
        "--camera",
        metavar="DEVICE|URL|FILE|ros2:TOPIC",
        help="follow a person or a hand watched live: frames read as they come, a new command when the "
        "gesture changes, the swarm paced to the wall clock; ros2:/camera/image_raw: a ROS 2 camera topic "
        "(sensor_msgs/Image or CompressedImage) through --ros2-router",
    )
    p.add_argument(
        "--subject",
        default="person",
        choices=["hand", "person", "auto"],
        help="--camera: a hand in front of a plain background, a person (static camera), or auto "
        "(decided from the first frames, said in the record)",
    )
    p.add_argument(
        "--fps", type=float, default=CAMERA_FPS, help="--camera: at most this many frames observed per second"
    )
    p.add_argument(
        "--stall-seconds",
        type=float,
        default=CAMERA_STALL_SECONDS,
        help="--camera: no new frame for this long is an error",
    )
    p.add_argument(
        "--controller",
        default=DEFAULT_CONTROLLER,
        choices=CONTROLLERS,
        help="fill (default): the swarm fills the silhouette like a liquid; region: waypoints at k-means "
        "regions (thesis ch. 6); pca: the recognised class' template; ann: skeleton -> body force",
    )
    p.add_argument("--frame", type=int, default=None, help="which frame of a clip or folder to imitate (default 0)")
    p.add_argument("--agents", type=int, default=AGENTS)
    p.add_argument("--steps", type=int, default=None)
    p.add_argument("--out", default=str(Recording.out))
    add_workers_arguments(p)
    add_swarm_arguments(p)
    add_json_argument(p)
    p.set_defaults(func=_imitate)


def _coordinator(args) -> int:
    from coordinator.process import main

    return main(args.args)


def run_config(args) -> RunConfig:
    """The imitation's whole configuration from its flags, every value checked here once (one line each, exit
    1): the one helper from flags to config, as zenoh's examples have (examples/common/common.py)."""
    from coordinator.control.imitation_setup import DEFAULT_STEPS

    check_agents(args.agents, embedded=not args.workers)  # workers: the run's routers are the hosts'
    steps = DEFAULT_STEPS if args.steps is None else args.steps
    if steps < 1:
        raise UserError(f"--steps: must be >= 1, got {steps}")
    if (args.input is None) == (args.camera is None):
        raise UserError("give an INPUT file or --camera DEVICE|URL|FILE (one of them)")
    if not 0 < args.fps <= 120:
        raise UserError(f"--fps: must be in (0, 120], got {args.fps}")
    if not 0 < args.stall_seconds < 3600:
        raise UserError(f"--stall-seconds: must be in (0, 3600), got {args.stall_seconds}")
    hosts = workers_options(args)
    if hosts and args.camera is not None:
        raise UserError("--workers: a file only (--camera runs on one host)")
    live, ros2, bag = live_from_args(args), ros2_from_args(args), ros2_bag_from_args(args)
    name = "camera" if args.camera is not None else Path(args.input).stem or "imitate"
    return RunConfig(
        agents=args.agents,
        steps=steps,
        controller=args.controller,
        robot=robot_model(args.robot),
        radio=radio_model(radio_options(args)),
        realtime=args.realtime or args.camera is not None,  # a camera's run keeps pace with the person
        recording=Recording(Path(args.out), name, live, ros2, bag),
        access=Access(**hosts),
    )


def _imitate(args) -> int:
    config = run_config(args)
    if args.camera is not None:
        from fluidswarm.orchestration.imitate_camera import imitate_camera

        camera = Camera(args.camera, args.fps, args.stall_seconds, args.subject, args.ros2_router)
        record = imitate_camera(camera, config)
    else:
        from fluidswarm.orchestration.imitate import imitate

        # a picture the coordinator cannot read is its one-line error (coordinator/handover.py CoordinatorFailed)
        record = imitate(args.input, config, frame=args.frame)
    write_run_bag(record.mcap, config.recording.bag)
    if args.json:
        print_json(record)
    else:
        print_lines(record)
    return 0


def print_lines(r: RunRecord) -> None:
    from coordinator.control.fidelity import format_fidelity

    assert r.fidelity is not None  # an imitation's score() always sets it
    print(format_fidelity(r.fidelity))
    print(f"formation_seconds={r.formation_seconds:.2f}")
    print(f"formation_wall_seconds={r.formation_wall_seconds:.2f}")
    print(f"formation_settled={'true' if r.formation_settled else 'false'}")
    print(f"agents_finished={r.finished}")
    print(f"robot={r.robot}")
    for k, v in (r.radio or {}).items():
        if k != "seed":
            print(f"radio_{k}={v}")
    if r.collisions is not None:
        print(f"collisions={r.collisions}")
        print(f"min_separation_m={r.min_separation_m:.4f}")
    if r.obstacle_penetrations is not None:
        print(f"obstacle_penetrations={r.obstacle_penetrations}")
        print(f"min_obstacle_distance_m={r.min_obstacle_distance_m:.4f}")
    print(f"steps_per_second={r.steps_per_second:.2f}")
    if r.realtime_factor is not None:
        print(f"realtime_factor={r.realtime_factor:.3f}")
    if r.subject:
        print(f"subject={r.subject}")
    for g in r.gestures:
        print(f"gesture seq={g['seq']} t={g['t']:.2f} {g['gesture']} ({g['why']})")
    for note in r.notes:
        print(f"note {note}")
    print(f"mcap={r.mcap}")
    print(f"png={r.pictures[0]}")
