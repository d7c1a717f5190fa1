"""The fill law: a particle outside the commanded shape is pulled to its nearest point, one inside is free.

The coordinator broadcasts the observed silhouette as a few rings (polygons, metres, eroded by half a
particle spacing so that boundary particles' discs end on the silhouette's edge, not across it). Each agent
decides its own body force from its own position only: inside the shape (even-odd rule over all rings, so
a ring inside another is a hole) no force; outside, the thesis' body force (eq. 6.2) towards the nearest
point of the shape's boundary, a stiff wall. Pressure does the rest: the swarm is set up slightly
compressed (the transform gives each particle less area than the Tait rest density asks for), so the fluid
spreads until the walls hold it, the way a liquid fills a vessel.

One implementation, the agent crate's fill.rs (through agent._native): the agents and the reference drivers
run the same arithmetic (tests/vectors/fill.json pins it).
"""

from __future__ import annotations

from collections.abc import Sequence

from agent.records import native

Ring = Sequence[tuple[float, float]]


def _rings(rings: Sequence[Ring]) -> list[list[tuple[float, float]]]:
    return [[(float(x), float(y)) for x, y in ring] for ring in rings]


def inside(rings: Sequence[Ring], x: float, y: float) -> bool:
    """Even-odd rule over every edge of every ring (a ring inside another ring is a hole)."""
    return native.fill_inside(_rings(rings), float(x), float(y))


def nearest_point(rings: Sequence[Ring], x: float, y: float) -> tuple[float, float]:
    """The point of the rings' edges nearest to (x, y); the first one found on a tie."""
    return native.fill_nearest_point(_rings(rings), float(x), float(y))


def zone_tuples(zones) -> list[tuple[float, float, float, float, float, float, float, float]]:
    """Zones (agent/protocol/command.py `Zone`) as agent._native takes them."""
    return [(z.x, z.y, z.ux, z.uy, z.a, z.b, z.beta, z.mu) for z in zones]


def zone_material(zones, x: float, y: float, beta: float, mu: float) -> tuple[float, float]:
    """(beta, mu) of the first zone (an ellipse, agent/protocol/command.py `Zone`) that holds (x, y); the
    given ones where none does."""
    return native.fill_zone_material(zone_tuples(zones), float(x), float(y), float(beta), float(mu))
