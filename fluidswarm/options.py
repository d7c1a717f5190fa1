"""The options several commands share, each with its help and its one check at the edge (issue 52: one name per
option across commands): the swarm's bodies and radio (`--robot`, `--radio-*`, and a scenario's [robot] and
[radio] tables through the same functions), `--obstacles FILE` of `launch` and `verify`, `--realtime`, `--json`.
`add_swarm_arguments` gives a command that runs a swarm the ones every such command has, in one order: bodies,
radio, `--live` (fluidswarm/recording/live.py), `--ros2` (fluidswarm/ros2_options.py), `--realtime`."""

from __future__ import annotations

from agent.protocol.errors import UserError
from agent.sph.radio import MAX_LATENCY, PERFECT, RadioModel, radio_from
from agent.sph.robot import POINT, ROBOT_KINDS, RobotModel, robot_from
from fluidswarm.recording.live import add_live_argument
from fluidswarm.ros2_options import add_ros2_arguments


def add_swarm_arguments(parser) -> None:
    """`--robot`, `--radio-*`, `--live`, `--ros2`, `--realtime`: what every command that runs a swarm takes."""
    add_robot_argument(parser)
    add_radio_arguments(parser)
    add_live_argument(parser)
    add_ros2_arguments(parser)
    add_realtime_argument(parser)


# --- `--json`: the run's record as exactly one JSON object on stdout ---------------------------------------------

JSON_HELP = (
    "print the run's record (fluidswarm/orchestration/run.py RunRecord) as one JSON object instead of key=value lines"
)


def add_json_argument(parser) -> None:
    parser.add_argument("--json", action="store_true", help=JSON_HELP)


def print_json(record) -> None:
    """`record`: a fluidswarm.orchestration.run.RunRecord."""
    print(record.to_json(), flush=True)


# --- `--realtime`: simulated time held to the wall clock instead of as fast as it can (swarmhost/pacing.py
# pace_realtime; `imitate --camera` always is). The record's `realtime_factor` says what was reached, and a swarm
# that cannot keep up says so once (fluidswarm/orchestration/run.py REALTIME_KEPT). -------------------------------

REALTIME_HELP = (
    "pace the swarm to the wall clock: simulated time never runs ahead of it (realtime_factor in the record "
    "and the MCAP; a swarm that cannot keep up says so once)"
)


def add_realtime_argument(parser) -> None:
    parser.add_argument("--realtime", action="store_true", help=REALTIME_HELP)


# --- `--robot point|holonomic|unicycle`, and a scenario's [robot] table -------------------------------------------

ROBOT_HELP = (
    "the particles' body and drive (docs/robots.md): point (the thesis' ideal particle, the default), "
    "holonomic (speed and acceleration limits, a body) or unicycle (differential drive: heading, forward "
    "speed, turn rate); limits and radius: the e-puck's scaled to the domain, or a scenario's [robot] table"
)


def add_robot_argument(parser) -> None:
    parser.add_argument("--robot", choices=ROBOT_KINDS, default=None, help=ROBOT_HELP)


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


# --- `--radio-loss/--radio-latency/--radio-noise`, and a scenario's [radio] table: the imperfect radio and
# localisation of the robots (agent/sph/radio.py, docs/robots.md) --------------------------------------------------

RADIO_OPTIONS = {"loss": "--radio-loss", "latency": "--radio-latency", "noise": "--radio-noise"}


def add_radio_arguments(parser) -> None:
    g = parser.add_argument_group("imperfect radio (docs/robots.md; lockstep only; draws seeded from the run's seed)")
    g.add_argument(
        "--radio-loss",
        type=float,
        default=None,
        metavar="P",
        help="probability in [0, 1) that a receiver loses a neighbour's state (not used in its step)",
    )
    g.add_argument(
        "--radio-latency",
        type=int,
        default=None,
        metavar="K",
        help=f"steps (0..{MAX_LATENCY}) before a received state is used: a neighbour's state of K steps back",
    )
    g.add_argument(
        "--radio-noise",
        type=float,
        default=None,
        metavar="SIGMA",
        help="m: standard deviation of each coordinate of a neighbour's reported position",
    )


def radio_options(args) -> dict:
    """The --radio-* options given, as [radio] table fields."""
    return {
        k: getattr(args, o[2:].replace("-", "_"))
        for k, o in RADIO_OPTIONS.items()
        if getattr(args, o[2:].replace("-", "_"), None) is not None
    }


def radio_model(table: dict | None, seed: int = 0, where: str = "") -> RadioModel:
    """The RadioModel of `table` (a scenario's [radio] with the options over it) for the run's `seed`; bad input
    is one line naming the key (`where`: the file, for a scenario; else the option)."""
    if not table:
        return PERFECT if seed == 0 else PERFECT.with_seed(seed)
    try:
        return radio_from(table, seed)
    except (ValueError, TypeError) as exc:
        key, _, problem = str(exc).partition(": ")
        if where:
            raise UserError(f"{where}: key '{key}': {problem}") from None
        option = RADIO_OPTIONS.get(key.removeprefix("radio."), key)
        raise UserError(f"{option}: {problem}") from None


def check_lockstep(radio: RadioModel, mode: str, where: str) -> None:
    """The imperfect radio is modelled in lockstep only (its draws are per step; async steps are each agent's)."""
    if not radio.is_perfect and mode == "async":
        raise UserError(f"{where}: the imperfect radio is modelled in lockstep only, not with sync mode async")


# --- `--obstacles FILE` of `launch` and `verify`: the [[obstacle]] tables of a TOML file (a scenario file, or one
# holding only obstacles, such as scenarios/inputs/block_obstacles.toml) placed in the block's domain; read by
# fluidswarm/scenario.py obstacles_file ---------------------------------------------------------------------------

OBSTACLES_HELP = (
    "a TOML file whose [[obstacle]] tables (kind circle: centre, radius; kind polygon: vertices; domain m) the "
    "fluid flows around (docs/robots.md); scenarios/inputs/block_obstacles.toml fits the verify block"
)


def add_obstacles_argument(parser) -> None:
    parser.add_argument("--obstacles", metavar="FILE", default=None, help=OBSTACLES_HELP)
