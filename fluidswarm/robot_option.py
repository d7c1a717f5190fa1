"""`--robot point|holonomic|unicycle` of the commands that run a swarm, and a scenario's [robot] table."""

from __future__ import annotations

from agent.protocol.errors import UserError
from agent.sph.robot import POINT, ROBOT_KINDS, RobotModel, robot_from

HELP = (
    "the particles' body and drive (docs/robots.md): point (the thesis' ideal particle, the default), "
    "holonomic (speed and acceleration limits, a body) or unicycle (differential drive: heading, forward "
    "speed, turn rate); limits and radius: the e-puck's scaled to the domain, or a scenario's [robot] table"
)


def add_robot_argument(parser) -> None:
    parser.add_argument("--robot", choices=ROBOT_KINDS, default=None, help=HELP)


def robot_model(kind: str | None, table: dict | None = None, where: str = "") -> RobotModel:
    """The RobotModel of `kind` (None: the table's, else a point) with `table`'s fields; bad input is one
    line naming the key (`where`: the file, for a scenario)."""
    if kind is None and not table:
        return POINT
    try:
        return robot_from(kind, table)
    except (ValueError, TypeError) as exc:
        key, _, problem = str(exc).partition(": ")
        raise UserError(f"{where}: key '{key}': {problem}" if where else f"--robot: {key}: {problem}") from None
