"""`--obstacles FILE` of `launch` and `verify`: the [[obstacle]] tables of a TOML file (a scenario file, or one
holding only obstacles, such as scenarios/inputs/block_obstacles.toml) placed in the block's domain."""

from __future__ import annotations

from pathlib import Path

from agent.protocol.errors import UserError
from agent.sph.obstacles import Obstacle

HELP = (
    "a TOML file whose [[obstacle]] tables (kind circle: centre, radius; kind polygon: vertices; domain m) the "
    "fluid flows around (docs/robots.md); scenarios/inputs/block_obstacles.toml fits the verify block"
)


def add_obstacles_argument(parser) -> None:
    parser.add_argument("--obstacles", metavar="FILE", default=None, help=HELP)


def obstacles_option(path: str | None) -> tuple[Obstacle, ...]:
    """The obstacles of `path` (None: none); bad input is one line naming the file and the key."""
    if path is None:
        return ()
    from fluidswarm.scenario import read_toml, scenario_obstacles

    raw = read_toml(Path(path), f"--obstacles {path}", "no such file")
    if "obstacle" not in raw:
        raise UserError(f"--obstacles {path}: key 'obstacle': the file holds no [[obstacle]] table")
    return scenario_obstacles(path, raw["obstacle"])
