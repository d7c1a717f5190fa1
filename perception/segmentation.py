"""Silhouettes: a hand on a plain background (`hand_mask`), a person in a static-camera clip (`person_regions`).

Hand silhouette from a photograph on a plain, white-ish background.

The background is bright and grey (low saturation); skin is saturated. Otsu's threshold on a blend of
saturation and darkness separates them despite the set's shadows and vignetting; morphology closes gaps
and the largest component is the hand, with the pale parts next to it that are more saturated than the
wall (raised fingers in bright light) grown back.

Person: the clip's temporal median is the background (thesis §5.2), the still body is found in it, and
each frame's whole silhouette is GrabCut seeded by the still body and the frame's motion
(perception/person.py), split into head, torso with legs and arms (perception/body_parts.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from agent.protocol.errors import UserError
from perception.body_parts import split_body
from perception.person import person_masks


class SegmentationError(UserError, ValueError):
    """No plausible silhouette in the picture (empty, blank, all white)."""


def hand_mask(image_bgr: np.ndarray) -> np.ndarray:
    """Boolean mask of the hand (largest saturated/dark component, holes filled, pale parts next to it grown
    back: `_grow_parts`)."""
    if image_bgr is None or image_bgr.size == 0:
        raise SegmentationError("empty image")
    img = image_bgr if image_bgr.ndim == 3 else cv2.cvtColor(image_bgr, cv2.COLOR_GRAY2BGR)
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    # Vignetting darkens the corners but leaves them grey: saturation carries most of the weight.
    # 0.75 saturation + 0.25 darkness (255 - value), in one pass (exact: quarters of 8-bit values)
    blend = cv2.addWeighted(hsv[..., 1], 0.75, hsv[..., 2], -0.25, 63.75, dtype=cv2.CV_32F)
    score = cv2.GaussianBlur(blend, (3, 3), 0)
    if float(score.max() - score.min()) < 12.0:
        raise SegmentationError("no foreground: the image is blank (uniform)")
    # cv2's stubs require dst; the binding takes None (a new array)
    score8 = cv2.normalize(score, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)  # type: ignore[call-overload]
    _t, fg = cv2.threshold(score8, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    k = max(3, (min(img.shape[:2]) // 50) | 1)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, kernel)
    fg = cv2.morphologyEx(fg, cv2.MORPH_CLOSE, kernel)
    n, labels, stats, _c = cv2.connectedComponentsWithStats(fg, connectivity=8)
    if n <= 1:
        raise SegmentationError("no foreground component found")
    biggest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    core = _fill((labels == biggest).astype(np.uint8)).astype(np.uint8)
    filled = _grow_parts(hsv[..., 1], core, k)
    area = int(filled.sum())
    if area < 0.01 * filled.size:
        raise SegmentationError(f"foreground too small ({area} px)")
    return filled


# Pale, brightly lit fingers raised against the white wall can fall below Otsu's threshold while the fist is
# kept. They are grown back from that core: the parts next to it, at least GROW_MIN_SHARE of the picture and
# thicker than the morphology kernel, whose saturation is above the wall's by GROW_SATURATION of the way from
# the wall's (median outside the core) to the core's. Saturation alone: a shadow is dark but as grey as the wall.
# Chosen by 5-fold cross-validation on the documented split's training part (docs/perception.md): 0.15-0.5
# alike (20-22 of 1049 wrong on ten classes, 1 of 523 on five); a lower threshold on the blend instead
# (hysteresis: shadows, vignetting, merged fingers) 0.948-0.979 on ten classes, GrabCut seeded by the core 0.978.
GROW_SATURATION = 0.3
GROW_MIN_SHARE = 0.004


def _grow_parts(saturation: np.ndarray, core: np.ndarray, k: int) -> np.ndarray:
    """`core` (uint8 0/1) with the thick, saturated-enough parts next to it added, as a filled bool mask."""
    if core.all():
        return core.astype(bool)
    sat = cv2.GaussianBlur(saturation, (3, 3), 0)  # uint8 (what np.median of its copies as float gave, exactly)
    wall, skin = _median_u8(sat, 1 - core), _median_u8(sat, core)
    low = (sat > wall + GROW_SATURATION * (skin - wall)).astype(np.uint8) & (1 - core)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    extra = cv2.morphologyEx(low, cv2.MORPH_OPEN, kernel)  # thin rims along the core's edge go
    near = cv2.dilate(core, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k + 2, k + 2)))
    _n, labels, stats, _c = cv2.connectedComponentsWithStats(extra, connectivity=8)
    grown = core.copy()
    # a cluttered picture has hundreds of parts: only those large enough are looked at, each in its own box
    for i in np.nonzero(stats[1:, cv2.CC_STAT_AREA] >= GROW_MIN_SHARE * core.size)[0] + 1:
        x, y, w, h = stats[i, :4]
        part = labels[y : y + h, x : x + w] == i
        if near[y : y + h, x : x + w][part].any():
            grown[y : y + h, x : x + w][part] = 1
    if int(grown.sum()) == int(core.sum()):
        return core.astype(bool)
    grown = cv2.morphologyEx(grown, cv2.MORPH_CLOSE, kernel)  # the seam between the core and the parts
    _n, labels, stats, _c = cv2.connectedComponentsWithStats(grown, connectivity=8)
    return _fill(labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA])))


def _median_u8(values: np.ndarray, where: np.ndarray) -> float:
    """np.median of the uint8 `values` where `where` (uint8 0/1) is set, from their histogram (the mean of the
    two middle ones for an even count, as np.median): no copy, no sort."""
    counts = np.cumsum(cv2.calcHist([values], [0], where, [256], [0, 256]).ravel().astype(np.int64))
    n = int(counts[-1])
    lo, hi = np.searchsorted(counts, [(n - 1) // 2, n // 2], side="right")
    return (float(lo) + float(hi)) / 2


# --- people in a video with a static camera (thesis §5.2 steps 1-3, §6.2.2) ---------------------------


class NoMotionError(SegmentationError):
    """The frames hold nothing that moves against the background."""


MOTION_THRESHOLD = 16  # grey levels (max over colour channels) between a frame and the background
BODY_THRESHOLD = 28  # grey levels between the median image and the wall estimate (static body)
WALL_KERNEL = 21  # median filter side that erases a person-sized object from the median image (64 x 64 clips)
MIN_PERSON_AREA = 30  # pixels
MIN_PERSON_HEIGHT = 0.4  # of the picture's height: a standing person seen whole is taller than this
MAX_MOVING_SHARE = 0.5  # of the picture: a frame that moves more than this is a moving camera, not a person
# A static camera's temporal median is as sharp as its frames (only the moving person blurs); a moving
# camera's is a blur. Median's mean gradient / a typical frame's: 0.72-0.95 on the 28 shared clips (jack,
# with the most motion, lowest), 0.12-0.21 for a 40-frame pan, 0.31-0.61 for a 10-frame pan or a shaking
# camera (+-3 px), 0.65 for a slow tilt (1 px per frame) -- that one is not caught.
MIN_MEDIAN_SHARPNESS = 0.6


@dataclass
class PersonRegions:
    """One frame's regions: boolean masks of the frame's shape (None when not found).

    silhouette: the whole person (perception/person.py: GrabCut seeded by the still body and the motion).
    stable: the still body seen in the clip's median image (the thesis' "common regions of the reference
    and the input image"; it seeds the silhouette). head, torso (with the legs), left_arm, right_arm: the
    silhouette split by body proportions (perception/body_parts.py), left/right as seen in the picture.
    bbox: (x, y, w, h) of the silhouette.
    """

    silhouette: np.ndarray
    stable: np.ndarray
    head: np.ndarray | None
    torso: np.ndarray | None
    left_arm: np.ndarray | None
    right_arm: np.ndarray | None
    bbox: tuple[int, int, int, int] | None


def background_median(frames: list[np.ndarray]) -> np.ndarray:
    """Per-pixel temporal median of the frames (static camera): the background model (§5.2 step 1).

    A person who stands still is part of it; what moves (the arms) is not."""
    if len(frames) < 3:
        raise NoMotionError(f"need at least 3 frames to model the background, got {len(frames)}")
    return np.median(np.stack(frames), axis=0).astype(np.uint8)


def _mean_gradient(img: np.ndarray) -> float:
    g = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(np.float32) if img.ndim == 3 else img.astype(np.float32)
    return float(np.abs(cv2.Sobel(g, cv2.CV_32F, 1, 0)).mean() + np.abs(cv2.Sobel(g, cv2.CV_32F, 0, 1)).mean())


def median_sharpness(frames: list[np.ndarray], background: np.ndarray) -> float:
    """The background's mean gradient over a typical (median) frame's: ~1 for a static camera."""
    typical = float(np.median([_mean_gradient(f) for f in frames]))
    return _mean_gradient(background) / typical if typical > 0 else 1.0


def _diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = cv2.absdiff(a, b)
    return d.max(axis=2) if d.ndim == 3 else d


def moving_masks(
    frames: list[np.ndarray], background: np.ndarray, threshold: int = MOTION_THRESHOLD
) -> list[np.ndarray]:
    """Per frame: pixels that differ from the background by more than threshold, gaps closed (§5.2 step 2)."""
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))
    out = []
    for f in frames:
        fg = (cv2.GaussianBlur(_diff(f, background), (3, 3), 0) > threshold).astype(np.uint8)
        out.append(cv2.morphologyEx(fg, cv2.MORPH_CLOSE, kernel).astype(bool))
    return out


# Of the picture away from the person (beyond a 20th of the picture round the silhouette): what changes
# there between the clip's median and its last frame. A static camera's clip: 0.011 median, 0.045 at most
# (255 windows of 6 frames of the 28 shared Weizmann clips); a camera panning 24 px a frame across a room
# (stripes, wood, skin-coloured wall, 3-6 frames): 0.03-0.38, mostly above 0.1.
MAX_MOVING_AWAY = 0.06


def moving_away(frames: list[np.ndarray], silhouette: np.ndarray) -> float:
    """The share of the picture away from `silhouette` (the last frame's person) that differs from the
    clip's median in the last frame: near 0 for a static camera, whatever the person does; 1.0 when the
    silhouette leaves no picture away from it."""
    frames = [f if f.ndim == 3 else cv2.cvtColor(f, cv2.COLOR_GRAY2BGR) for f in frames]
    moving = moving_masks(frames[-1:], background_median(frames))[0]
    k = max(3, (min(silhouette.shape) // 20) | 1)
    near = cv2.dilate(silhouette.astype(np.uint8), np.ones((k, k), np.uint8)).astype(bool)
    return float(moving[~near].mean()) if (~near).any() else 1.0


def static_body(background: np.ndarray, near: np.ndarray | None = None) -> np.ndarray:
    """The still part of the person inside the median image: where it differs from a wall estimate (the
    median image median-filtered with a WALL_KERNEL window, which erases person-sized objects); the
    component closest to `near` (e.g. where the arms move), else the largest."""
    k = min(WALL_KERNEL, (min(background.shape[:2]) // 2) * 2 - 1)
    wall = cv2.medianBlur(background, k) if k >= 3 else background
    body = (_diff(background, wall) > BODY_THRESHOLD).astype(np.uint8)
    body = cv2.morphologyEx(body, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3)))
    comps = _components(body, MIN_PERSON_AREA // 2)
    if not comps:
        return np.zeros(background.shape[:2], bool)
    if near is not None and near.any():
        ny, nx = np.nonzero(near)
        centre = np.array([nx.mean(), ny.mean()])

        def score(m):
            ys, xs = np.nonzero(m)
            return np.hypot(xs - centre[0], ys - centre[1]).min() - 1e-3 * len(xs)

        comps.sort(key=score)
    return _fill(comps[0])


def _fill(mask: np.ndarray) -> np.ndarray:
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    filled = np.zeros(mask.shape, np.uint8)
    cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
    return filled.astype(bool)


def _components(mask: np.ndarray, min_area: int) -> list[np.ndarray]:
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    order: np.ndarray | list[int] = (np.argsort(-stats[1:, cv2.CC_STAT_AREA]) + 1) if n > 1 else []
    return [labels == i for i in order if stats[i, cv2.CC_STAT_AREA] >= min_area]


class NoPersonError(SegmentationError):
    """Something moves, but not a person in front of a static camera (a moving camera, a small object)."""


def _seed_place(stable: np.ndarray, anywhere: np.ndarray) -> tuple[int, int]:
    """The person's centre column (the still body's, else the motion's) and top row: the higher of the still
    body's top and the top of the motion above it (raised arms, a jump: better start the band too high -
    colour then says wall - than too low)."""
    src = stable if stable.any() else anywhere
    ys, xs = np.nonzero(src)
    centre, top = int(round(xs.mean())), int(ys.min())
    near = anywhere[:, max(0, centre - 2) : centre + 3]
    if near.any():
        top = min(top, int(np.flatnonzero(near.any(axis=1))[0]))
    return centre, top


def person_regions(
    frames: list[np.ndarray], threshold: int = MOTION_THRESHOLD, only: list[int] | None = None
) -> list[PersonRegions]:
    """Regions of the one person in each frame of a static-camera clip (thesis §5.2, §6.2.2).

    Background = temporal median (the still body stays in it); moving parts = frame minus background.
    The still body is found in the median image against a wall estimate. Each frame's whole silhouette is
    GrabCut seeded with a band round the still body and that frame's moving parts (perception/person.py),
    split into head, torso with legs and arms by body proportions (perception/body_parts.py).
    `only`: the indices of the frames wanted (default all; the background always comes from all frames).
    Raises NoMotionError if nothing moves, NoPersonError if the camera moves (the median picture is a blur
    of the frames, or most of the picture moves) or no person-sized silhouette is found.
    """
    if not frames:
        raise NoMotionError("no frames")
    frames = [f if f.ndim == 3 else cv2.cvtColor(f, cv2.COLOR_GRAY2BGR) for f in frames]
    if len({f.shape for f in frames}) != 1:
        raise SegmentationError("frames differ in size")
    bg = background_median(frames)
    moving = moving_masks(frames, bg, threshold)
    rows, cols = bg.shape[:2]
    min_motion = max(5, int(2e-4 * rows * cols))
    if sum(int(m.sum() >= min_motion) for m in moving) < max(2, len(frames) // 10):
        raise NoMotionError(
            "no person found: no motion, nothing in the frames differs from the background "
            "(a still picture or an empty scene?)"
        )
    sharp = median_sharpness(frames, bg)
    if sharp < MIN_MEDIAN_SHARPNESS:
        raise NoPersonError(
            f"no person found: the camera moves (the clip's median picture keeps {sharp:.0%} of "
            f"a frame's detail, a static camera's at least {MIN_MEDIAN_SHARPNESS:.0%})"
        )
    shares = np.array([m.mean() for m in moving])
    if np.median(shares) > MAX_MOVING_SHARE:
        raise NoPersonError(
            f"no person found: {100 * np.median(shares):.0f} % of the picture moves in a typical "
            "frame (a moving camera?); a person needs a static camera"
        )
    anywhere = np.mean(np.stack(moving), axis=0) > 0.05
    stable = static_body(bg, near=anywhere)
    centre_col, top_row = _seed_place(stable, anywhere)
    wanted = range(len(frames)) if only is None else list(only)
    silhouettes = person_masks([frames[i] for i in wanted], [moving[i] for i in wanted], centre_col, top_row)
    tall = [s.any() and np.ptp(np.flatnonzero(s.any(axis=1))) + 1 >= MIN_PERSON_HEIGHT * rows for s in silhouettes]
    if sum(tall) < 0.5 * len(silhouettes):
        raise NoPersonError(
            f"no person found: what moves is never a standing person (taller than "
            f"{MIN_PERSON_HEIGHT:.0%} of the picture) in more than half of the frames"
        )
    out = []
    for i, sil in zip(wanted, silhouettes):
        parts = split_body(sil, moving[i])
        bbox = None
        if sil.any():
            ys, xs = np.nonzero(sil)
            bbox = (int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1))
        out.append(PersonRegions(sil, stable, parts.head, parts.torso, parts.left_arm, parts.right_arm, bbox))
    return out
