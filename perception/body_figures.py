"""Figures of a person's silhouette and body ellipses against labels (issue 20's acceptance; tests and
scripts/body_figures.py use them).

- head error: |the silhouette's top on the labelled head column - the labelled head-top row|. The top is the
  top of the silhouette's run, on the columns head_x - 1 .. head_x + 1, that holds a row within 3 px of the
  label (so hands above the head, apart from it, do not count; hands resting on it do).
- feet error: |the silhouette's lowest row - the labelled feet row|.
- torso: its ellipse within 25 degrees of vertical, l_major >= 18 px, centre below the head's centre.
"""

from __future__ import annotations

import numpy as np

from perception.ellipses import Ellipse

HEAD_FEET_TOLERANCE = 3  # pixels
TORSO_MAX_TILT = 25.0  # degrees from vertical
TORSO_MIN_MAJOR = 18.0  # pixels


def head_error(silhouette: np.ndarray, head_x: int, head_top: int) -> float:
    """See the module docstring; inf when the silhouette misses the head's column near the label."""
    cols = np.asarray(silhouette[:, max(0, head_x - 1) : head_x + 2].any(axis=1))
    near = [
        r
        for r in range(head_top - HEAD_FEET_TOLERANCE, head_top + HEAD_FEET_TOLERANCE + 1)
        if 0 <= r < len(cols) and cols[r]
    ]
    if not near:
        return float("inf")
    r = near[0]
    while r > 0 and cols[r - 1]:
        r -= 1
    return float(abs(r - head_top))


def feet_error(silhouette: np.ndarray, feet: int) -> float:
    rows = np.flatnonzero(silhouette.any(axis=1))
    return float(abs(rows[-1] - feet)) if len(rows) else float("inf")


def tilt_from_vertical(e: Ellipse) -> float:
    return abs(90.0 - e.orientation_deg)


def torso_upright(torso: Ellipse | None, head: Ellipse | None) -> bool:
    """Torso ellipse within TORSO_MAX_TILT of vertical, at least TORSO_MIN_MAJOR long, centre below the head's."""
    return (
        torso is not None
        and head is not None
        and tilt_from_vertical(torso) <= TORSO_MAX_TILT
        and torso.l_major >= TORSO_MIN_MAJOR
        and torso.y_c > head.y_c
    )
