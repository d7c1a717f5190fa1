"""A hand in one picture (a camera frame): its silhouette and recognised class, or why there is none.

Each frame is read on its own -- a hand does not stand still like a person's torso, so nothing is assumed
of the frames before. Two readings, in turn: the plain one (`plain_hand`, below), for what the shared
photographs show -- a hand in front of a plain, bright background; then, for a picture it refuses, the
learned one (perception/hand_detector.py: MediaPipe's landmarks, a GrabCut silhouette; issue 50) for a
hand in front of anything else. A frame that is no 8-bit picture, or smaller than MIN_SIDE, is one line
(`check_frame`). The plain reading says "no hand found: ..." (`NoHandError`) when

- nothing stands out of the background (an empty picture: `hand_mask` finds no foreground),
- what stands out is too small a part of the picture (a hand leaving it),
- what stands out is not skin-saturated (a hand's silhouette is: the shared photographs' hands have a
  mean saturation of 73-125; the shared Weizmann persons, clothes and all, 41-69), or the background
  around it is not plain (grey: the photographs' 3-17; a cluttered scene's more),
- what stands out does not reach the picture's edge (a held-up hand comes in with its wrist or arm;
  a person standing in a room, seen whole, does not),
- its vectors lie far from the space the training hands span (`EigenClassifier.hand_space_distance`:
  a person, a cluttered background whose segmentation is not a hand).

One frame cannot tell a hand half out of the picture from a whole one: a 5 lowered 20-35 px out of a
100 px picture (its fist and palm left) is read as a 3, an 8 or a 0 with full confidence, at hand-space
distances (0.20-0.29) that whole unseen hands reach too (0.10-0.28). `ExitWatch` looks across frames
instead: fed each observed frame's foreground (`Hand.mask`, or `NoHandError.mask` of a refused one), it
says a hand is leaving when, over its last EXIT_FRAMES frames, the foreground touches a border, its far
edge (the one opposite that border) moves steadily toward it, its area shrinks, and it moves as a whole
(shifted by the far edge's move, the silhouette before is the one after: a finger curling or another
gesture shown changes the shape instead) -- and keeps saying so
while the hand goes on, is gone, or comes back, until a hand's box stands still again. A hand near a border
that stays put never moves its far edge: it is read as before.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from perception.eigen import HAND_SPACE_LIMIT, EigenClassifier
from perception.features import hand_hog
from perception.segmentation import SegmentationError, hand_mask

# Of the picture: the shared photographs' hands cover 10-39 % (1449 pictures); a hand of which less than
# this is in the picture is leaving it.
MIN_HAND_SHARE = 0.05
MIN_SKIN_SATURATION = 70.0  # mean HSV saturation (0-255) of a hand's silhouette
MAX_BACKGROUND_SATURATION = 30.0  # mean HSV saturation of the background away from the silhouette

# A hand leaving the picture (ExitWatch). Measured on scripts/hand_video.py's `lowered` part (a shared 5
# moved down 5 px every second frame of 8 fps, 100 x 100, observed at the camera's 5 fps: 0-5 px between
# observed frames) and on still hands near a border (0 px).
EXIT_FRAMES = 4  # observed frames judged together
EXIT_TRAVEL = 0.06  # of the picture across the border: the far edge's least total move toward it
EXIT_SHRINK = 0.04  # of the first frame's area: the least total shrink
AREA_NOISE = 0.02  # of the area: a step growing no more than this still counts as not growing
# A step toward the border is the hand moving as a whole (not a finger curling, not another gesture) when
# the silhouette before, shifted by the far edge's move, overlaps the one after by this IoU at least, and
# better than unshifted.
SHIFT_IOU = 0.85
STILL = 0.01  # of the picture: a box whose edges all move less than this between two frames stands still
STILL_STEPS = 2  # consecutive still steps that end a leaving
BORDERS = ("bottom", "top", "left", "right")
MIN_SIDE = 32  # px: a smaller frame holds no hand either reading can see


class NoHandError(SegmentationError):
    """The picture shows no hand in front of a plain background; the message says what was not found.
    `mask`: what stood out of the background (refused as a hand), None when nothing did."""

    def __init__(self, message: str, mask: np.ndarray | None = None):
        super().__init__(message)
        self.mask = mask


@dataclass(frozen=True)
class Hand:
    mask: np.ndarray  # bool, the picture's shape
    label: str  # the classifier's class (the shared set's class folder name: the digit shown)
    confidence: float  # share of the one-vs-one duels the label won (0..1)
    distance: float  # from the hand space (HAND_SPACE_LIMIT and below: a hand)


def find_hand(frame_bgr: np.ndarray, classifier: EigenClassifier, learned: bool = True, poses=None) -> Hand:
    """The hand in `frame_bgr` with its class ("best" classifier). Raises NoHandError.

    A plain, bright background is read as before (`plain_hand`: the classifier's own segmentation, its
    figures unchanged); a picture it refuses goes to the learned hand detector (`learned_hand`: MediaPipe's
    landmarks, a GrabCut silhouette, the hand on a plain background for the classifier), unless `learned`
    is False (`poses`: the learned reading's landmark classifier, default the shipped one). The message of
    a refusal by both starts with the plain reading's."""
    frame_bgr = check_frame(frame_bgr)
    try:
        return plain_hand(frame_bgr, classifier)
    except NoHandError as exc:
        if not learned:
            raise
        plain = exc
    from perception.hand_detector import learned_hand  # the DNN models load on first use

    found = learned_hand(frame_bgr, classifier, poses)
    if isinstance(found, str):
        raise NoHandError(f"{plain}; {found}", plain.mask)
    return Hand(*found)


def check_frame(frame: np.ndarray) -> np.ndarray:
    """The frame as 8-bit BGR; one line naming what is wrong (NoHandError) for anything else."""
    if not isinstance(frame, np.ndarray) or frame.size == 0:
        raise NoHandError("no hand found: the frame is empty")
    if frame.dtype != np.uint8:
        raise NoHandError(f"no hand found: the frame's pixels are {frame.dtype}, 8-bit (uint8) expected")
    if frame.ndim == 2 or (frame.ndim == 3 and frame.shape[2] == 1):
        return cv2.cvtColor(frame.reshape(frame.shape[:2]), cv2.COLOR_GRAY2BGR)
    if frame.ndim == 3 and frame.shape[2] == 4:
        return cv2.cvtColor(frame, cv2.COLOR_BGRA2BGR)
    if frame.ndim != 3 or frame.shape[2] != 3:
        raise NoHandError(f"no hand found: a frame of shape {frame.shape} is no picture (rows x columns x 3)")
    if min(frame.shape[:2]) < MIN_SIDE:
        raise NoHandError(
            f"no hand found: a {frame.shape[1]} x {frame.shape[0]} frame is too small (at least {MIN_SIDE} px a side)"
        )
    return frame


def plain_hand(frame_bgr: np.ndarray, classifier: EigenClassifier) -> Hand:
    """The hand in front of a plain, bright background (the shared photographs'). Raises NoHandError."""
    try:
        mask = hand_mask(frame_bgr)
    except SegmentationError as exc:
        raise NoHandError(f"no hand found: {exc}") from None
    share = float(mask.mean())
    if share < MIN_HAND_SHARE:
        raise NoHandError(
            f"no hand found: what stands out covers {100 * share:.1f} % of the picture "
            f"(a hand covers at least {100 * MIN_HAND_SHARE:.0f} %; one leaving the picture?)",
            mask,
        )
    sat = cv2.cvtColor(
        frame_bgr if frame_bgr.ndim == 3 else cv2.cvtColor(frame_bgr, cv2.COLOR_GRAY2BGR), cv2.COLOR_BGR2HSV
    )[..., 1].astype(np.float32)
    k = max(3, (min(mask.shape) // 10) | 1)
    away = ~cv2.dilate(mask.astype(np.uint8), np.ones((k, k), np.uint8)).astype(bool)
    background = float(sat[away].mean()) if away.any() else 0.0
    if background > MAX_BACKGROUND_SATURATION:
        raise NoHandError(
            f"no hand found: the background is not plain (saturation {background:.0f}, a plain "
            f"one's at most {MAX_BACKGROUND_SATURATION:.0f}; clutter?)",
            mask,
        )
    skin = float(sat[mask].mean())
    if skin < MIN_SKIN_SATURATION:
        raise NoHandError(
            f"no hand found: what stands out is not skin-coloured (saturation {skin:.0f}, a hand's "
            f"at least {MIN_SKIN_SATURATION:.0f}; a person?)",
            mask,
        )
    if not (mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any()):
        raise NoHandError(
            "no hand found: what stands out does not reach the picture's edge (a hand held up "
            "comes in with its wrist; a person seen whole?)",
            mask,
        )
    x = hand_hog([frame_bgr], [mask])
    distance = float(classifier.hand_space_distance(x)[0])
    if distance > HAND_SPACE_LIMIT:
        raise NoHandError(
            f"no hand found: the silhouette is not a hand's (distance from the hand space "
            f"{distance:.2f} > {HAND_SPACE_LIMIT}; a person, or a cluttered background?)",
            mask,
        )
    label, conf = classifier.predict_features(x)
    return Hand(mask, str(label[0]), float(conf[0]), distance)


@dataclass(frozen=True)
class Extent:
    """A foreground's box (x0, y0, x1, y1: x1, y1 one past the last pixel), area [px], the picture's borders
    it touches and the picture's (rows, cols)."""

    box: tuple[int, int, int, int]
    area: int
    touches: frozenset[str]
    shape: tuple[int, int]


def extent_of(mask: np.ndarray) -> Extent | None:
    """The box, area and touched borders of `mask` (bool); None when it is empty."""
    ys, xs = np.nonzero(mask)
    if ys.size == 0:
        return None
    rows, cols = mask.shape
    x0, y0, x1, y1 = int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1
    touches = {"top": y0 == 0, "bottom": y1 == rows, "left": x0 == 0, "right": x1 == cols}
    return Extent((x0, y0, x1, y1), int(ys.size), frozenset(b for b, t in touches.items() if t), (rows, cols))


def _far_edge(e: Extent, border: str) -> float:
    """How far toward `border` the edge opposite it has come, as a fraction of the picture across it."""
    x0, y0, x1, y1 = e.box
    rows, cols = e.shape
    return {"bottom": y0 / rows, "top": (rows - y1) / rows, "right": x0 / cols, "left": (cols - x1) / cols}[border]


def shifted(mask: np.ndarray, border: str, d: int) -> np.ndarray:
    """`mask` moved `d` px toward `border`, what goes past it dropped."""
    out = np.zeros_like(mask)
    if d <= 0:
        return mask.copy() if d == 0 else out
    if border == "bottom":
        out[d:] = mask[:-d]
    elif border == "top":
        out[:-d] = mask[d:]
    elif border == "right":
        out[:, d:] = mask[:, :-d]
    else:
        out[:, :-d] = mask[:, d:]
    return out


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    union = np.logical_or(a, b).sum()
    return float(np.logical_and(a, b).sum() / union) if union else 1.0


def moves_as_a_whole(a: np.ndarray, b: np.ndarray, border: str, d: int) -> bool:
    """Silhouette `b` is `a` moved `d` px toward `border` (SHIFT_IOU, and better than not moved)."""
    if d <= 0:
        return True
    moved = _iou(shifted(a, border, d), b)
    return moved >= SHIFT_IOU and moved >= _iou(a, b)


def leaving_border(extents: Sequence[Extent], masks: Sequence[np.ndarray] | None = None) -> str | None:
    """The border the hand of the last EXIT_FRAMES `extents` (oldest first, one picture size) is moving out
    through, or None: it touches that border in each, its far edge never moves back (by STILL or more) and
    comes at least EXIT_TRAVEL closer to it, its area never grows (beyond AREA_NOISE) and shrinks by at
    least EXIT_SHRINK, and (given the `masks` of the extents) each step is the silhouette moving as a
    whole (`moves_as_a_whole`)."""
    last = list(extents)[-EXIT_FRAMES:]
    if len(last) < EXIT_FRAMES or len({e.shape for e in last}) != 1:
        return None
    areas = np.array([e.area for e in last], dtype=float)
    if areas[-1] > (1 - EXIT_SHRINK) * areas[0] or (areas[1:] > areas[:-1] * (1 + AREA_NOISE)).any():
        return None
    rows, cols = last[0].shape
    for border in BORDERS:
        if not all(border in e.touches for e in last):
            continue
        far = np.array([_far_edge(e, border) for e in last])
        if not ((np.diff(far) > -STILL).all() and far[-1] - far[0] >= EXIT_TRAVEL):
            continue
        if masks is not None:
            size = rows if border in ("top", "bottom") else cols
            ms = list(masks)[-EXIT_FRAMES:]
            px = np.round(np.diff(far) * size).astype(int)
            if not all(moves_as_a_whole(a, b, border, int(d)) for a, b, d in zip(ms, ms[1:], px)):
                continue
        return border
    return None


def stands_still(a: Extent, b: Extent) -> bool:
    """No edge of the box moved by STILL of the picture or more between `a` and `b`."""
    rows, cols = b.shape
    scale = np.array([cols, rows, cols, rows], dtype=float)
    return a.shape == b.shape and bool((np.abs(np.subtract(b.box, a.box)) / scale < STILL).all())


def leaving_note(border: str) -> str:
    """The one line said while a hand leaves (the same all along, so it is said once)."""
    return f"hand leaving the frame: it moved out through the {border} border (the swarm keeps its command)"


class ExitWatch:
    """Across frames: is the hand leaving the picture? Fed each observed frame's foreground; no I/O."""

    def __init__(self) -> None:
        self.extents: deque[Extent] = deque(maxlen=EXIT_FRAMES)
        self.masks: deque[np.ndarray] = deque(maxlen=EXIT_FRAMES)
        self.leaving: str | None = None  # the border it is leaving (or left) through
        self._still = 0

    def update(self, mask: np.ndarray | None, hand: bool = True) -> str | None:
        """The border the hand is leaving through, from the frame that shows it moving out until a hand's
        box has stood still for STILL_STEPS steps (also after it was gone and came back), else None.
        `mask`: what stood out of this frame's background (None: nothing did); `hand`: whether it was taken
        for a hand (what is left of one that has mostly gone, or the background taken for the foreground
        then, is not: it does not end a leaving)."""
        e = None if mask is None else extent_of(mask)
        if e is None or (self.extents and self.extents[-1].shape != e.shape):
            self.extents.clear()  # gone (or never there): a leaving hand has left
            self.masks.clear()
            self._still = 0
        if e is None:
            return self.leaving
        prev = self.extents[-1] if self.extents else None
        self.extents.append(e)
        self.masks.append(np.asarray(mask, dtype=bool))
        border = leaving_border(self.extents, self.masks)
        if border is not None:
            self.leaving, self._still = border, 0
        elif self.leaving is not None:
            self._still = self._still + 1 if hand and prev is not None and stands_still(prev, e) else 0
            if self._still >= STILL_STEPS:
                self.leaving, self._still = None, 0
        return self.leaving
