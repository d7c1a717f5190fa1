"""Ellipse regions (thesis §6.2.3, eq. 6.1): each focus region -> (l_major, l_minor, orientation, x_c, y_c).

All figures are in PIXELS of the picture given: x = column, y = row (rows grow downwards).

- l_major, l_minor: full lengths of the axes (not semi-axes).
- orientation_deg: angle of the major axis in [0, 180), measured from the +x (column) axis towards the
  top of the picture (counter-clockwise as seen on screen): 0 = horizontal, 90 = vertical.
- x_c, y_c: centre.

The thesis measures the axes between extreme pixels of a region. We use the region's second moments
instead, which is exact for a filled ellipse (variance along an axis of length l is l^2/16) and less
sensitive to a ragged outline: l = 4 sqrt(eigenvalue of the pixel covariance).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import cv2
import numpy as np

MIN_FINGER_AREA_SHARE = 0.006  # of the hand's area... of the picture; smaller bits are noise
PALM_SCALE = 1.55  # the palm disc is this many times the largest inscribed circle's radius


@dataclass(frozen=True)
class Ellipse:
    """An ellipse in pixel coordinates (x = column, y = row); see the module docstring."""

    l_major: float
    l_minor: float
    orientation_deg: float
    x_c: float
    y_c: float

    def as_dict(self) -> dict:
        return {k: round(float(v), 2) for k, v in asdict(self).items()}

    def cv_box(self):
        """As OpenCV's RotatedRect ((cx, cy), (w, h), angle) for cv2.ellipse (angle clockwise on screen)."""
        return ((self.x_c, self.y_c), (self.l_major, self.l_minor), -self.orientation_deg)


def fit_ellipse(region: np.ndarray) -> Ellipse | None:
    """The moment ellipse of a boolean region (None if it has fewer than 3 pixels)."""
    ys, xs = np.nonzero(region)
    if len(xs) < 3:
        return None
    x_c, y_c = xs.mean(), ys.mean()
    cov = np.cov(np.stack([xs - x_c, ys - y_c]).astype(np.float64), bias=True)
    lam, vec = np.linalg.eigh(cov)
    lam = np.maximum(lam, 0.0)
    major = vec[:, 1]
    # image y grows down: flip its sign so the angle is counter-clockwise as seen on screen
    angle = np.degrees(np.arctan2(-major[1], major[0])) % 180.0
    # a filled ellipse sampled on the pixel grid: variance = l^2/16 (+1/12 from pixel width, negligible)
    return Ellipse(
        float(4 * np.sqrt(lam[1] + 1 / 12)), float(4 * np.sqrt(lam[0] + 1 / 12)), float(angle), float(x_c), float(y_c)
    )


def _wrist_side(mask: np.ndarray) -> str | None:
    """The picture border the hand touches most (the arm leaves the picture there), or None."""
    contact = {"bottom": mask[-1].sum(), "top": mask[0].sum(), "left": mask[:, 0].sum(), "right": mask[:, -1].sum()}
    side = max(contact, key=lambda k: contact[k])
    return side if contact[side] > 0 else None


def hand_regions(mask: np.ndarray) -> dict:
    """Focus regions of a hand silhouette (thesis §6.2.2-6.2.3), in pixels.

    palm: the largest inscribed circle of the silhouette (distance transform maximum), grown by
    PALM_SCALE, intersected with the silhouette. Fingers: the components of the silhouette outside the
    palm disc, minus the wrist/arm (the component that reaches the wrist border; default bottom).
    Returns {'palm': Ellipse, 'fingers': [Ellipse...], 'critical_points': {'centre_of_mass', 'image_centre',
    'palm_centre', 'first_joints': [(x, y)...], 'finger_tips': [(x, y)...]}, 'wrist_side': str|None}.
    A first joint is the finger pixel nearest the palm centre (where the finger leaves the palm); a tip is
    the finger pixel farthest from it.
    """
    mask = np.asarray(mask, bool)
    if not mask.any():
        raise ValueError("empty silhouette")
    m8 = mask.astype(np.uint8)
    dist = cv2.distanceTransform(np.pad(m8, 1), cv2.DIST_L2, 5)[1:-1, 1:-1]
    py, px = np.unravel_index(int(np.argmax(dist)), dist.shape)
    radius = float(dist[py, px])
    yy, xx = np.mgrid[: mask.shape[0], : mask.shape[1]]
    d_palm = np.hypot(xx - px, yy - py)
    palm_disc = d_palm <= PALM_SCALE * radius
    palm = mask & palm_disc
    wrist = _wrist_side(mask)
    min_area = max(4, int(MIN_FINGER_AREA_SHARE * mask.size))
    n, labels, stats, _ = cv2.connectedComponentsWithStats((mask & ~palm_disc).astype(np.uint8), connectivity=8)
    fingers, joints, tips = [], [], []
    for i in range(1, n):
        if stats[i, cv2.CC_STAT_AREA] < min_area:
            continue
        comp = labels == i
        if wrist is not None and _touches(comp, wrist) and _towards(comp, (px, py), wrist, mask.shape):
            continue  # the wrist / forearm
        e = fit_ellipse(comp)
        if e is None:
            continue
        ys, xs = np.nonzero(comp)
        d = d_palm[ys, xs]
        fingers.append(e)
        joints.append((float(xs[np.argmin(d)]), float(ys[np.argmin(d)])))
        tips.append((float(xs[np.argmax(d)]), float(ys[np.argmax(d)])))
    order: np.ndarray | list[int] = np.argsort([t[0] for t in tips]) if tips else []
    ys, xs = np.nonzero(mask)
    return {
        "palm": fit_ellipse(palm),
        "fingers": [fingers[i] for i in order],
        "critical_points": {
            "centre_of_mass": (float(xs.mean()), float(ys.mean())),
            "image_centre": ((mask.shape[1] - 1) / 2.0, (mask.shape[0] - 1) / 2.0),
            "palm_centre": (float(px), float(py)),
            "first_joints": [joints[i] for i in order],
            "finger_tips": [tips[i] for i in order],
        },
        "palm_radius": radius,
        "wrist_side": wrist,
    }


def _touches(comp: np.ndarray, side: str) -> bool:
    return bool({"bottom": comp[-1], "top": comp[0], "left": comp[:, 0], "right": comp[:, -1]}[side].any())


def _towards(comp: np.ndarray, centre, side: str, shape) -> bool:
    """Is the component on the wrist's side of the palm centre (not a finger cut by the same border)?"""
    ys, xs = np.nonzero(comp)
    dx, dy = xs.mean() - centre[0], ys.mean() - centre[1]
    direction = {"bottom": (0, 1), "top": (0, -1), "left": (-1, 0), "right": (1, 0)}[side]
    return dx * direction[0] + dy * direction[1] > 0


def body_regions(regions) -> dict:
    """Ellipses of one frame's `perception.segmentation.PersonRegions` (thesis §6.2.3, Fig. 6.7).

    Returns {'torso', 'head', 'left_arm', 'right_arm'}: Ellipse or None (region not found).
    """
    return {
        "torso": fit_ellipse(regions.torso) if regions.torso is not None else None,
        "head": fit_ellipse(regions.head) if regions.head is not None else None,
        "left_arm": fit_ellipse(regions.left_arm) if regions.left_arm is not None else None,
        "right_arm": fit_ellipse(regions.right_arm) if regions.right_arm is not None else None,
    }
