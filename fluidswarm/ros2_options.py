"""`--ros2` and `--ros2-router ENDPOINT` on the commands that record a run (docs/ros2.md)."""

from __future__ import annotations

import sys
from pathlib import Path

from agent.protocol.errors import UserError
from ros2link.rmw import DEFAULT_ROUTER, check_endpoint, domain_from_env


def add_ros2_arguments(parser) -> None:
    parser.add_argument(
        "--ros2",
        action="store_true",
        help="also publish the run on ROS 2 (rmw_zenoh's format: node /fluidswarm, /fluidswarm/poses, /tf, ...; "
        "domain from ROS_DOMAIN_ID)",
    )
    parser.add_argument(
        "--ros2-router",
        default=DEFAULT_ROUTER,
        metavar="ENDPOINT",
        help=f"the ROS 2 system's Zenoh router (default {DEFAULT_ROUTER}, rmw_zenohd's)",
    )
    parser.add_argument(
        "--ros2-bag",
        metavar="DIR",
        help="once the run ends, also write its MCAP as the new rosbag2 directory DIR (as replay --ros2-bag)",
    )


def ros2_bag_from_args(args) -> Path | None:
    """`--ros2-bag DIR`, checked before the run starts (one line if it exists or cannot be made)."""
    if not getattr(args, "ros2_bag", None):
        return None
    from fluidswarm.ros2_bag import check_bag_dir

    check_bag_dir(Path(args.ros2_bag))
    return Path(args.ros2_bag)


def write_run_bag(mcap: str | None, bag: Path | None) -> None:
    """The run's MCAP as the bag `bag` (after the run); says where on stderr (stdout holds the run's record)."""
    if bag is None:
        return
    if not mcap or not Path(mcap).exists():
        raise UserError(f"--ros2-bag {bag}: the run wrote no MCAP to convert")
    from fluidswarm.recording.reader import load_run
    from fluidswarm.ros2_bag import write_bag

    summary = write_bag(load_run(mcap), bag)
    print(f"ros2: wrote the bag {bag} ({sum(summary.counts.values())} messages)", file=sys.stderr, flush=True)


def ros2_from_args(args) -> str:
    """The ROS 2 router's endpoint for the recorder ('' without --ros2); a bad endpoint or ROS_DOMAIN_ID is one
    line before anything starts."""
    router = getattr(args, "ros2_router", DEFAULT_ROUTER)
    try:
        check_endpoint(router)
        domain = domain_from_env()
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if not getattr(args, "ros2", False):
        if router != DEFAULT_ROUTER and not str(getattr(args, "camera", None) or "").startswith("ros2:"):
            raise UserError("--ros2-router needs --ros2 (or --camera ros2:TOPIC)")
        return ""
    print(f"ros2: node /fluidswarm on domain {domain} through {router}", file=sys.stderr, flush=True)
    return router
