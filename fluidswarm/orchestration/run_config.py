"""A run's configuration at the edge: the defaults the commands and scenario files share, each declared here
once, and the one check of each value a user gives, whichever edge it came through (an option of `imitate`,
`run`, `demo`, `launch`, `verify`, or a key of a scenario file): the problem is worded here, the edge only
names where it came from (`--agents: ...`, `FILE: key 'agents': ...`), one line, exit 1.

Where the other defaults live, once each (tests/test_defaults.py fails when one is written again):
- what an agent is told when its spec leaves a field out (the async `rate` and `max_age`, the timeouts): the
  agent's crate, read by agent/protocol/spec.py (`RATE`, `MAX_AGE`, `NEIGHBOUR_TIMEOUT`);
- the fluid (beta, mu, h, dt, ...): agent/sph/params.py `SPHParams`, checked equal to the crate's;
- the imitation's materials: coordinator/control/material.py; its steps and controller:
  coordinator/control/imitation_setup.py `DEFAULT_STEPS`, `DEFAULT_CONTROLLER`;
- a camera's pace (fps, stall seconds): perception/stream.py `StreamParams`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from agent.protocol import keys
from agent.protocol.errors import UserError
from agent.protocol.spec import MAX_AGE, MODES, RATE, SyncMode
from agent.sph.radio import PERFECT, RadioModel
from agent.sph.robot import POINT, RobotModel
from coordinator.control.imitation_setup import DEFAULT_CONTROLLER, DEFAULT_STEPS
from fluidswarm.orchestration.split_options import SHARE_KINDS, WORKERS_TIMEOUT
from perception.stream import StreamParams

AGENTS = 60  # an imitation's swarm (imitate, imitate --camera, a scenario file that names none)
LAUNCH_AGENTS = 16  # launch's block
VERIFY_AGENTS = 64  # verify's block against the reference driver
CAMERA_FPS = StreamParams.fps  # imitate --camera: at most this many frames observed per second
CAMERA_STALL_SECONDS = StreamParams.stall_seconds  # imitate --camera: no new frame for this long is an error
MAX_AGENTS = keys.MAX_AGENTS  # every id has its key (docs/protocol.md); one host's router may hold fewer
SYNC_OPTION = "--sync"  # the option of every command that picks it (launch also takes its old name --mode)


def agents_problem(agents: int) -> str | None:
    """What is wrong with a swarm of `agents` (None: nothing), wherever it runs."""
    if not 1 <= agents <= MAX_AGENTS:
        return f"must be in 1..{MAX_AGENTS}, got {agents}"
    return None


def check_agents(agents: int, embedded: bool) -> None:
    """`--agents` of a command, checked once: on a router of the run's own (`embedded`) first against what that
    router holds (its ids at the access level, swarmhost/launcher.py check_swarm_size: the line names them),
    then against every run's bounds."""
    if embedded:
        from swarmhost.launcher import check_swarm_size

        check_swarm_size(agents)
    check("--agents", agents_problem(agents))


def positive_problem(value: float) -> str | None:
    """What is wrong with a value that must be a positive finite number (an async agent's rate, max_age)."""
    if not (value > 0 and math.isfinite(value)):
        return f"must be > 0 and finite, got {value}"
    return None


def check(where: str, problem: str | None) -> None:
    """The edge's one line for a value's problem: UserError "<where>: <problem>" (nothing when None)."""
    if problem is not None:
        raise UserError(f"{where}: {problem}")


@dataclass(frozen=True)
class Sync:
    """How the agents keep time (docs/protocol.md): mode SyncMode.LOCKSTEP or .ASYNC (or its name); rate
    [steps/s] each async agent aims for; max_age [s] after which an async neighbour state is not used. The
    defaults are the agent's own (agent/protocol/spec.py RATE, MAX_AGE)."""

    mode: SyncMode = SyncMode.LOCKSTEP
    rate: float = RATE
    max_age: float = MAX_AGE

    def __post_init__(self) -> None:
        object.__setattr__(self, "mode", SyncMode(self.mode))  # a mode's name (CLI, scenario) is that mode

    def spec(self) -> dict:
        return {"mode": self.mode, "rate": self.rate, "max_age": self.max_age}


@dataclass(frozen=True)
class Recording:
    """What a run writes: the MCAP and pictures in `out` (None: nothing, no recorder) under `name`; `live`:
    HOST:PORT of the recorder's Foxglove server (empty: none); `ros2`: the ROS 2 router the recorder also
    publishes the run to (docs/ros2.md; empty: none); `bag`: a rosbag2 folder the MCAP is made into after the
    run (`--ros2-bag`; None: none)."""

    out: Path | None = Path("out/imitate")
    name: str = "imitate"
    live: str = ""
    ros2: str = ""
    bag: Path | None = None


@dataclass(frozen=True)
class Access:
    """Whose bus the run is on: by default a fresh run on an embedded router of its own with fresh credentials;
    with `connect` and `run` a router elsewhere and the users file `auth_file` (docs/security.md), the run split
    with `workers` other hosts (docs/multi-host.md: waited for `workers_timeout` s, cut by `shares`)."""

    connect: str | None = None
    run: str | None = None
    auth_file: str = ""
    workers: int = 0
    workers_timeout: float = WORKERS_TIMEOUT
    shares: str = SHARE_KINDS[0]


@dataclass(frozen=True)
class RunConfig:
    """One imitation run, described whole and checked at its edge (the command line builds it once, from the
    flags, `fluidswarm/imitate_commands.py`): the swarm (`agents` processes for at most `steps` steps), its
    control (`controller`, agent/protocol/command.py's commands), the robots' bodies and radios, the pacing
    (`realtime`: simulated time held to the wall clock), what is recorded and the bus it runs on."""

    agents: int = AGENTS
    steps: int = DEFAULT_STEPS
    controller: str = DEFAULT_CONTROLLER
    robot: RobotModel = POINT
    radio: RadioModel = PERFECT
    realtime: bool = False
    recording: Recording = Recording()
    access: Access = Access()


@dataclass(frozen=True)
class Camera:
    """A live source of `imitate --camera`: a device number, a stream URL, a video file played as a stream or
    `ros2:TOPIC` (through the ROS 2 router `ros2_router`); at most `fps` frames observed per second, a stall of
    `stall_seconds` is an error; `subject` a hand, a person or auto (decided from the first frames)."""

    source: str
    fps: float = CAMERA_FPS
    stall_seconds: float = CAMERA_STALL_SECONDS
    subject: str = "person"
    ros2_router: str = ""


__all__ = [
    "AGENTS",
    "LAUNCH_AGENTS",
    "MAX_AGENTS",
    "MODES",
    "SYNC_OPTION",
    "VERIFY_AGENTS",
    "Access",
    "Camera",
    "Recording",
    "RunConfig",
    "Sync",
]
