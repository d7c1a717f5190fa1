"""Static obstacles in the domain and the SPH boundary force that keeps the fluid out of them (issue 33 item 3).

An obstacle is a disc (`Circle`: centre and radius) or a simple polygon (`Polygon`: vertices, closed
implicitly). The fluid flows around them through a repulsive boundary force, the Lennard-Jones form of
Monaghan (J. Comput. Phys. 110, 1994, "Simulating free surface flows with SPH", eq. 4.4 / §4): every boundary
element pushes a fluid particle a distance d from it with

    f = D ((r0/d)^p1 - (r0/d)^p2) x / d^2   for d < r0, else 0,   p1 = 12, p2 = 4,

x the vector from the element to the particle. Monaghan places boundary particles along the wall; we take,
for each obstacle *edge* (each polygon side; a circle is one edge), the edge's point nearest to the particle's
body centre as its one boundary element, so the force is normal to a flat wall, has no ripple along it and
sums the two sides' pushes in a concave corner (a convex corner, where both sides' nearest point is the shared
vertex, pushes twice). Because the force diverges at the edge a body never crosses one; the start layout is
checked to hold no body overlapping an obstacle (`check_start`).

    r0 = radius + OBSTACLE_MARGIN * h + v_max^2 / (2 a_max)
                                        where the force begins: a body touches an obstacle at d = radius, and a
                                        robot, whose drive brakes at a_max, needs its braking distance to stop
                                        (a point stops at once: no braking term). The e-puck default:
                                        0.25 + 0.125 + 0.86^2 / 3.4 = 0.593 m. Measured: without the braking
                                        term (0.375 m) 60 unicycles overlapped the obstacle_course wall 141 times.
    D  = v^2                            Monaghan: of the order of the largest speed squared; v = the robot's
                                        v_max, the fluid's v_max for a point particle (robot.py: contacts)

Sensing range: an agent uses only the obstacle edges whose nearest point lies within the kernel support
kappa h of its body centre (the range in which it hears its neighbours; r0 < kappa h at every body that
fits a start layout, so nothing the force would feel is left out). It learns the obstacles from its spec
(agent/protocol/spec.py `obstacles`).

All functions are scalar and pure (the agent's port, agent/native/src/obstacle.rs, evaluates the same
operations in the same order, so `fluidswarm verify` with obstacles stays exact).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from agent.records import native

OBSTACLE_MARGIN = 0.125  # x h: how far beyond a body's edge the boundary force begins
KINDS = ("circle", "polygon")
MAX_VERTICES = 256
MAX_COVERED = 0.5  # the largest share of a target silhouette obstacles may cover (the swarm needs room)


@dataclass(frozen=True)
class Circle:
    """A disc obstacle: centre (x, y) [m], radius [m]."""

    x: float
    y: float
    radius: float

    def as_dict(self) -> dict:
        return {"kind": "circle", "centre": [self.x, self.y], "radius": self.radius}


@dataclass(frozen=True)
class Polygon:
    """A simple polygon obstacle: vertices [(x, y), ...] [m], closed implicitly, no two sides crossing."""

    vertices: tuple[tuple[float, float], ...]

    def as_dict(self) -> dict:
        return {"kind": "polygon", "vertices": [[x, y] for x, y in self.vertices]}


Obstacle = Circle | Polygon


def _point(value, where: str) -> tuple[float, float]:
    if (
        not isinstance(value, (list, tuple))
        or len(value) != 2
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    ):
        raise ValueError(f"{where}: must be [x, y] finite numbers, got {value!r}")
    return float(value[0]), float(value[1])


def obstacle_from(table, where: str = "obstacle[0]") -> Obstacle:
    """One obstacle from its table ({kind = "circle", centre = [x, y], radius = r} or {kind = "polygon",
    vertices = [[x, y], ...]}), validated: ValueError "<where>.<key>: <problem>"."""
    if not isinstance(table, dict):
        raise ValueError(f"{where}: must be a table, got {table!r}")  # noqa: TRY004  # callers catch ValueError: bad input
    kind = table.get("kind")
    if kind not in KINDS:
        raise ValueError(f"{where}.kind: must be one of {KINDS}, got {kind!r}")
    allowed = {"kind", "centre", "radius"} if kind == "circle" else {"kind", "vertices"}
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise ValueError(f"{where}.{unknown[0]}: unknown key for a {kind} (known: {', '.join(sorted(allowed))})")
    if kind == "circle":
        for key in ("centre", "radius"):
            if key not in table:
                raise ValueError(f"{where}.{key}: missing (a circle needs centre and radius)")
        x, y = _point(table["centre"], f"{where}.centre")
        r = table["radius"]
        if not isinstance(r, (int, float)) or isinstance(r, bool) or not math.isfinite(r) or r <= 0:
            raise ValueError(f"{where}.radius: must be a finite number > 0, got {r!r}")
        return Circle(x, y, float(r))
    raw = table.get("vertices")
    if not isinstance(raw, (list, tuple)) or not 3 <= len(raw) <= MAX_VERTICES:
        raise ValueError(f"{where}.vertices: must be a list of 3 to {MAX_VERTICES} [x, y] points, got {raw!r}")
    vertices = tuple(_point(v, f"{where}.vertices[{k}]") for k, v in enumerate(raw))
    if native.fill_edges_cross([list(vertices)]):
        raise ValueError(f"{where}.vertices: the polygon intersects itself (two sides cross)")
    if abs(_signed_area(vertices)) <= 0.0:
        raise ValueError(f"{where}.vertices: the polygon has no area")
    return Polygon(vertices)


def obstacles_from(tables, where: str = "obstacle") -> tuple[Obstacle, ...]:
    """A list of obstacle tables (a scenario's [[obstacle]], a spec's `obstacles`), validated."""
    if not isinstance(tables, (list, tuple)):
        raise ValueError(f"{where}: must be a list of obstacle tables, got {tables!r}")  # noqa: TRY004  # callers catch ValueError: bad input
    return tuple(obstacle_from(t, f"{where}[{k}]") for k, t in enumerate(tables))


def _signed_area(vertices: Sequence[tuple[float, float]]) -> float:
    n = len(vertices)
    return 0.5 * sum(
        vertices[k][0] * vertices[(k + 1) % n][1] - vertices[(k + 1) % n][0] * vertices[k][1] for k in range(n)
    )


def edge_offset(x: float, y: float, x1: float, y1: float, x2: float, y2: float) -> tuple[float, float]:
    """(x, y) minus the point of the segment (x1, y1)-(x2, y2) nearest to it."""
    ex, ey = x2 - x1, y2 - y1
    ll = ex * ex + ey * ey
    t = 0.0
    if ll > 0.0:
        t = ((x - x1) * ex + (y - y1) * ey) / ll
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
    return x - (x1 + t * ex), y - (y1 + t * ey)


def circle_offset(x: float, y: float, c: Circle) -> tuple[float, float]:
    """(x, y) minus the point of the circle nearest to it (the centre itself: no direction, (0, 0))."""
    dx, dy = x - c.x, y - c.y
    dc = math.sqrt(dx * dx + dy * dy)
    if dc <= 0.0:
        return 0.0, 0.0
    k = (dc - c.radius) / dc
    return dx * k, dy * k


def boundary_term(dx: float, dy: float, r0: float, strength: float, sensing: float) -> tuple[float, float]:
    """Monaghan's (1994) repulsive boundary force per unit mass on a body whose centre is (dx, dy) from an
    edge's nearest point: D ((r0/d)^12 - (r0/d)^4) (dx, dy) / d^2 for d < r0 (and within the sensing range)."""
    d2 = dx * dx + dy * dy
    if not (d2 < r0 * r0 and d2 <= sensing * sensing and d2 > 0.0):
        return 0.0, 0.0
    q = r0 / math.sqrt(d2)
    mag = strength * (q**12 - q**4) / d2
    return mag * dx, mag * dy


def obstacle_acceleration(
    cx: float, cy: float, obstacles: Sequence[Obstacle], r0: float, strength: float, sensing: float
) -> tuple[float, float]:
    """The sum of `boundary_term` over every edge of every obstacle (in order) on the body centred at (cx, cy)."""
    ax, ay = 0.0, 0.0
    for o in obstacles:
        if isinstance(o, Circle):
            dx, dy = circle_offset(cx, cy, o)
            tx, ty = boundary_term(dx, dy, r0, strength, sensing)
            ax, ay = ax + tx, ay + ty
            continue
        v = o.vertices
        n = len(v)
        for k in range(n):
            x1, y1 = v[k]
            x2, y2 = v[(k + 1) % n]
            dx, dy = edge_offset(cx, cy, x1, y1, x2, y2)
            tx, ty = boundary_term(dx, dy, r0, strength, sensing)
            ax, ay = ax + tx, ay + ty
    return ax, ay


def inside(o: Obstacle, x: float, y: float) -> bool:
    """Is (x, y) inside the obstacle (a polygon: the even-odd rule)?"""
    if isinstance(o, Circle):
        return math.hypot(x - o.x, y - o.y) < o.radius
    odd = False
    v = o.vertices
    n = len(v)
    for k in range(n):
        (x1, y1), (x2, y2) = v[k], v[(k + 1) % n]
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            odd = not odd
    return odd


def distance(o: Obstacle, x: float, y: float) -> float:
    """Signed distance [m] from (x, y) to the obstacle's boundary: positive outside, negative inside."""
    if isinstance(o, Circle):
        return math.hypot(x - o.x, y - o.y) - o.radius
    v = o.vertices
    n = len(v)
    best = min(math.hypot(*edge_offset(x, y, *v[k], *v[(k + 1) % n])) for k in range(n))
    return -best if inside(o, x, y) else best


def clearance(x: float, y: float, obstacles: Sequence[Obstacle]) -> float:
    """The smallest signed distance from (x, y) to any of `obstacles` (inf without obstacles)."""
    return min((distance(o, x, y) for o in obstacles), default=math.inf)


def check_start(centres, obstacles: Sequence[Obstacle], radius: float, where: str = "obstacle") -> None:
    """No body of the start layout (centres (N, 2), discs of `radius`) overlaps an obstacle (ValueError naming
    the obstacle)."""
    for k, o in enumerate(obstacles):
        for x, y in centres:
            d = distance(o, float(x), float(y))
            if d < radius:
                raise ValueError(
                    f"{where}[{k}]: overlaps the swarm's start layout (a body centred at ({x:.3g}, {y:.3g}) is "
                    f"{d:.3g} m from it, bodies need {radius:g} m)"
                )


def covered_share(points, obstacles: Sequence[Obstacle]) -> float:
    """The share of `points` ((N, 2), a target silhouette's pixel centres in the domain) inside an obstacle."""
    pts = [(float(x), float(y)) for x, y in points]
    if not pts:
        return 0.0
    return sum(any(inside(o, x, y) for o in obstacles) for x, y in pts) / len(pts)


def clearances(centres, obstacles: Sequence[Obstacle]):
    """(N,) the smallest signed distance from each of `centres` ((N, 2)) to any of `obstacles` (negative:
    inside one; inf without obstacles). Vectorised over the centres, for what the recorder measures."""
    import numpy as np

    c = np.asarray(centres, dtype=float).reshape(-1, 2)
    best = np.full(len(c), np.inf)
    x, y = c[:, 0], c[:, 1]
    for o in obstacles:
        if isinstance(o, Circle):
            best = np.minimum(best, np.hypot(x - o.x, y - o.y) - o.radius)
            continue
        v = np.asarray(o.vertices, dtype=float)
        a, b = v, np.roll(v, -1, axis=0)
        e = b - a  # (E, 2)
        ll = np.maximum((e * e).sum(axis=1), 1e-300)
        t = np.clip(
            ((x[:, None] - a[None, :, 0]) * e[None, :, 0] + (y[:, None] - a[None, :, 1]) * e[None, :, 1]) / ll, 0, 1
        )
        px, py = a[None, :, 0] + t * e[None, :, 0], a[None, :, 1] + t * e[None, :, 1]
        d = np.hypot(x[:, None] - px, y[:, None] - py).min(axis=1)
        # even-odd rule, vectorised
        y1, y2 = a[None, :, 1], b[None, :, 1]
        straddle = (y1 > y[:, None]) != (y2 > y[:, None])
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = a[None, :, 0] + (y[:, None] - y1) * (b[None, :, 0] - a[None, :, 0]) / (y2 - y1)
        odd = (straddle & (x[:, None] < xc)).sum(axis=1) % 2 == 1
        best = np.minimum(best, np.where(odd, -d, d))
    return best
