"""How an agent follows a gesture command, decided locally from its id (pure, deterministic).

The same `RouteFollower`, `FillFollower`, `CommandFollower` and `class_of` run inside every agent process and
in the reference drivers: the agent crate's route.rs, through agent._native (typed wrappers here), so a swarm
that follows a command can be checked against the centralised solver.
"""

from __future__ import annotations

import os
import time

import numpy as np

from agent.fill import zone_tuples
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
    """The agent's command follower (route.rs CommandFollower, through agent._native): accepts signed commands
    (republications settled without decoding, replays and forgeries refused and named), follows the newest
    from its next step, its class' route or the command's shape. The shared test vectors
    (tests/vectors/command_sequences.json) record what it decides."""

    def __init__(self, spec):
        secret = bytes.fromhex(spec.secret or os.environ.get("FLUIDSWARM_SECRET", ""))
        c = spec.static_control()
        static = (float(c.wx), float(c.wy), float(c.r), float(c.s), float(c.alpha), float(c.beta), float(c.mu))
        self._native = native.CommandFollower(secret, int(spec.id), (*static, float(c.push_x), float(c.push_y)))

    def offer(self, payload: bytes) -> str | None:
        """None: accepted (or the current command again); else the reason it was refused."""
        return self._native.offer(bytes(payload), time.time())

    @property
    def has_command(self) -> bool:
        return self._native.has_command

    def control(self, state: np.ndarray, step: int) -> Control:
        return Control(*self._native.control(float(state[X]), float(state[Y])))

    @property
    def accepted(self) -> int:
        return self._native.report()[0]

    @property
    def particle_class(self) -> int:
        return self._native.report()[1]

    def report(self) -> dict:
        accepted, particle_class, waypoint, seq, first_at = self._native.report()
        return {
            "commands_accepted": accepted,
            "particle_class": particle_class,
            "waypoint_index": waypoint,
            "command_seq": seq,
            "first_command_at": first_at,
        }
