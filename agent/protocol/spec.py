"""What one agent process is told at start (its command line, as JSON): a typed wrapper of the one
implementation, the agent crate's spec.rs (through agent._native). `to_json` checks every field and writes it
with the encoder the agent decodes with (`spec_encode`); `from_json` reads with the agent's own decoder
(`spec_decode`): one set of checks, one set of defaults (the optional fields' come from the crate too).

Besides its spec an agent reads only its environment's FLUIDSWARM_SECRET (the command key, when the spec's
`secret` is empty) and FLUIDSWARM_ZENOH_USER / FLUIDSWARM_ZENOH_PASSWORD (its credentials, docs/security.md):
secrets stay out of argv. It sets ZENOH_RUNTIME for itself, over any value given (zenoh's thread layout,
measured: docs/protocol.md, "Inside an agent process"); no other variable of ours changes what it does.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from enum import StrEnum

from agent.records import native
from agent.sph.obstacles import Obstacle, obstacles_from
from agent.sph.params import SPHParams
from agent.sph.particle import Control
from agent.sph.radio import RadioModel
from agent.sph.robot import RobotModel


class SyncMode(StrEnum):
    """How the agents keep step: lockstep (a step waits for every neighbour's previous one: exact, the
    reference drivers' result) or async (each agent at its own rate on its neighbours' latest states)."""

    LOCKSTEP = "lockstep"
    ASYNC = "async"


MODES = tuple(m.value for m in SyncMode)
# What an async agent is told when its spec leaves them out: the crate's (spec.rs), the one declaration.
RATE = native.SPEC_DEFAULT_RATE  # steps/s an async agent aims for
MAX_AGE = native.SPEC_DEFAULT_MAX_AGE  # s: an older neighbour state is not used


@dataclass(frozen=True)
class NeighbourTimeouts:
    """s an agent waits for a silent expected neighbour before it drops it (frozen or lost), by kind of run.

    Written here once; every command and run kind takes its value from `NEIGHBOUR_TIMEOUT`.
    default     launch, physics experiments: a frozen neighbour costs the swarm this long
    imitation   imitate (file, camera): up to 300 agents share 2 cores with perception and the recorder
    benchmark   bench: N = 1000 on 2 cores, a step can take seconds while the links are full
    exact       verify: never drop a neighbour that is merely slow (exactness with both cores busy)
    """

    default: float = native.SPEC_DEFAULT_TIMEOUT  # the agent's own default (spec.rs)
    imitation: float = 5.0
    benchmark: float = 10.0
    exact: float = 15.0


NEIGHBOUR_TIMEOUT = NeighbourTimeouts()


@dataclass
class AgentSpec:
    """One agent's start-up parameters.

    run            run name (one key chunk)
    id             this agent's particle id (0 .. keys.MAX_AGENTS - 1)
    connect        Zenoh endpoints to connect to, e.g. ["tcp/127.0.0.1:7447"]
    steps          number of steps to run (lockstep)
    initial        [x, y, vx, vy] in m and m/s
    control        the static Control fields (used until a gesture command arrives)
    params         SPHParams fields
    timeout        s: a neighbour silent this long in one step is dropped (frozen or lost)
    start_timeout  s: give up if the launcher's start signal does not come
    drop_out       fraction [0, 1) of this agent's outgoing state messages to drop (failure injection)
    secret         hex key of the run's command signatures (HMAC-SHA256), never sent on the bus
    join           True for a late joiner: adopt the swarm's current step instead of waiting for start
    state_key_ids  a router with per-process rights: the agent puts its states on state/<id> (the launcher's
                   relay puts them on the cell keys), instead of on its cell's key (docs/protocol.md)
    inbox          the launcher's embedded router hands the agent its neighbours' states in one message per
                   lockstep step on inbox/<id>, after the cells it names on watch/<id> (needs state_key_ids;
                   agent/native/src/relay/inboxes.rs), instead of a subscription per cell
    mode           "lockstep" (wait for every expected neighbour's state of the same step; reproducible) or
                   "async" (step on the agent's own clock with the latest neighbour states; docs/protocol.md)
    rate           steps/s an async agent aims for (its own clock); a late agent does not race to catch up
    max_age        s: in async mode a neighbour state older than this is not used (frozen, gone or far)
    neighbours     [[id, x, y], ...]: agents placed near this one; those in its watched cells are its step-0
                   neighbours (swarmhost/initial_neighbours.py)
    robot          the particle's body and drive, RobotModel fields (agent/sph/robot.py; {}: a point)
    radio          what its radio and localisation make of the states it receives, RadioModel fields
                   (agent/sph/radio.py: loss, latency, noise, seed; {}: perfect; lockstep only)
    obstacles      the domain's static obstacles, [{"kind": "circle", "centre": [x, y], "radius": r} |
                   {"kind": "polygon", "vertices": [[x, y], ...]}, ...] (agent/sph/obstacles.py; []: none)
    """

    run: str
    id: int
    connect: list[str]
    steps: int
    initial: list[float]
    control: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    timeout: float = NEIGHBOUR_TIMEOUT.default
    start_timeout: float = native.SPEC_DEFAULT_START_TIMEOUT
    drop_out: float = 0.0
    secret: str = ""
    join: bool = False
    state_key_ids: bool = False
    inbox: bool = False
    mode: str = SyncMode.LOCKSTEP
    rate: float = RATE
    max_age: float = MAX_AGE
    neighbours: list = field(default_factory=list)
    robot: dict = field(default_factory=dict)
    radio: dict = field(default_factory=dict)
    obstacles: list = field(default_factory=list)

    def to_json(self) -> str:
        """The spec as the agent reads it; ValueError ("agent spec: <field> ...") if a field is malformed."""
        # Its fields as they are, not dataclasses.asdict's deep copy of every list and dict (nothing nested is a
        # dataclass): the copy was a third of a launcher's time per agent started (0.3 s of 300 spawns).
        return native.spec_encode({f.name: getattr(self, f.name) for f in fields(self)})

    @classmethod
    def from_json(cls, text: str) -> AgentSpec:
        """The spec in `text` as the agent reads it; ValueError naming the field if it would refuse it."""
        return cls(**native.spec_decode(text))

    # The records inside, as the physics layer's objects (the reference drivers, coordinator/control/route.py):
    # conversions of a spec the agent's decoder accepted, no checks of their own.
    def robot_model(self) -> RobotModel:
        return RobotModel(**self.robot)

    def radio_model(self) -> RadioModel:
        return RadioModel(**self.radio)

    def obstacle_list(self) -> tuple[Obstacle, ...]:
        return obstacles_from(self.obstacles, "obstacles")

    def sph_params(self) -> SPHParams:
        p = dict(self.params)
        if "domain" in p:
            p["domain"] = tuple(p["domain"])
        return SPHParams(**p)

    def static_control(self) -> Control:
        return Control(**self.control)
