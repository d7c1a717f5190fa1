"""Silhouettes: a hand on a plain background (`hand_mask`), a person in a static-camera clip (`person_regions`).

Hand silhouette from a photograph on a plain, white-ish background.

The background is bright and grey (low saturation); skin is saturated. Otsu's threshold on a blend of
saturation and darkness separates them despite the set's shadows and vignetting; morphology closes gaps
and the largest component is the hand.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


class SegmentationError(ValueError):
    """No plausible silhouette in the picture (empty, blank, all white)."""


def hand_mask(image_bgr: np.ndarray) -> np.ndarray:
    """Boolean mask of the hand (largest saturated/dark component, holes filled)."""
    if image_bgr is None or image_bgr.size == 0:
        raise SegmentationError("empty image")
    img = image_bgr if image_bgr.ndim == 3 else cv2.cvtColor(image_bgr, cv2.COLOR_GRAY2BGR)
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    sat = hsv[..., 1].astype(np.float32)
    dark = 255.0 - hsv[..., 2].astype(np.float32)
    # Vignetting darkens the corners but leaves them grey: saturation carries most of the weight.
    score = cv2.GaussianBlur(0.75 * sat + 0.25 * dark, (3, 3), 0)
    if float(score.max() - score.min()) < 12.0:
        raise SegmentationError("no foreground: the image is blank (uniform)")
    score8 = cv2.normalize(score, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    _t, fg = cv2.threshold(score8, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    k = max(3, (min(img.shape[:2]) // 50) | 1)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, kernel)
    fg = cv2.morphologyEx(fg, cv2.MORPH_CLOSE, kernel)
    n, labels, stats, _c = cv2.connectedComponentsWithStats(fg, connectivity=8)
    if n <= 1:
        raise SegmentationError("no foreground component found")
    biggest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    mask = (labels == biggest).astype(np.uint8)
    contours, _h = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    filled = np.zeros_like(mask)
    cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
    area = int(filled.sum())
    if area < 0.01 * filled.size:
        raise SegmentationError(f"foreground too small ({area} px)")
    return filled.astype(bool)


# --- people in a video with a static camera (thesis §5.2 steps 1-3, §6.2.2) ---------------------------

class NoMotionError(SegmentationError):
    """The frames hold nothing that moves against the background."""


MOTION_THRESHOLD = 16  # grey levels (max over colour channels) between a frame and the background
BODY_THRESHOLD = 28  # grey levels between the median image and the wall estimate (static body)
WALL_KERNEL = 21  # median filter side that erases a person-sized object from the median image (64 x 64 clips)
MIN_PERSON_AREA = 30  # pixels
MIN_ARM_AREA = 5  # pixels
HEAD_SHARE = 0.2  # of the static body's height, from its top
TORSO_SHARE = 0.6  # the torso ends (hips) at 60% of the static body's height; below are the legs
ARM_ZONE_SHARE = 0.8  # moving parts below 80% of the static body's height are not arms


@dataclass
class PersonRegions:
    """One frame's regions: boolean masks of the frame's shape (None when not found).

    silhouette: the person (static body plus this frame's moving parts). stable: the static body (the
    thesis' "common regions of the reference and the input image"). head, torso: the static body split at
    HEAD_SHARE and TORSO_SHARE of its height. left_arm, right_arm: the two biggest moving components,
    left/right as seen in the picture (smaller column = left). bbox: (x, y, w, h) of the silhouette.
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


def _diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = cv2.absdiff(a, b)
    return d.max(axis=2) if d.ndim == 3 else d


def moving_masks(frames: list[np.ndarray], background: np.ndarray, threshold: int = MOTION_THRESHOLD) -> list[np.ndarray]:
    """Per frame: pixels that differ from the background by more than threshold, gaps closed (§5.2 step 2)."""
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))
    out = []
    for f in frames:
        fg = (cv2.GaussianBlur(_diff(f, background), (3, 3), 0) > threshold).astype(np.uint8)
        out.append(cv2.morphologyEx(fg, cv2.MORPH_CLOSE, kernel).astype(bool))
    return out


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
    order = (np.argsort(-stats[1:, cv2.CC_STAT_AREA]) + 1) if n > 1 else []
    return [labels == i for i in order if stats[i, cv2.CC_STAT_AREA] >= min_area]


def _arms(moving: np.ndarray, cx: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The biggest moving component on each side of the body's centre column cx (cut there, so hands
    that meet over the head still give two arms): (left, right) as seen in the picture."""
    cut = moving.copy()
    cut[:, cx] = False
    out = []
    for side in (slice(0, cx), slice(cx + 1, None)):
        half = np.zeros_like(cut)
        half[:, side] = cut[:, side]
        comps = _components(half, MIN_ARM_AREA)
        out.append(comps[0] if comps else None)
    return out[0], out[1]


def person_regions(frames: list[np.ndarray], threshold: int = MOTION_THRESHOLD) -> list[PersonRegions]:
    """Regions of the one person in each frame of a static-camera clip (thesis §5.2, §6.2.2).

    Background = temporal median (the still body stays in it). Moving parts = frame minus background;
    the biggest component on each side of the body's centre column is an arm. The static body is found in the
    median image against a wall estimate; its top HEAD_SHARE is the head, down to TORSO_SHARE the torso.
    Raises NoMotionError if nothing moves.
    """
    if not frames:
        raise NoMotionError("no frames")
    frames = [f if f.ndim == 3 else cv2.cvtColor(f, cv2.COLOR_GRAY2BGR) for f in frames]
    if len({f.shape for f in frames}) != 1:
        raise SegmentationError("frames differ in size")
    bg = background_median(frames)
    moving = moving_masks(frames, bg, threshold)
    min_motion = max(MIN_ARM_AREA, int(2e-4 * bg.shape[0] * bg.shape[1]))
    if sum(int(m.sum() >= min_motion) for m in moving) < max(2, len(frames) // 10):
        raise NoMotionError("no motion: nothing in the frames differs from the background (a still picture?)")
    anywhere = np.mean(np.stack(moving), axis=0) > 0.05
    stable = static_body(bg, near=anywhere)
    head = torso = None
    r_arms = bg.shape[0]
    if stable.any():
        rows = np.flatnonzero(stable.any(axis=1))
        top, height = rows[0], rows[-1] - rows[0] + 1
        r_head, r_hips = top + int(round(HEAD_SHARE * height)), top + int(round(TORSO_SHARE * height))
        rr = np.arange(stable.shape[0])[:, None]
        r_arms = top + int(round(ARM_ZONE_SHARE * height))
        head = stable & (rr < r_head)
        torso = stable & (rr >= r_head) & (rr < r_hips)
        head = head if head.any() else None
        torso = torso if torso.any() else None
    out = []
    cx = int(round(np.nonzero(stable)[1].mean())) if stable.any() else bg.shape[1] // 2
    arm_zone = np.arange(bg.shape[0])[:, None] < r_arms  # not the moving edges of a shirt or legs
    for mv in moving:
        left, right = _arms(mv & ~stable & arm_zone, cx)
        arms = [a for a in (left, right) if a is not None]
        sil = stable.copy()
        for a in arms:
            sil |= a
        bbox = None
        if sil.any():
            ys, xs = np.nonzero(sil)
            bbox = (int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1))
        out.append(PersonRegions(sil, stable, head, torso, left, right, bbox))
    return out
