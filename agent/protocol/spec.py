"""What one agent process is told at start (its command line, as JSON), validated once at the edge.

Besides its spec an agent reads only its environment's FLUIDSWARM_SECRET (the command key, when the spec's
`secret` is empty) and FLUIDSWARM_ZENOH_USER / FLUIDSWARM_ZENOH_PASSWORD (its credentials, docs/security.md):
secrets stay out of argv. It sets ZENOH_RUNTIME for itself, over any value given (zenoh's thread layout,
measured: docs/protocol.md, "Inside an agent process"); no other variable of ours changes what it does.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from enum import StrEnum

from agent.protocol.keys import MAX_AGENTS, valid_run_name
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


@dataclass(frozen=True)
class NeighbourTimeouts:
    """s an agent waits for a silent expected neighbour before it drops it (frozen or lost), by kind of run.

    Written here once; every command and run kind takes its value from `NEIGHBOUR_TIMEOUT`.
    default     launch, physics experiments: a frozen neighbour costs the swarm this long
    imitation   imitate (file, camera): up to 300 agents share 2 cores with perception and the recorder
    benchmark   bench: N = 1000 on 2 cores, a step can take seconds while the links are full
    exact       verify: never drop a neighbour that is merely slow (exactness with both cores busy)
    """

    default: float = 2.0
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
    start_timeout: float = 120.0
    drop_out: float = 0.0
    secret: str = ""
    join: bool = False
    state_key_ids: bool = False
    mode: str = SyncMode.LOCKSTEP
    rate: float = 12.0
    max_age: float = 1.0
    neighbours: list = field(default_factory=list)
    robot: dict = field(default_factory=dict)
    radio: dict = field(default_factory=dict)
    obstacles: list = field(default_factory=list)

    def to_json(self) -> str:
        fields = asdict(self)
        if not fields["radio"]:
            del fields["radio"]  # a perfect radio is the default: the spec of a run without one is as before
        if not fields["obstacles"]:
            del fields["obstacles"]  # likewise an empty domain
        return json.dumps(fields, separators=(",", ":"))

    @classmethod
    def from_json(cls, text: str) -> AgentSpec:
        try:
            raw = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"agent spec: not JSON ({exc.msg})") from None
        except RecursionError:  # found by fuzzing (tests/vectors/fuzz.json): deeper than json's stack
            raise ValueError("agent spec: not JSON (nested too deep)") from None
        if not isinstance(raw, dict):
            raise ValueError("agent spec: must be a JSON object")  # noqa: TRY004  # callers catch ValueError: bad input
        known = set(cls.__dataclass_fields__)
        unknown = set(raw) - known
        if unknown:
            raise ValueError(f"agent spec: unknown field {min(unknown)!r}")
        try:
            spec = cls(**raw)
        except TypeError as exc:
            raise ValueError(f"agent spec: {exc}") from None
        spec.validate()
        return spec

    def validate(self) -> None:
        if not isinstance(self.run, str) or not valid_run_name(self.run):
            raise ValueError(f"agent spec: run {self.run!r} must be 1-64 letters, digits, '-' or '_'")
        if not isinstance(self.id, int) or isinstance(self.id, bool) or not 0 <= self.id < MAX_AGENTS:
            # only these ids have a key (keys.id_chunk); the native agent refuses the same (spec.rs)
            raise ValueError(f"agent spec: id must be an integer in [0, {MAX_AGENTS}), got {self.id!r}")
        if not isinstance(self.steps, int) or self.steps < 0:
            raise ValueError(f"agent spec: steps must be a non-negative integer, got {self.steps!r}")
        if (
            not isinstance(self.initial, list)
            or len(self.initial) != 4
            or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in self.initial)
        ):
            raise ValueError(f"agent spec: initial must be [x, y, vx, vy] finite numbers, got {self.initial!r}")
        if not isinstance(self.connect, list) or not all(isinstance(e, str) and e for e in self.connect):
            raise ValueError("agent spec: connect must be a list of endpoints")
        if self.mode not in MODES:
            raise ValueError(f"agent spec: mode must be one of {MODES}, got {self.mode!r}")
        for name in ("timeout", "start_timeout", "rate", "max_age"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"agent spec: {name} must be > 0, got {v!r}")
        if not isinstance(self.drop_out, (int, float)) or not 0 <= self.drop_out < 1:
            raise ValueError(f"agent spec: drop_out must be in [0, 1), got {self.drop_out!r}")
        if not isinstance(self.neighbours, list) or not all(
            isinstance(n, list)
            and len(n) == 3
            and isinstance(n[0], int)
            and not isinstance(n[0], bool)
            and 0 <= n[0] < MAX_AGENTS
            and all(isinstance(v, (int, float)) and math.isfinite(v) for v in n[1:])
            for n in self.neighbours
        ):
            raise ValueError(
                f"agent spec: neighbours must be a list of [id, x, y] (id in [0, {MAX_AGENTS}), x, y finite)"
            )
        self.robot_model().check_fits(self.sph_params().v_max)
        radio = self.radio_model()
        if self.mode == SyncMode.ASYNC and not radio.is_perfect:
            raise ValueError("agent spec: radio: the imperfect radio is modelled in lockstep only (mode async)")
        self.static_control()
        self.obstacle_list()

    def robot_model(self) -> RobotModel:
        if not isinstance(self.robot, dict):
            raise ValueError(f"agent spec: robot must be an object, got {self.robot!r}")  # noqa: TRY004  # spec errors are ValueErrors: one kind for the caller
        try:
            return RobotModel(**self.robot)
        except TypeError as exc:
            raise ValueError(f"agent spec: robot: {exc}") from None

    def radio_model(self) -> RadioModel:
        if not isinstance(self.radio, dict):
            raise ValueError(f"agent spec: radio must be an object, got {self.radio!r}")  # noqa: TRY004  # spec errors are ValueErrors: one kind for the caller
        try:
            return RadioModel(**self.radio)
        except TypeError as exc:
            raise ValueError(f"agent spec: radio: {exc}") from None
        except ValueError as exc:
            raise ValueError(f"agent spec: {exc}") from None

    def obstacle_list(self) -> tuple[Obstacle, ...]:
        try:
            return obstacles_from(self.obstacles, "obstacles")
        except ValueError as exc:
            raise ValueError(f"agent spec: {exc}") from None

    def sph_params(self) -> SPHParams:
        if not isinstance(self.params, dict):
            raise ValueError(f"agent spec: params must be an object, got {self.params!r}")  # noqa: TRY004  # spec errors are ValueErrors: one kind for the caller
        p = dict(self.params)
        try:
            if "domain" in p:
                p["domain"] = tuple(p["domain"])
            return SPHParams(**p)
        except (TypeError, ValueError) as exc:  # SPHParams' own checks name the field (found by fuzzing)
            raise ValueError(f"agent spec: params: {exc}") from None

    def static_control(self) -> Control:
        try:
            c = Control(**self.control)
        except TypeError as exc:
            raise ValueError(f"agent spec: control: {exc}") from None
        for name, v in asdict(c).items():
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"agent spec: control.{name} must be a finite number, got {v!r}")
        return c
