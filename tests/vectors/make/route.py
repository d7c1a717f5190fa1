"""route.json: coordinator.control.route.class_counts/class_of and RouteFollower controls."""

from __future__ import annotations

import math
import random

import numpy as np

from agent.protocol.command import Waypoint
from agent.sph.particle import NFIELDS
from coordinator.control.route import RouteFollower, class_counts, class_of

from .common import control_list


def route_vectors() -> dict:
    rng = random.Random(7)
    cases = [
        (10, [1.0, 1.0, 1.0]),
        (7, [0.1, 0.2, 0.7]),
        (5, [0.0, 1.0, 0.0, 2.0]),
        (1, [1.0, 1.0]),
        (100000, [0.1] * 10),
        (33, [1 / 3, 1 / 3, 1 / 3]),
        (30, [1e-300, 1.0]),
        (12, [1e6, 1e-6, 0.5]),
        (99, [0.3, 0.3, 0.3, 0.1]),
        (3, [2.0, 2.0, 2.0, 2.0, 2.0]),
    ]
    for _ in range(20):
        k = rng.randint(1, 64)
        cases.append((rng.randint(1, 100000), [rng.choice([0.0, rng.random(), rng.uniform(0, 1e6)]) for _ in range(k)]))
    class_cases = []
    for n, shares in cases:
        if sum(shares) <= 0:
            shares[0] = 1.0
        ids = sorted(
            {0, 1, n // 3, n // 2, n - 2 if n > 1 else 0, n - 1, n, n + 1, n + 2, n + 7, n + 1000}
            | {rng.randrange(n) for _ in range(20)}
        )
        class_cases.append(
            {
                "n": n,
                "shares": shares,
                "counts": class_counts(n, shares),
                "ids": ids,
                "classes": [class_of(i, n, shares) for i in ids],
            }
        )

    def wp(x, y, r, beta=None, mu=None):
        return Waypoint(x, y, r, 1.5, 2.5, beta, mu)

    # A position where Python's d**2 (the C library's pow) is not d*d and that decides `reached`.
    d = pow_case(rng)
    routes = [
        (
            [wp(0.0, 0.0, 1.0, beta=5.0), wp(10.0, 0.0, 1.0, mu=0.5), wp(10.0, 10.0, 2.0, beta=1.0, mu=0.0)],
            2.0,
            0.0,
            [
                (5.0, 5.0),
                (0.5, 0.5),
                (0.0, 0.0),
                (3.0, 4.0),
                (10.0, 1.0),
                (10.0, 1.0000000000000002),
                (10.0, 8.0),
                (10.0, 10.0),
                (0.0, 0.0),
            ],
        ),
        # reached at exactly r (3-4-5), chained waypoints passed in one call
        (
            [wp(3.0, 4.0, 5.0), wp(0.0, 0.0, 5.0, beta=7.0), wp(1.0, 1.0, 0.1, mu=3.0)],
            2.0,
            0.0,
            [(0.0, 0.0), (1.0, 1.0), (1.0, 1.05)],
        ),
        ([wp(0.0, 0.0, 0.0, beta=9.0)], 3.0, 1.0, [(0.0, 0.0), (1e-300, 0.0), (-0.0, -0.0)]),
        (
            [wp(0.1, 0.2, 0.3), wp(0.7, 0.1, 0.2)],
            2.0,
            0.0,
            [(0.1 + 0.2, 0.2), (0.4, 0.2), (0.30000000000000004, 0.4), (0.5, 0.1), (0.7, 0.30000000000000004)],
        ),
        ([wp(0.0, 0.0, d["r"], beta=8.0), wp(1.0, 1.0, 0.0)], 2.0, 0.0, [(d["x"], d["y"])]),
    ]
    route_cases = []
    for route, beta, mu, positions in routes:
        f = RouteFollower(route, beta, mu)
        outs = []
        for x, y in positions:
            state = np.zeros(NFIELDS)
            state[0], state[1] = x, y
            c = f.control(state, 0)
            outs.append({"position": [x, y], "control": control_list(c), "index": f.index})
        route_cases.append(
            {
                "route": [[w.x, w.y, w.r, w.s, w.alpha, w.beta, w.mu] for w in route],
                "beta": beta,
                "mu": mu,
                "steps": outs,
            }
        )
    return {"class_of": class_cases, "route_follower": route_cases}


def pow_case(rng) -> dict:
    """A position (x, y) and radius r around the origin with x**2 + y**2 <= r*r for Python's `**` (the C
    library's pow, which rounds x**2 below x*x here) but x*x + y*y > r*r."""
    while True:
        x = rng.uniform(0.5, 2.0)
        if not x**2 < x * x:
            continue
        r = x
        for _ in range(8):
            r = math.nextafter(r, math.inf)
            y = math.sqrt(r * r - x**2)
            for _ in range(8):
                if x**2 + y**2 <= r * r < x * x + y * y:
                    return {"x": x, "y": y, "r": r}
                y = math.nextafter(y, math.inf)
