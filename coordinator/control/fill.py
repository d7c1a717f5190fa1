"""Fill controller (default): the silhouette itself, as a few polygons, is the command.

The thesis' controllers send particles to waypoints (region centres, templates); the swarm then sits in
clumps at those points. Here the coordinator broadcasts the observed shape and the agents fill it like a
liquid fills a vessel (agent/fill.py): no force inside, a stiff pull back from outside, and a fluid set up
slightly compressed so that pressure spreads it over the whole shape.

Three choices, measured on the shared hand photos with the reference solver (docs/fill.md):
- Area per particle 1.7 m^2 (hexagonal spacing 1.40 m = 1.4 h). Closer spacings (0.9-1.4 m^2) pair
  particles up: the Gaussian kernel's gradient falls to zero at r -> 0, so two particles closer than
  ~0.7 h stop repelling each other (nn_cv 0.3-0.6). The rest density follows from the area:
  rho0 = COMPRESSION x the density of a hexagonal lattice of that spacing, so the fluid is in compression
  (a Tait pressure below zero pulls particles together).
- The vessel is the silhouette eroded by half a spacing (a boundary particle's disc then ends on the edge),
  but never by more than half of a part's own half-width: a finger narrower than one spacing keeps its
  central band instead of vanishing from the vessel (IoU 0.75 -> 0.80 over 50 photos).
- Stiffness beta 2 and viscosity mu 0.2 everywhere: a stiffer fluid (beta 5-20) rings and clumps.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from agent.protocol.command import (
    MAX_RINGS,
    MAX_VERTICES,
    MAX_ZONES,
    Fill,
    GestureCommand,
    ParticleClass,
    Waypoint,
    Zone,
    edges_cross,
)
from agent.protocol.errors import UserError
from agent.sph.kernel import gaussian_kernel
from agent.sph.params import SPHParams
from coordinator.control.geometry import ImageToDomain
from coordinator.control.material import BETA, MU

AREA_PER_PARTICLE = 1.7  # m^2 of silhouette per particle
COMPRESSION = 0.85  # rest density / the density the area calls for
THIN_PART = 0.5  # erode a thin part by at most this fraction of its half-width
ALPHA, RAMP = 80.0, 0.2  # the wall: 80 1/s^2 over 0.2 m (at most 16 m/s^2 back into the shape)
ZONE_GROW = 1.2  # a moment ellipse (4 sigma) stops short of a part's ends
INITIAL_SPACING = 1.2  # m, the starting lattice at the palm / torso centre
MIN_PIXELS = 20  # a smaller silhouette does not say what shape it is (a coarse one is fine: a 64 px clip's
# person of ~200 pixels still outlines 300 particles; where a spacing is under a pixel the
# vessel is the whole silhouette)
MIN_FILLABLE = 0.25  # the vessel must keep at least this share of the silhouette (else: too thin / fragmented)


class ShapeError(UserError, ValueError):
    """The silhouette cannot be filled by the swarm (too small, too thin or too fragmented)."""


def spacing(area_per_particle: float = AREA_PER_PARTICLE) -> float:
    """Side of the hexagonal lattice whose cells have this area [m]."""
    return math.sqrt(2.0 * area_per_particle / math.sqrt(3.0))


def rest_density(params: SPHParams, area_per_particle: float = AREA_PER_PARTICLE) -> float:
    """COMPRESSION x the summation density (eq. 3.9) of an infinite hexagonal lattice with this cell area."""
    d = spacing(area_per_particle)
    k = np.arange(-8, 9)
    i, j = np.meshgrid(k, k)
    r = np.hypot(d * (i + 0.5 * j), d * (math.sqrt(3.0) / 2.0) * j).ravel()
    return COMPRESSION * float(np.sum(params.mass * gaussian_kernel(r, params.h, params.kappa)))


def vessel(mask: np.ndarray, erode_px: float) -> np.ndarray:
    """The silhouette eroded by `erode_px`, except that a part thinner than that keeps its central band."""
    m = np.pad(mask.astype(np.uint8), 1)
    dist = cv2.distanceTransform(m, cv2.DIST_L2, 5)[1:-1, 1:-1]
    rad = max(1, int(round(2 * erode_px)))
    thickness = cv2.dilate(dist, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * rad + 1, 2 * rad + 1)))
    return dist > np.minimum(erode_px, THIN_PART * thickness)


def shape_rings(
    mask: np.ndarray, transform: ImageToDomain, n_agents: int
) -> tuple[tuple[tuple[float, float], ...], ...]:
    """The vessel as polygons in domain metres (outer boundaries and holes), at most MAX_VERTICES vertices."""
    area_px = int(np.count_nonzero(mask))
    if area_px < MIN_PIXELS:
        raise ShapeError(
            f"the silhouette has {area_px} pixels: too small to say what shape to fill (at least {MIN_PIXELS})"
        )
    erode_px = 0.5 * spacing() / transform.scale
    v = vessel(mask, erode_px).astype(np.uint8)
    if np.count_nonzero(v) < MIN_FILLABLE * area_px:
        raise ShapeError(
            f"the silhouette is too thin or fragmented for {n_agents} particles: only "
            f"{np.count_nonzero(v) / area_px:.0%} of it is wider than a particle spacing"
        )
    contours, _ = cv2.findContours(v, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_SIMPLE)
    # Parts smaller than a tenth of a particle's area are noise, not something to fill.
    min_px = 0.1 * AREA_PER_PARTICLE / transform.scale**2
    contours = sorted((c for c in contours if cv2.contourArea(c) >= min_px), key=cv2.contourArea, reverse=True)
    contours = contours[:MAX_RINGS]
    if not contours:
        raise ShapeError(f"the silhouette is too small or too thin for {n_agents} particles")
    for eps in (1.0, 1.5, 2.25, 3.4, 5.0, 7.6):
        rings: list[tuple[tuple[float, float], ...]] = []
        for c in contours:
            # approxPolyDP may make a simplified ring cross itself or a neighbour; the traced contour
            # never does, so fall back towards it, ring by ring.
            for e in (eps, 0.7 * eps, 0.5, 0.3, 0.0):
                poly = (cv2.approxPolyDP(c, e, True) if e > 0 else c).reshape(-1, 2).astype(float)
                if len(poly) < 3:
                    break
                xy = transform.to_domain(poly + 0.5)  # pixel centres, exact with transform_for's scale
                ring = tuple((float(x), float(y)) for x, y in xy)
                if not edges_cross(rings + [ring]):
                    rings.append(ring)
                    break
        if rings and sum(len(r) for r in rings) <= MAX_VERTICES:
            return tuple(rings)
    raise ShapeError(f"the silhouette's outline needs more than {MAX_VERTICES} vertices")


def material_zones(ellipses, transform: ImageToDomain, beta: float, mu: float) -> tuple[Zone, ...]:
    """Zones (agent/protocol/command.py) of the given pixel ellipses (perception/ellipses.py), grown by
    ZONE_GROW so that they reach the part's outline, all of one material."""
    zones = []
    for e in ellipses[:MAX_ZONES]:
        x, y = transform.to_domain(np.array([e.x_c, e.y_c]) + 0.5)
        angle = math.radians(e.orientation_deg)  # counter-clockwise on screen = in the domain (y up)
        a = max(0.5 * ZONE_GROW * e.l_major * transform.scale, 1e-3)
        b = max(0.5 * ZONE_GROW * e.l_minor * transform.scale, 1e-3)
        zones.append(Zone(float(x), float(y), math.cos(angle), math.sin(angle), a, b, beta, mu))
    return tuple(zones)


def fill_command(
    mask: np.ndarray,
    transform: ImageToDomain,
    n_agents: int,
    seq: int = 1,
    gesture: str = "fill",
    zones: tuple[Zone, ...] = (),
) -> GestureCommand:
    """The command that makes `n_agents` particles fill `mask` (seen through `transform`); `zones` are
    the parts where the fluid is another material (`material_zones`)."""
    rings = shape_rings(mask, transform, n_agents)
    ys, xs = np.nonzero(mask)
    cx, cy = transform.to_domain(np.array([xs.mean(), ys.mean()]) + 0.5)
    # One class: with a shape, routes are not followed; the class names what the particles do.
    fill_class = ParticleClass("fill", 1.0, (Waypoint(float(cx), float(cy), 0.0, 0.0, 0.0),))
    extra = {"controller": "fill", "rings": len(rings), "vertices": sum(len(r) for r in rings)}
    if zones:
        extra["zones"] = len(zones)
    return GestureCommand(seq, gesture[:64], n_agents, (fill_class,), BETA, MU, extra, Fill(rings, ALPHA, RAMP, zones))
