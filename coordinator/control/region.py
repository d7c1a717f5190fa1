"""Region controller (thesis ch. 6, extended): a silhouette -> routes that fill it.

The thesis fits ellipses to focus regions and sends particles to the region centres, branching by raising
the stiffness at the critical point. We go further so the swarm *fills* the shape: the silhouette is cut
into K compact regions (k-means on its pixels), each becomes a particle class whose share of the swarm is
proportional to its area; every route starts at the palm/torso centre (the common first waypoint) and ends
at its region's centre with a no-force radius that lets the class spread over the region. Regions far from
the centre (fingers, arms) switch to a higher stiffness when they arrive, as the thesis' branching does.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from agent.protocol.command import GestureCommand, ParticleClass, Waypoint
from coordinator.control.geometry import ImageToDomain
from coordinator.control.material import BETA, MU

# m^2 of silhouette per particle: 1.4 gave the best fidelity over 8 shared photos in a sweep of
# {1.1, 1.4, 1.8, 2.4} (reference solver, 60 particles, 450 steps; min IoU 0.556, mean 0.590).
AREA_PER_PARTICLE = 1.4


def fit_transform(mask: np.ndarray, n_agents: int, area_per_particle: float = AREA_PER_PARTICLE) -> ImageToDomain:
    """Scale the picture so the silhouette's area is what n_agents particles cover; image at the origin."""
    area_px = max(int(mask.sum()), 1)
    scale = math.sqrt(n_agents * area_per_particle / area_px)
    rows = mask.shape[0]
    return ImageToDomain(scale=scale, x0=0.0, y0=rows * scale)


def domain_for(mask: np.ndarray, transform: ImageToDomain, margin: float = 6.0) -> tuple[float, float, float, float]:
    rows, cols = mask.shape[:2]
    return (-margin, cols * transform.scale + margin, -margin, rows * transform.scale + margin)


def centre_px(mask: np.ndarray) -> tuple[float, float]:
    """The silhouette's most interior point (distance-transform maximum): palm or torso centre."""
    dist = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, 5)
    v, u = np.unravel_index(int(np.argmax(dist)), dist.shape)
    return float(u), float(v)


def regions(mask: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """k compact regions of the silhouette: (centres (k, 2) in pixels (u, v), pixel counts (k,))."""
    centres, counts, _us, _vs, _labels = _region_labels(mask, k)
    return centres, counts


def region_command(
    mask: np.ndarray,
    transform: ImageToDomain,
    n_agents: int,
    seq: int = 1,
    gesture: str = "regions",
    k: int | None = None,
    beta_far: float | None = None,
    alpha: float = 4.0,
) -> GestureCommand:
    """K = N/3 regions (about 3 particles each); gain alpha = 4 1/s^2 (a sweep of {1.5, 4} favoured the
    stronger pull). beta_far, if given, is the stiffness the outer regions switch to on arrival (the
    thesis' branching; off by default because it lowered the fill in our sweep)."""
    k = k or int(np.clip(round(n_agents / 3), 4, 30))
    cu, cv = centre_px(mask)
    centre = transform.to_domain(np.array([cu, cv]))
    cents, counts = regions(mask, k)
    cents_m = transform.to_domain(cents)
    far = np.hypot(cents_m[:, 0] - centre[0], cents_m[:, 1] - centre[1])
    order = np.argsort(far, kind="stable")  # classes from the centre outwards
    reach = float(np.percentile(far, 60)) if len(far) > 1 else 0.0
    # The common first waypoint (palm/torso centre) is reached by every particle of the compact start
    # blob at once: a smaller radius makes a crowd orbit the centre, unable to get within it.
    start_radius = max(1.5, math.sqrt(n_agents / math.pi) + 0.5)
    classes = []
    for rank, j in enumerate(order):
        area_m2 = counts[j] * transform.scale**2
        eq_radius = math.sqrt(area_m2 / math.pi)
        first = Waypoint(float(centre[0]), float(centre[1]), r=start_radius, s=2.0, alpha=alpha)
        last = Waypoint(
            float(cents_m[j, 0]),
            float(cents_m[j, 1]),
            r=0.5 * eq_radius,
            s=2.0,
            alpha=alpha,
            beta=beta_far if (beta_far is not None and far[j] > reach) else None,
        )
        classes.append(ParticleClass(f"region{rank}", float(counts[j]), (first, last)))
    extra = {"controller": "region", "centre": [float(centre[0]), float(centre[1])], "k": int(k)}
    return GestureCommand(
        seq=seq, gesture=gesture, n_agents=int(n_agents), classes=tuple(classes), beta=BETA, mu=MU, extra=extra
    )


def _region_labels(mask: np.ndarray, k: int):
    """Like `regions`, with each silhouette pixel's region: (centres (k, 2) (u, v), counts (k,), us, vs, labels)."""
    vs, us = np.nonzero(mask)
    pts = np.stack([us, vs], axis=1).astype(np.float32)
    k = max(1, min(k, len(pts)))
    cv2.setRNGSeed(12345)
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 0.05)
    # cv2's stubs require bestLabels; the binding takes None (no initial labels)
    _c, labels, centres = cv2.kmeans(pts, k, None, criteria, 4, cv2.KMEANS_PP_CENTERS)  # type: ignore[call-overload]
    labels = labels.ravel()
    return centres.astype(float), np.bincount(labels, minlength=k), us, vs, labels


ARM_PARTS = ("left_arm", "right_arm")


def body_region_command(
    mask: np.ndarray,
    parts: dict,
    transform: ImageToDomain,
    n_agents: int,
    seq: int = 1,
    gesture: str = "body",
    k: int | None = None,
    alpha: float = 4.0,
    beta_arm: float = 20.0,
) -> GestureCommand:
    """A person's silhouette (thesis ch. 6, body poses): the same fill by K compact regions, each region
    belonging to the part (torso, left arm, right arm) most of its pixels lie in. Every route starts at
    the torso centre; an arm region's route then passes the shoulder (the arm pixel nearest the torso
    centre, the critical point), where its particles switch to the arms' stiffness (thesis: beta 2 -> 20),
    and ends at the region's centre. Class names say the part: torso0.., left_arm0.., right_arm0.."""
    k = k or int(np.clip(round(n_agents / 3), 4, 30))
    torso = parts.get("torso")
    if torso is not None and torso.any():
        ty, tx = np.nonzero(torso)
        cu, cv = float(tx.mean()), float(ty.mean())
    else:
        cu, cv = centre_px(mask)
    centre = transform.to_domain(np.array([cu, cv]))
    cents, counts, us, vs, labels = _region_labels(mask, k)
    cents_m = transform.to_domain(cents)
    part_names = ["torso"] + [p for p in ARM_PARTS if p in parts]
    owner = []
    for j in range(len(cents)):
        sel = labels == j
        votes = [int(parts[p][vs[sel], us[sel]].sum()) if p in parts else 0 for p in part_names]
        votes[0] = max(votes[0], 0)
        best = int(np.argmax(votes))
        # regions the arms do not claim (torso, head, legs) belong to the body
        owner.append(part_names[best] if best > 0 and votes[best] > 0.3 * sel.sum() else "torso")
    shoulders = {}
    for p in ARM_PARTS:
        if p in parts:
            ay, ax = np.nonzero(parts[p])
            i = int(np.argmin(np.hypot(ax - cu, ay - cv)))
            shoulders[p] = transform.to_domain(np.array([float(ax[i]), float(ay[i])]))
    start_radius = max(1.5, math.sqrt(n_agents / math.pi) + 0.5)
    far = np.hypot(cents_m[:, 0] - centre[0], cents_m[:, 1] - centre[1])
    classes = []
    counter: dict[str, int] = {}
    for j in np.argsort(far, kind="stable"):
        part = owner[j]
        eq_radius = math.sqrt(counts[j] * transform.scale**2 / math.pi)
        route = [Waypoint(float(centre[0]), float(centre[1]), r=start_radius, s=2.0, alpha=alpha)]
        if part in shoulders:
            sx, sy = shoulders[part]
            route.append(Waypoint(float(sx), float(sy), r=1.5, s=2.0, alpha=alpha, beta=beta_arm))
        route.append(Waypoint(float(cents_m[j, 0]), float(cents_m[j, 1]), r=0.5 * eq_radius, s=2.0, alpha=alpha))
        name = f"{part}{counter.get(part, 0)}"
        counter[part] = counter.get(part, 0) + 1
        classes.append(ParticleClass(name, float(counts[j]), tuple(route)))
    extra = {"controller": "region", "kind": "body", "centre": [float(centre[0]), float(centre[1])], "k": int(k)}
    return GestureCommand(
        seq=seq, gesture=gesture[:64], n_agents=int(n_agents), classes=tuple(classes), beta=BETA, mu=MU, extra=extra
    )
