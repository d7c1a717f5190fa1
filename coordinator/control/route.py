"""How an agent follows a gesture command, decided locally from its id (pure, deterministic).

The same `RouteFollower` and `class_of` run inside every agent process and in the reference drivers, so
a swarm that follows a command can be checked against the centralised solver.
"""

from __future__ import annotations

import math
import os

import numpy as np

from agent.fill import inside, nearest_point, zone_material
from agent.protocol.command import CommandRejected, decode
from agent.sph.particle import Control, X, Y


def class_counts(n: int, shares) -> list[int]:
    """Largest-remainder split of n particles over the class shares (deterministic)."""
    total = float(sum(shares))
    exact = [n * s / total for s in shares]
    counts = [math.floor(e) for e in exact]
    rest = n - sum(counts)
    order = sorted(range(len(shares)), key=lambda k: (-(exact[k] - counts[k]), k))
    for k in order[:rest]:
        counts[k] += 1
    return counts


def class_of(agent_id: int, n: int, shares) -> int:
    """The class of particle `agent_id` (ids 0..n-1 in order fill class 0, then 1, ...); ids >= n (late
    joiners) are spread over the classes round-robin."""
    counts = class_counts(n, shares)
    if agent_id >= n:
        nonzero = [k for k, c in enumerate(counts) if c > 0]
        return nonzero[agent_id % len(nonzero)]
    edge = 0
    for k, c in enumerate(counts):
        edge += c
        if agent_id < edge:
            return k
    return len(counts) - 1


class RouteFollower:
    """Waypoint after waypoint: advance when within r of the current one (the last one is kept); switch
    beta/mu when a waypoint that names them is reached."""

    def __init__(self, route, beta: float, mu: float, push=(0.0, 0.0)):
        self.route = list(route)
        self.index = 0
        self.beta, self.mu = beta, mu
        self.push = push

    def control(self, state: np.ndarray, step: int) -> Control:
        while True:
            w = self.route[self.index]
            reached = (state[X] - w.x) ** 2 + (state[Y] - w.y) ** 2 <= w.r * w.r
            if not reached:
                break
            if w.beta is not None:
                self.beta = w.beta
            if w.mu is not None:
                self.mu = w.mu
            if self.index + 1 >= len(self.route):
                break
            self.index += 1
        w = self.route[self.index]
        return Control(w.x, w.y, w.r, w.s, w.alpha, self.beta, self.mu, *self.push)


class FillFollower:
    """The fill law (agent/fill.py): no body force inside the shape, eq. 6.2 towards the nearest boundary
    point outside it (r = 0, so the pull fades to nothing on the boundary); the stiffness and viscosity of
    the zone the particle is in (`zone_material`), else the command's."""

    def __init__(self, fill, beta: float, mu: float):
        self.rings, self.alpha, self.s, self.zones = fill.rings, fill.alpha, fill.s, fill.zones
        self.beta, self.mu = beta, mu
        self.index = 0  # no waypoints: reported as waypoint 0

    def control(self, state: np.ndarray, step: int) -> Control:
        x, y = state[X], state[Y]
        beta, mu = zone_material(self.zones, x, y, self.beta, self.mu)
        if inside(self.rings, x, y):
            return Control(x, y, 0.0, self.s, 0.0, beta, mu)
        px, py = nearest_point(self.rings, x, y)
        return Control(px, py, 0.0, self.s, self.alpha, beta, mu)


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
