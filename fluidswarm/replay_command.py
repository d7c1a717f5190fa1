"""The `fluidswarm replay` subcommand. `replay` (matplotlib, Pillow) is imported when the subcommand runs:
the command line imports every `commands` module to build its parser."""

from __future__ import annotations

import argparse

from agent.protocol.errors import UserError
from coordinator.control.fidelity import format_fidelity
from fluidswarm.recording.reader import completeness, finished, load_run, recorded_robots, salvage_lines, salvaged


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "replay",
        help="render a recorded run (PNGs, GIF, plots, fidelity) or --check it",
        description="Render a recorded run: PNG snapshots, an animated GIF, the thesis' plots (average "
        "speed per class, average pressure, average inter-particle distance) and the fidelity "
        "score. With --check, verify that every alive agent's state is recorded at every step.",
    )
    p.add_argument("run", metavar="RUN.mcap", help="the recording")
    p.add_argument("--out", metavar="DIR", help="output directory (default: RUN_replay/ beside the file)")
    p.add_argument(
        "--check",
        action="store_true",
        help="print complete=, steps=, missing_states= (and the recorded fidelity, if any); exit 0 if complete else 1",
    )
    p.add_argument(
        "--recover",
        action="store_true",
        help="a file whose writer died (no footer): rewrite it finished with every whole record it "
        "holds; print what was kept and dropped, and complete=, steps=, missing_states=",
    )
    p.add_argument(
        "--ros2-bag",
        metavar="DIR",
        help="write the run as a new rosbag2 directory (MCAP storage, CDR, standard types: docs/ros2.md) instead "
        "of rendering it; prints each topic's message count",
    )
    p.add_argument("--max-frames", type=int, default=120, metavar="N", help="GIF frames at most (default 120)")
    p.add_argument("--fps", type=float, default=10.0, help="GIF frame rate (default 10)")
    p.set_defaults(func=_main)


def _main(args: argparse.Namespace) -> int:
    if args.recover:
        return _recover(args.run)
    if args.ros2_bag:
        return _ros2_bag(args.run, args.ros2_bag)
    if args.check:
        run = load_run(args.run, images=False)
        c = completeness(run)
        print(c.lines())
        if run.truncated:  # read up to its last whole record: its writer died
            print(salvage_lines(run))
        for key, value in run.fidelity.items():  # the score the recorder kept with the run
            print(f"recorded_{key}={value:.4f}")
        if run.fidelity_gesture is not None:  # the gesture whose target it scored (the last one written)
            print(f"recorded_fidelity_gesture={run.fidelity_gesture}")
        if "realtime_factor" in run.timing:  # simulated / wall seconds, as the recorder saw the steps come
            print(f"recorded_realtime_factor={run.timing['realtime_factor']:.4f}")
        for e in run.events:  # hosts of a split run its main host lost, with their agents (the launcher's events)
            if e.kind == "host_lost":
                print(f"lost_host t={e.t:.2f} s: {e.message}")
        return 0 if c.complete else 1
    from fluidswarm.replay import replay  # matplotlib only when rendering

    result = replay(args.run, args.out, max_frames=args.max_frames, fps=args.fps)
    if result.fidelity is not None:
        print(format_fidelity(result.fidelity))
    else:
        print("fidelity: the recording holds no target silhouette")
    robots = recorded_robots(args.run)
    for key in ("collisions", "min_separation_m", "obstacle_penetrations", "min_obstacle_distance_m"):
        if robots and key in robots:  # what the recorder measured on the bodies (recording/contacts.py)
            v = robots[key]
            print(f"{key}={v:.4f}" if isinstance(v, float) else f"{key}={v}")
    for path in result.paths:
        print(f"wrote {path}")
    return 0


def _ros2_bag(name: str, out: str) -> int:
    """`replay --ros2-bag DIR` (fluidswarm/ros2_bag.py): the directory is checked before the file is read."""
    from pathlib import Path

    from fluidswarm.ros2_bag import check_bag_dir, write_bag

    check_bag_dir(Path(out))
    summary = write_bag(load_run(name), Path(out))
    for topic, count in summary.counts.items():
        print(f"{topic} {count}")
    print(f"wrote {summary.path}")
    return 0


def _recover(name: str) -> int:
    """`replay --recover`: rewrite an unfinished file finished (recording/recover.py); a finished one is left."""
    from pathlib import Path

    from fluidswarm.recording.recover import rewrite

    path = Path(name)
    if finished(path):
        print("recovered=false (the file is finished: nothing to recover)")
    else:
        kept = salvaged(path)
        try:
            rewrite(path, kept)
        except OSError as exc:
            raise UserError(f"{path}: cannot rewrite it ({exc.strerror or exc})") from None
        print(f"recovered=true\n{kept.lines()}")
    c = completeness(load_run(path, images=False))
    print(c.lines())
    return 0 if c.complete else 1
