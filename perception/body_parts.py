"""A standing person's silhouette -> head, torso (with the legs) and arms, as the thesis' ch. 6 uses them.

The body's axis is the median over rows of each row's middle silhouette column (an arm held out on one
side moves few rows' middles). The head's top is where the silhouette, followed upwards along the axis from
its centroid row, ends. Lengths are shares of the person's visible height L (head top to the lowest
silhouette row), after the usual proportions of an adult (a head is about 1/8 of the height, the shoulders
about 1/4 of it wide, the crotch at about half of it); the clips cut the feet off, so L is a little shorter
than the body and the shares are a little larger than those proportions.

- head (with the neck): rows from the head top to the shoulders (shoulder_share * L below it), the run of
  silhouette through the axis in each row, at most head_half_share * L either side of the axis.
- torso: from the shoulders, the silhouette inside a band either side of the axis down to the hips
  (hip_share * L below the head top), and all of the silhouette below the hips (legs, apart or not). The
  band is as wide as the body at the waist (the median width of the silhouette's run through the axis
  between waist_rows of L: below the elbows of raised or sideways arms), kept between torso_half_min and
  torso_half_max of L either side (a loose jacket is torso, hanging arms beside the hips are not).
- arms: the rest of the silhouette above the hips (beside the torso, beside or above the head: a raised
  upper arm starts at the shoulder); the biggest part on each side of the axis is that side's arm
  (left/right as seen in the picture). In a clip, a part that moves (thesis §5.2: the arms are the moving
  parts; a loose jacket's sides beside the torso band stay still); if nothing moves on a side, a still part
  as long as an arm (ARM_MIN_LENGTH of L, ARM_MIN_ELONGATION) is a still arm (e.g. one hanging down).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from perception.ellipses import fit_ellipse

MIN_ARM_AREA = 5  # pixels: smaller leftovers beside the torso are the outline's noise, not an arm
ARM_MIN_LENGTH = 0.25  # of L: a still part beside the torso this long (an upper arm and more) can be an arm
ARM_MIN_ELONGATION = 2.5  # l_major / l_minor of a still arm (a jacket's edge is short, a hanging arm long)


@dataclass(frozen=True)
class BodyShares:
    """Body proportions as shares of the visible height L (head top to lowest silhouette row).

    shoulder_share: 0.2 (a head is ~1/8 of the standing height, the neck a little more; L misses the feet).
    head_half_share: 0.1 (half a head's width, ~1/16 of the height, plus a pixel of outline).
    waist_rows: (0.3, 0.5) of L below the head top (chest to waist).
    torso_half_min, torso_half_max: 0.1, 0.22 (half a waist width is ~1/12 of the height, half the shoulders'
        ~1/8; with a loose jacket a little more).
    hip_share: 0.55 (the crotch is at about half the standing height).
    """

    shoulder_share: float = 0.2
    head_half_share: float = 0.1
    waist_rows: tuple[float, float] = (0.3, 0.5)
    torso_half_min: float = 0.1
    torso_half_max: float = 0.22
    hip_share: float = 0.55


@dataclass
class BodyParts:
    """Boolean masks of the silhouette's shape (None when that part is not found); axis column, head top row."""

    head: np.ndarray | None
    torso: np.ndarray | None
    left_arm: np.ndarray | None
    right_arm: np.ndarray | None
    axis: int
    head_top: int


def body_axis(silhouette: np.ndarray) -> int:
    """The median over rows of each row's middle silhouette column."""
    mids = [np.median(np.flatnonzero(row)) for row in silhouette if row.any()]
    return int(round(float(np.median(mids))))


def head_top(silhouette: np.ndarray, axis: int, gap_share: float = 0.08) -> int:
    """Where the silhouette ends, followed upwards along the axis (3 columns) from its centroid row; gaps of
    up to gap_share of the silhouette's height are crossed (a wall-coloured belt or midriff)."""
    cols = np.asarray(silhouette[:, max(0, axis - 1) : axis + 2].any(axis=1))
    ys = np.nonzero(silhouette)[0]
    gap = max(2, int(round(gap_share * (ys.max() - ys.min() + 1))))
    r = int(round(ys.mean()))
    on = np.flatnonzero(cols)
    if len(on) == 0:  # nothing on the axis (a silhouette that is no standing person): its top
        return int(ys.min())
    if not cols[r]:  # the centroid row misses the axis (e.g. arms up pull it high): the nearest row on it
        r = int(on[np.argmin(np.abs(on - r))])
    above = on[on < r][::-1]
    for row in above:
        if r - row > gap + 1:
            break
        r = int(row)
    return r


def _run_through(row: np.ndarray, col: int) -> np.ndarray:
    """The row's run of True that contains col, or the run nearest to it (boolean row)."""
    out = np.zeros_like(row)
    on = np.flatnonzero(row)
    if len(on) == 0:
        return out
    c = int(on[np.argmin(np.abs(on - col))])
    left = right = c
    while left > 0 and row[left - 1]:
        left -= 1
    while right < len(row) - 1 and row[right + 1]:
        right += 1
    out[left : right + 1] = True
    return out


def _largest(mask: np.ndarray, min_area: int) -> np.ndarray | None:
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 1:
        return None
    i = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return labels == i if stats[i, cv2.CC_STAT_AREA] >= min_area else None


def split_body(
    silhouette: np.ndarray, moving: np.ndarray | None = None, shares: BodyShares = BodyShares()
) -> BodyParts:
    """Head, torso (with legs), left and right arm of a standing person's silhouette (see the module
    docstring); `moving`: the frame's moving pixels, if it is a clip's frame (arms are then what moves)."""
    sil = np.asarray(silhouette, bool)
    if not sil.any():
        return BodyParts(None, None, None, None, sil.shape[1] // 2, 0)
    axis = body_axis(sil)
    top = head_top(sil, axis)
    bottom = int(np.flatnonzero(sil.any(axis=1))[-1])
    height = bottom - top + 1
    r_shoulders = top + max(2, int(round(shares.shoulder_share * height)))
    r_hips = top + int(round(shares.hip_share * height))
    waist = [
        int(_run_through(sil[r], axis).sum())
        for r in range(top + int(shares.waist_rows[0] * height), top + int(shares.waist_rows[1] * height) + 1)
    ]
    half = float(np.median(waist)) / 2 if waist else 0.0
    half = max(2, int(round(np.clip(half, shares.torso_half_min * height, shares.torso_half_max * height))))
    head_half = max(1, int(round(shares.head_half_share * height)))
    head = np.zeros_like(sil)
    for r in range(top, min(r_shoulders, bottom + 1)):
        head[r] = _run_through(sil[r], axis)
    head[:, : max(0, axis - head_half)] = False
    head[:, axis + head_half + 1 :] = False
    band = np.zeros_like(sil)
    band[r_shoulders:r_hips, max(0, axis - half) : axis + half + 1] = True
    torso = sil & band
    torso[r_hips:] = sil[r_hips:]
    rest = sil & ~head & ~torso
    rest[r_hips:] = False
    moves = None
    if moving is not None:
        moves = cv2.dilate(np.asarray(moving, np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    arms = []
    for side in (slice(0, axis), slice(axis + 1, None)):
        part = np.zeros_like(rest)
        part[:, side] = rest[:, side]
        arm = _largest(part & moves, MIN_ARM_AREA) if moves is not None else _largest(part, MIN_ARM_AREA)
        if arm is None and moves is not None:
            still = _largest(part, MIN_ARM_AREA)
            arm = still if still is not None and _arm_shaped(still, ARM_MIN_LENGTH * height) else None
        arms.append(arm)
    return BodyParts(head if head.any() else None, torso if torso.any() else None, arms[0], arms[1], axis, top)


def _arm_shaped(part: np.ndarray, min_length: float) -> bool:
    e = fit_ellipse(part)
    return e is not None and e.l_major >= min_length and e.l_major >= ARM_MIN_ELONGATION * e.l_minor
