"""fill.json: agent.fill.inside/nearest_point and FillFollower controls, and
agent.protocol.command.edges_cross."""

from __future__ import annotations

import math
import random

import numpy as np

from agent.fill import inside, nearest_point
from agent.protocol.command import Fill, Zone, edges_cross
from agent.sph.particle import NFIELDS
from coordinator.control.route import FillFollower

from .common import control_list
from .shapes import photo_command, square, zone_list


def fill_vectors() -> dict:
    rng = random.Random(13)
    photo = photo_command().fill
    shapes = [
        (
            "square_with_hole",
            (((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)), ((4.0, 4.0), (6.0, 4.0), (6.0, 6.0), (4.0, 6.0))),
            80.0,
            0.2,
        ),
        ("photo", photo.rings, photo.alpha, photo.s, photo.zones),
        (
            "square_with_overlapping_zones",
            (((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)),),
            80.0,
            0.2,
            (Zone(3.0, 4.0, 0.6, 0.8, 3.0, 1.5, 20.0, 1.0), Zone(5.0, 5.0, 1.0, 0.0, 2.0, 2.0, 5.0, 0.0)),
        ),
        (
            "u_shape_clockwise",
            (((0.0, 0.0), (0.0, 6.0), (1.0, 6.0), (1.0, 1.0), (3.0, 1.0), (3.0, 6.0), (4.0, 6.0), (4.0, 0.0)),),
            50.0,
            0.5,
        ),
        (
            "triangle_duplicate_vertex_and_spike",
            (((0.1, 0.2), (0.1, 0.2), (3.3, 0.7), (1.7, 2.9), (1.7, 4.0), (1.7, 2.9)),),
            1e4,
            0.0,
        ),
        (
            "two_islands",
            (((-5.0, -5.0), (-1.0, -5.0), (-3.0, -1.0)), ((1.0, 1.0), (5.0, 1.0), (5.0, 5.0), (1.0, 5.0))),
            0.0,
            1.0,
        ),
    ]
    cases = []
    for name, rings, alpha, s, *rest in shapes:
        zones = rest[0] if rest else ()
        pts = {(x, y) for ring in rings for x, y in ring}  # on the vertices
        for z in zones:  # on the zones' axes' ends and just inside/outside them
            for t in (1.0, math.nextafter(1.0, 0.0), math.nextafter(1.0, 2.0)):
                pts |= {(z.x + t * z.a * z.ux, z.y + t * z.a * z.uy), (z.x - t * z.b * z.uy, z.y + t * z.b * z.ux)}
        for ring in rings:  # on and next to the edges' midpoints, and on the horizontal lines of the vertices
            for k in range(len(ring)):
                (x1, y1), (x2, y2) = ring[k], ring[(k + 1) % len(ring)]
                mx, my = x1 + 0.5 * (x2 - x1), y1 + 0.5 * (y2 - y1)
                pts |= {
                    (mx, my),
                    (math.nextafter(mx, math.inf), my),
                    (mx, math.nextafter(my, -math.inf)),
                    (mx + 0.05, my + 0.05),
                    (mx - 0.3, y1),
                }
        xs = [x for ring in rings for x, _ in ring]
        ys = [y for ring in rings for _, y in ring]
        x0, x1, y0, y1 = min(xs) - 2.0, max(xs) + 2.0, min(ys) - 2.0, max(ys) + 2.0
        for _ in range(60):
            pts.add((rng.uniform(x0, x1), rng.uniform(y0, y1)))
        pts |= {(x0 - 1e3, y0), (0.1 + 0.2, 0.30000000000000004), (-0.0, -0.0)}
        f = FillFollower(Fill(rings, alpha, s, zones), 2.0, 0.2)
        steps = []
        for x, y in sorted(pts):
            state = np.zeros(NFIELDS)
            state[0], state[1] = x, y
            steps.append(
                {
                    "position": [x, y],
                    "inside": inside(rings, x, y),
                    "nearest": list(nearest_point(rings, x, y)),
                    "control": control_list(f.control(state, 0)),
                }
            )
        cases.append(
            {
                "name": name,
                "rings": [[list(v) for v in ring] for ring in rings],
                "alpha": alpha,
                "s": s,
                "zones": [zone_list(z) for z in zones],
                "beta": 2.0,
                "mu": 0.2,
                "steps": steps,
            }
        )
    assert any(st["inside"] for c in cases for st in c["steps"]) and not all(
        st["inside"] for c in cases for st in c["steps"]
    )

    crossing = [
        [[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]],  # bow-tie
        [square(0.0, 0.0, 2.0), square(1.0, 1.0, 2.0)],
        [square(0.0, 0.0, 1.0), square(1.0, 1.0, 1.0)],  # touching at a vertex
        [square(0.0, 0.0, 10.0), square(4.0, 4.0, 2.0)],  # a hole
        [[[0.0, 0.0], [4.0, 0.0], [2.0, 0.0], [2.0, 3.0]]],  # collinear spike
        [[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]], [[2.0, 0.0], [3.0, -1.0], [1.0, -1.0]]],  # a vertex on an edge
        [[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]], [[2.0, 1e-300], [3.0, -1.0], [1.0, -1.0]]],  # just across
        [[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]], [[2.0, -1e-300], [3.0, -1.0], [1.0, -1.0]]],  # just outside
        [[[0.1, 0.1], [0.7, 0.1], [0.7, 0.30000000000000004]], [[0.30000000000000004, 0.1], [0.5, -0.2], [0.2, -0.2]]],
        [[list(v) for v in ring] for ring in photo.rings],
    ]
    for _ in range(30):  # random quadrilaterals and triangles: some cross, some do not
        crossing.append(
            [
                [
                    [round(rng.uniform(-1, 1), rng.randint(1, 17)), round(rng.uniform(-1, 1), rng.randint(1, 17))]
                    for _ in range(rng.choice([3, 4, 5]))
                ]
                for _ in range(rng.choice([1, 2]))
            ]
        )
    cross_cases = [
        {"rings": rings, "cross": edges_cross([[tuple(v) for v in ring] for ring in rings])} for rings in crossing
    ]
    assert any(c["cross"] for c in cross_cases) and not all(c["cross"] for c in cross_cases)
    return {"followers": cases, "edges_cross": cross_cases}
