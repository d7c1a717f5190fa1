"""How an agent follows a gesture command, decided locally from its id (pure, deterministic).

The same `RouteFollower`, `FillFollower` and `class_of` run inside every agent process and in the reference
drivers: the agent crate's route.rs, through agent._native (typed wrappers here), so a swarm that follows a
command can be checked against the centralised solver.
"""

from __future__ import annotations

import os

import numpy as np

from agent.fill import zone_tuples
from agent.protocol.command import CommandRejected, decode
from agent.records import native
from agent.sph.particle import Control, X, Y


def class_counts(n: int, shares) -> list[int]:
    """Largest-remainder split of n particles over the class shares (deterministic)."""
    return native.route_class_counts(int(n), [float(s) for s in shares])


def class_of(agent_id: int, n: int, shares) -> int:
    """The class of particle `agent_id` (ids 0..n-1 in order fill class 0, then 1, ...); ids >= n (late
    joiners) are spread over the classes round-robin."""
    return native.route_class_of(int(agent_id), int(n), [float(s) for s in shares])


class RouteFollower:
    """Waypoint after waypoint: advance when within r of the current one (the last one is kept); switch
    beta/mu when a waypoint that names them is reached (route.rs RouteFollower)."""

    def __init__(self, route, beta: float, mu: float, push=(0.0, 0.0)):
        self.route = list(route)
        waypoints = [(w.x, w.y, w.r, w.s, w.alpha, w.beta, w.mu) for w in self.route]
        self._native = native.RouteFollower(waypoints, float(beta), float(mu), (float(push[0]), float(push[1])))

    @property
    def index(self) -> int:
        return self._native.index

    @property
    def beta(self) -> float:
        return self._native.beta

    @property
    def mu(self) -> float:
        return self._native.mu

    def control(self, state: np.ndarray, step: int) -> Control:
        return Control(*self._native.control(float(state[X]), float(state[Y])))


class FillFollower:
    """The fill law (agent/fill.py): no body force inside the shape, eq. 6.2 towards the nearest boundary
    point outside it (r = 0, so the pull fades to nothing on the boundary); the stiffness and viscosity of
    the zone the particle is in, else the command's (route.rs FillFollower)."""

    index = 0  # no waypoints: reported as waypoint 0

    def __init__(self, fill, beta: float, mu: float):
        rings = [[(float(x), float(y)) for x, y in ring] for ring in fill.rings]
        self._native = native.FillFollower(rings, fill.alpha, fill.s, zone_tuples(fill.zones), float(beta), float(mu))

    def control(self, state: np.ndarray, step: int) -> Control:
        return Control(*self._native.control(float(state[X]), float(state[Y])))


def follower(command, particle_class: int):
    """What an agent of `particle_class` follows: the command's shape if it has one, else its class' route."""
    if command.fill is not None:
        return FillFollower(command.fill, command.beta, command.mu)
    return RouteFollower(command.classes[particle_class].route, command.beta, command.mu)


def followers_for(command, ids) -> list:
    """The reference drivers' controls for a command: what each agent would decide for itself."""
    shares = [c.share for c in command.classes]
    return [follower(command, class_of(int(i), command.n_agents, shares)) for i in ids]


class CommandFollower:
    """The command follower of the agent process (ported to agent/native/src/route.rs): accepts signed commands,
    follows its class' route. Kept here as the oracle of the shared test vectors (tests/vectors) and the
    reference drivers."""

    def __init__(self, spec):
        self._decode = decode
        self.secret = bytes.fromhex(spec.secret or os.environ.get("FLUIDSWARM_SECRET", ""))
        self.agent_id = spec.id
        self.static = spec.static_control()
        self.command = None
        self.pending = None
        self._current_payload: bytes | None = None
        self._replays: set[bytes] = set()
        self.follower: RouteFollower | FillFollower | None = None
        self.particle_class = 0
        self.accepted = 0
        self.first_command_at: float | None = None

    def offer(self, payload: bytes) -> str | None:
        # The coordinator republishes the current command every 0.2 s, and a captured old command replayed
        # is the same bytes again: both are settled without decoding (a flood must not starve the agent).
        # The one encoder writes a command as one string of bytes, so only those bytes are a republication.
        if payload == self._current_payload:
            return None
        if payload in self._replays:
            return "replay"
        try:
            cmd = self._decode(payload, self.secret)
        except CommandRejected as exc:
            return exc.reason
        newest = self.pending or self.command
        if newest is not None and cmd.seq <= newest.seq:  # other bytes than the newest's (checked above)
            if len(self._replays) < 64:  # authentic but old: it stays a replay (seq only grows)
                self._replays.add(bytes(payload))
            return "replay"
        self._current_payload = bytes(payload)
        self.pending = cmd
        self.accepted += 1
        if self.first_command_at is None:
            import time

            self.first_command_at = time.time()
        return None

    @property
    def has_command(self) -> bool:
        return self.pending is not None or self.command is not None

    def control(self, state: np.ndarray, step: int) -> Control:
        if self.pending is not None:  # a new gesture takes effect at the agent's next step
            self.command, self.pending = self.pending, None
            shares = [c.share for c in self.command.classes]
            self.particle_class = class_of(self.agent_id, self.command.n_agents, shares)
            self.follower = follower(self.command, self.particle_class)
        if self.follower is None:
            return self.static
        return self.follower.control(state, step)

    def report(self) -> dict:
        return {
            "commands_accepted": self.accepted,
            "particle_class": self.particle_class,
            "waypoint_index": self.follower.index if self.follower else -1,
            "command_seq": self.command.seq if self.command else -1,
            "first_command_at": self.first_command_at,
        }
