"""The fill law: a particle outside the commanded shape is pulled to its nearest point, one inside is free.

The coordinator broadcasts the observed silhouette as a few rings (polygons, metres, eroded by half a
particle spacing so that boundary particles' discs end on the silhouette's edge, not across it). Each agent
decides its own body force from its own position only: inside the shape (even-odd rule over all rings, so
a ring inside another is a hole) no force; outside, the thesis' body force (eq. 6.2) towards the nearest
point of the shape's boundary, a stiff wall. Pressure does the rest: the swarm is set up slightly
compressed (the transform gives each particle less area than the Tait rest density asks for), so the fluid
spreads until the walls hold it, the way a liquid fills a vessel.

Pure arithmetic in a fixed order: agent/native/src/fill.rs repeats it operation for operation, so the
native swarm equals the reference drivers to rounding (tests/vectors/fill.json checks both).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

Ring = Sequence[tuple[float, float]]


def inside(rings: Sequence[Ring], x: float, y: float) -> bool:
    """Even-odd rule over every edge of every ring (a ring inside another ring is a hole)."""
    odd = False
    for ring in rings:
        n = len(ring)
        for k in range(n):
            x1, y1 = ring[k]
            x2, y2 = ring[(k + 1) % n]
            if (y1 > y) != (y2 > y):
                xc = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
                if x < xc:
                    odd = not odd
    return odd


def nearest_point(rings: Sequence[Ring], x: float, y: float) -> tuple[float, float]:
    """The point of the rings' edges nearest to (x, y); the first one found on a tie."""
    best = math.inf
    bx, by = x, y
    for ring in rings:
        n = len(ring)
        for k in range(n):
            x1, y1 = ring[k]
            x2, y2 = ring[(k + 1) % n]
            ex, ey = x2 - x1, y2 - y1
            ll = ex * ex + ey * ey
            t = 0.0
            if ll > 0.0:
                t = ((x - x1) * ex + (y - y1) * ey) / ll
                t = min(1.0, max(0.0, t))
            px, py = x1 + t * ex, y1 + t * ey
            d2 = (x - px) * (x - px) + (y - py) * (y - py)
            if d2 < best:
                best, bx, by = d2, px, py
    return bx, by


def zone_material(zones, x: float, y: float, beta: float, mu: float) -> tuple[float, float]:
    """(beta, mu) of the first zone (an ellipse, agent/protocol/command.py `Zone`) that holds (x, y); the
    given ones where none does."""
    for z in zones:
        dx, dy = x - z.x, y - z.y
        p = (dx * z.ux + dy * z.uy) / z.a
        q = (dy * z.ux - dx * z.uy) / z.b
        if p * p + q * q <= 1.0:
            return z.beta, z.mu
    return beta, mu
