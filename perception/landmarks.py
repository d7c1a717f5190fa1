"""A hand's 21 landmarks in one picture: MediaPipe's two-stage hand landmarker (palm detection, then the
landmarks in a rotated crop round the palm), re-implemented round its two TFLite models (perception/models.py).

The stages and their constants are MediaPipe's own (mediapipe/modules/palm_detection/palm_detection_cpu.pbtxt,
hand_landmark/palm_detection_detection_to_roi.pbtxt, hand_landmark_cpu.pbtxt of the 0.10.21 release whose
model files are shipped): SSD anchors of the 192-px palm detector (4 layers, strides 8/16/16/16, scales
0.1484375-0.75, one aspect ratio, fixed anchor size), sigmoid scores clipped at 100, weighted non-maximum
suppression at IoU 0.3; the hand's box from the palm's: turned so the wrist -> middle-finger knuckle points
up, shifted half its height toward the fingers, squared on its long side and scaled 2.6; the 224-px
landmark model in that box, its hand-presence score and 21 (x, y, z) landmarks mapped back.

Landmark numbering (MediaPipe's): 0 wrist; thumb 1-4; index 5-8; middle 9-12; ring 13-16; little 17-20
(knuckle, two joints, tip). Coordinates in pixels of the picture given, x = column, y = row.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from perception.models import run_model

PALM_MODEL = "palm_detection_lite.tflite"
LANDMARK_MODEL = "hand_landmark_lite.tflite"
# MediaPipe's larger landmark model (the same 0.10.21 wheel, the same inputs and outputs; ~2x a lite pass): it reads
# a hand the two classifiers disagree on (hand_detector.full_pose)
FULL_LANDMARK_MODEL = "hand_landmark_full.tflite"
PALM_SIZE = 192
LANDMARK_SIZE = 224
PALM_SCORE = 0.3  # below MediaPipe's 0.5: a palm in clutter scores lower; the presence score decides
PRESENCE = 0.5  # MediaPipe's min_hand_presence_confidence default
NMS_IOU = 0.3
ROI_SCALE = 2.6
ROI_SHIFT = -0.5  # of the palm box's height, toward the fingers
MAX_HANDS = 2
REFINE_POINTS = (0, 1, 2, 3, 5, 6, 9, 10, 13, 14, 17, 18)
REFINE_SCALE = 2.0
REFINE_SHIFT = -0.1
REREAD_SCALES = (0.85, 1.2)  # of the tracking box's side: the rereadings' crops (REFINE_SCALE 2.0 -> 1.7, 2.4)
BOTTOM_SIDE = 0.75  # of the picture's height: the bottom corners' squares (palm_views)
# of the picture's height: the sides of bottom_boxes' squares (0.6 as well found 4 more of 40 hands, 4 more passes;
# 0.3, issue 50 session 6: hands 100-130 px tall, whose landmarks a square ~1.3 times their box finds)
# 0.6 last (session 8): large hands, 200-240 px tall, no palm view held; tuning +4 hands, held-out +4, none wrong
BOTTOM_CROPS = (0.4, 0.3, 0.6)
BOTTOM_BELOW = 0.1  # of a bottom box's side: below the picture's edge

FINGERS = ((1, 2, 3, 4), (5, 6, 7, 8), (9, 10, 11, 12), (13, 14, 15, 16), (17, 18, 19, 20))
PALM = (0, 1, 5, 9, 13, 17)


@dataclass(frozen=True)
class HandLandmarks:
    points: np.ndarray  # (21, 2) float32, pixels of the picture
    depth: np.ndarray  # (21,) relative depth (MediaPipe's z, in the crop's pixel scale)
    presence: float  # the landmark model's hand-presence score (0..1)
    palm_score: float  # the palm detector's score (0..1)

    def palm_length(self) -> float:
        """Wrist to the middle finger's knuckle [px]: the hand's own length unit."""
        return float(np.linalg.norm(self.points[9] - self.points[0]))


def _anchors() -> np.ndarray:
    """(2016, 2) anchor centres in [0, 1] (fixed anchor size: widths and heights are 1)."""
    out = []
    strides = (8, 16, 16, 16)
    layer = 0
    while layer < len(strides):
        # layers with the same stride share one grid: two anchors per cell per layer (the scale and the
        # interpolated one; a single aspect ratio)
        last = layer
        while last < len(strides) and strides[last] == strides[layer]:
            last += 1
        per_cell = 2 * (last - layer)
        n = int(np.ceil(PALM_SIZE / strides[layer]))
        ys, xs = np.mgrid[0:n, 0:n]
        centres = np.stack([(xs.ravel() + 0.5) / n, (ys.ravel() + 0.5) / n], axis=1)
        out.append(np.repeat(centres, per_cell, axis=0))
        layer = last
    return np.concatenate(out).astype(np.float32)


ANCHORS = _anchors()


def letterbox(image_rgb: np.ndarray, size: int) -> tuple[np.ndarray, float, float, float]:
    """The picture scaled to fit a size x size square, centred, padded with black; (square, scale, pad_x,
    pad_y): picture = (square - pad) / scale."""
    h, w = image_rgb.shape[:2]
    s = size / max(h, w)
    nw, nh = max(1, round(w * s)), max(1, round(h * s))
    px, py = (size - nw) // 2, (size - nh) // 2
    out = np.zeros((size, size, 3), np.uint8)
    out[py : py + nh, px : px + nw] = cv2.resize(image_rgb, (nw, nh), interpolation=cv2.INTER_AREA)
    return out, s, float(px), float(py)


def _weighted_nms(boxes: np.ndarray, scores: np.ndarray, extra: np.ndarray) -> list[tuple[float, np.ndarray]]:
    """MediaPipe's WEIGHTED suppression: each kept detection is the score-weighted mean of those it
    overlaps by IoU > NMS_IOU. boxes (n, 4) x0 y0 x1 y1; extra (n, k) values averaged the same way."""
    order = np.argsort(-scores)
    left = list(order)
    kept = []
    while left:
        i = left[0]
        x0 = np.maximum(boxes[i, 0], boxes[left, 0])
        y0 = np.maximum(boxes[i, 1], boxes[left, 1])
        x1 = np.minimum(boxes[i, 2], boxes[left, 2])
        y1 = np.minimum(boxes[i, 3], boxes[left, 3])
        inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
        area = (boxes[left, 2] - boxes[left, 0]) * (boxes[left, 3] - boxes[left, 1])
        iou = inter / np.maximum(area + area[0] - inter, 1e-9)
        group = [left[k] for k in np.nonzero(iou > NMS_IOU)[0]]
        w = scores[group][:, None]
        kept.append((float(scores[i]), (extra[group] * w).sum(0) / w.sum()))
        left = [j for k, j in enumerate(left) if iou[k] <= NMS_IOU]
    return kept


def detect_palms(image_bgr: np.ndarray, min_score: float = PALM_SCORE) -> list[tuple[float, np.ndarray]]:
    """Palms in the picture: [(score, (18,) box centre x, y, w, h, 7 keypoints (x, y)) in pixels], best first."""
    # letterboxed, then turned RGB: the same square as the other way round (the scaling is per channel), at a
    # tenth of the conversion's cost
    square, s, px, py = letterbox(image_bgr, PALM_SIZE)
    square = cv2.cvtColor(square, cv2.COLOR_BGR2RGB)
    raw, logits = run_model(PALM_MODEL, square, ("Identity", "Identity_1"))
    raw = raw.reshape(-1, 18).astype(np.float32)
    scores = 1.0 / (1.0 + np.exp(-np.clip(logits.reshape(-1), -100.0, 100.0)))
    good = np.nonzero(scores >= min_score)[0]
    if len(good) == 0:
        return []
    r = raw[good] / PALM_SIZE
    a = ANCHORS[good]
    vals = r.copy()
    vals[:, 0:2] += a  # box centre
    vals[:, 4::2] += a[:, :1]  # keypoints x
    vals[:, 5::2] += a[:, 1:]  # keypoints y
    boxes = np.stack(
        [
            vals[:, 0] - vals[:, 2] / 2,
            vals[:, 1] - vals[:, 3] / 2,
            vals[:, 0] + vals[:, 2] / 2,
            vals[:, 1] + vals[:, 3] / 2,
        ],
        axis=1,
    )
    out = []
    for score, v in _weighted_nms(boxes, scores[good], vals)[:MAX_HANDS]:
        v = v * PALM_SIZE
        pix = v.copy()
        pix[0] = (v[0] - px) / s
        pix[1] = (v[1] - py) / s
        pix[2:4] = v[2:4] / s
        pix[4::2] = (v[4::2] - px) / s
        pix[5::2] = (v[5::2] - py) / s
        out.append((score, pix.astype(np.float32)))
    return out


def hand_box(palm: np.ndarray) -> tuple[float, float, float, float]:
    """(centre x, centre y, side, rotation [rad]) of the landmark model's crop for one palm detection."""
    cx, cy, w, h = (float(v) for v in palm[:4])
    wrist, middle = palm[4:6], palm[8:10]
    rotation = np.pi / 2 - np.arctan2(-(middle[1] - wrist[1]), middle[0] - wrist[0])
    rotation = float((rotation + np.pi) % (2 * np.pi) - np.pi)
    cx += -h * ROI_SHIFT * np.sin(rotation)
    cy += h * ROI_SHIFT * np.cos(rotation)
    return cx, cy, max(w, h) * ROI_SCALE, rotation


def _crop_matrix(box: tuple[float, float, float, float], size: int) -> np.ndarray:
    """Affine map picture -> size x size crop of the rotated square `box` (its 'up' is the crop's up)."""
    cx, cy, side, rot = box
    c, s = np.cos(rot), np.sin(rot)
    k = size / side
    # rotate the picture by -rot about the box centre, scale, move the centre to the crop's
    return np.array(
        [[k * c, k * s, size / 2 - k * (c * cx + s * cy)], [-k * s, k * c, size / 2 - k * (-s * cx + c * cy)]],
        np.float32,
    )


def landmarks_in(
    image_bgr: np.ndarray, box: tuple[float, float, float, float], mirrored: bool = False, model: str = LANDMARK_MODEL
) -> HandLandmarks:
    """The landmark model on the rotated square `box` of the picture (`mirrored`: on its mirror image, the
    landmarks mirrored back: the model reads a left and a right hand, so this is a second, different look)."""
    m = _crop_matrix(box, LANDMARK_SIZE)
    # cropped, then turned RGB (the same crop: the warp is per channel; the whole frame's conversion cost more)
    crop = cv2.warpAffine(image_bgr, m, (LANDMARK_SIZE, LANDMARK_SIZE), flags=cv2.INTER_LINEAR, borderValue=(0, 0, 0))
    crop = cv2.cvtColor(crop, cv2.COLOR_BGR2RGB)
    if mirrored:
        crop = np.ascontiguousarray(crop[:, ::-1])
    pts, flag = run_model(model, crop, ("Identity", "Identity_1"))
    xyz = pts.reshape(21, 3).astype(np.float32)
    if mirrored:
        xyz[:, 0] = LANDMARK_SIZE - xyz[:, 0]
    inv = cv2.invertAffineTransform(m)
    xy = xyz[:, :2] @ inv[:, :2].T + inv[:, 2]
    presence = float(np.asarray(flag).ravel()[0])
    return HandLandmarks(xy.astype(np.float32), xyz[:, 2].copy(), presence, 0.0)


def landmark_box(points: np.ndarray) -> tuple[float, float, float, float]:
    """MediaPipe's box for the next landmark pass from a hand's landmarks (hand_landmark_landmarks_to_roi):
    turned so the wrist -> middle knuckle points up, the box of the palm's and fingers' lower landmarks in
    that frame, shifted 0.1 of its height toward the fingers, squared on its long side, scaled 2."""
    sub = points[list(REFINE_POINTS)]
    d = points[9] - points[0]
    rotation = float((np.pi / 2 - np.arctan2(-d[1], d[0]) + np.pi) % (2 * np.pi) - np.pi)
    c, s = np.cos(rotation), np.sin(rotation)
    centre = (sub.min(0) + sub.max(0)) / 2
    rel = sub - centre
    # the landmarks in the box's own frame (its up is the hand's)
    rx = rel[:, 0] * c + rel[:, 1] * s
    ry = -rel[:, 0] * s + rel[:, 1] * c
    w, h = float(rx.max() - rx.min()), float(ry.max() - ry.min())
    mid = np.array([(rx.max() + rx.min()) / 2, (ry.max() + ry.min()) / 2])
    cx = centre[0] + mid[0] * c - mid[1] * s
    cy = centre[1] + mid[0] * s + mid[1] * c
    cx += -h * REFINE_SHIFT * np.sin(rotation)
    cy += h * REFINE_SHIFT * np.cos(rotation)
    return float(cx), float(cy), max(w, h) * REFINE_SCALE, rotation


def rereadings(
    image_bgr: np.ndarray,
    points: np.ndarray,
    scales: tuple[float, ...] = REREAD_SCALES,
    mirrored: bool = True,
    model: str = LANDMARK_MODEL,
) -> list[HandLandmarks]:
    """The same hand read again in other crops round its landmarks `points` (test-time augmentation): the
    tracking box (`landmark_box`) mirrored (unless `mirrored` is False), and that box REREAD_SCALES times its
    size. A hand's landmarks barely move between them; landmarks the model fitted to a wall's pattern or to a
    half-seen hand move (see hand_detector.py: where its two classifiers disagree, the landmarks' class counts
    only if every rereading gives it). mirrored + len(scales) landmark passes (~4 ms each)."""
    return list(reread(image_bgr, points, scales, mirrored, model))


def reread(
    image_bgr: np.ndarray,
    points: np.ndarray,
    scales: tuple[float, ...] = REREAD_SCALES,
    mirrored: bool = True,
    model: str = LANDMARK_MODEL,
) -> Iterator[HandLandmarks]:
    """`rereadings` one pass at a time, for a caller that stops at the first reading that does not hold."""
    cx, cy, side, rotation = landmark_box(points)
    if mirrored:
        yield landmarks_in(image_bgr, (cx, cy, side, rotation), True, model)
    for scale in scales:
        yield landmarks_in(image_bgr, (cx, cy, side * scale, rotation), model=model)


def find_landmarks(image_bgr: np.ndarray, min_presence: float = PRESENCE) -> list[HandLandmarks]:
    """The hands in the picture (at most MAX_HANDS), best palm first; [] when none. Each hand's landmarks
    are read twice: in the palm's box, then in the box those landmarks give (MediaPipe's tracking box,
    tighter and turned by the whole hand; on one frame it does what the tracker does from frame to frame).
    No palm in any view: the landmark model alone in the squares along the bottom edge (`bottom_boxes`)."""
    hands: list[HandLandmarks] = []
    for x0, y0, view in palm_views(image_bgr):
        for score, palm in detect_palms(view):
            palm = palm.copy()  # the view's pixels -> the picture's (centre and keypoints; not the size)
            palm[0], palm[1] = palm[0] + x0, palm[1] + y0
            palm[4::2] += x0
            palm[5::2] += y0
            lm = landmarks_in(image_bgr, hand_box(palm))
            if lm.presence >= min_presence:
                again = landmarks_in(image_bgr, landmark_box(lm.points))
                lm = again if again.presence >= min_presence else lm
            if lm.presence >= min_presence:
                hands.append(HandLandmarks(lm.points, lm.depth, lm.presence, score))
        if hands:
            return hands
    for box in bottom_boxes(image_bgr.shape[0], image_bgr.shape[1]):
        lm = landmarks_in(image_bgr, box)
        if lm.presence >= min_presence:
            again = landmarks_in(image_bgr, landmark_box(lm.points))
            if again.presence >= min_presence:
                return [HandLandmarks(again.points, again.depth, again.presence, 0.0)]
    return hands


def bottom_boxes(h: int, w: int) -> list[tuple[float, float, float, float]]:
    """Upright squares along the picture's bottom edge for the landmark model itself (no palm detected):
    BOTTOM_CROPS of the height, overlapping by half, each reaching BOTTOM_BELOW of its side below the edge
    (black there: a raised hand's wrist on the edge sits inside the crop, as in the model's own boxes).
    Looked at only when no palm view holds a hand; the presence score, read twice (in the square, then in
    the box its landmarks give), decides. On composites of bench-perception's generator (seeds 7, 13, 17 and
    held-out 11, 19; not the benchmark's), 67 of 525 hands had no palm the landmark model confirmed (35 on
    wood: small hands on skin-toned grain): squares of 0.4 and 0.6 of the height found 40, 30 with their
    landmarks on the hand; none of the 525 hand-free frames gave a hand. `find_hand` with these six squares
    (and a palm-less hand's class required to be steady, hand_detector.py): detection 0.779 -> 0.806, accuracy
    (ten classes) 0.958 -> 0.960, hand-free frames read as a hand 1 of 525 as before. The palm detector
    letterboxes the whole view and wants a palm of 28 px of its 192; the landmark model looks at a square
    hand-sized crop. Cost: up to 6 landmark passes (~25 ms) on frames without a palm only: the median frame's
    time did not move (bench-perception seed 0, back to back under the lock: 45.4 ms without, 44.8 with).
    Squares of 0.3 of the height as well (session 6: 8 more; a landmark pass in a square 1.3 times the pasted
    hand's box, centred on it, confirmed 25 of the 31 tuning hands still not found, most 95-130 px tall, for
    which the 0.4 squares are 1.5-2 times too large): no hand found in the 525 hand-free frames, and with
    hand_detector.STEADY_SCALES detection 0.806 -> 0.827 at accuracy 0.960 -> 0.959. Up to 14 landmark passes
    (~55 ms) on a frame without a palm: the median did not move (44.3 ms against 46.7, back to back), the 90th
    percentile 96 -> 100 ms."""
    boxes = []
    for share in BOTTOM_CROPS:
        side = share * h
        n = int(np.ceil((w - side) / (side / 2))) + 1 if w > side else 1
        for cx in np.linspace(side / 2, max(side / 2, w - side / 2), n):
            boxes.append((float(cx), h - (0.5 - BOTTOM_BELOW) * side, side, 0.0))
    return boxes


def palm_views(image_bgr: np.ndarray) -> list[tuple[int, int, np.ndarray]]:
    """(x0, y0, view) to look for palms in, in turn until one holds a hand: the whole picture (letterboxed,
    a 640 x 480 frame's palm shrinks to 0.3 of its size), then the two squares at the ends of its longer
    side (0.4: a 20-px palm of the whole is 27 px there; the detector's smallest anchor is 28 px), then two
    squares BOTTOM_SIDE of the height at the bottom corners (0.53: a hand raised into a camera's picture
    comes in from its bottom edge). On 100 composites of five cluttered families: 65 palms found in the
    whole picture at MediaPipe's score 0.5, 89 with the first two squares at 0.3 (10 of 50 hand-free
    frames gave a palm; the landmark model's presence score refuses what is no hand). The bottom squares
    (issue 50, session 3), on the 48 of 315 composites (bench-perception's generator, seeds 7, 13 and the
    held-out 11, not the benchmark's) where the first three views found no hand: 13 hands found, all on
    the pasted hand, and no hand in any of the 315 hand-free frames (squares of 0.6 of the height, three
    of them: 14; 0.5, three: 9; CLAHE or grey copies of the first views: 6 and 9). They cost two palm
    passes (~9 ms each) on frames without a hand only."""
    h, w = image_bgr.shape[:2]
    views = [(0, 0, image_bgr)]
    side = min(h, w)
    if max(h, w) > 1.2 * side:
        if w > h:
            views += [(0, 0, image_bgr[:, :side]), (w - side, 0, image_bgr[:, w - side :])]
        else:
            views += [(0, 0, image_bgr[:side]), (0, h - side, image_bgr[h - side :])]
    low = min(w, int(round(BOTTOM_SIDE * h)))
    views += [(0, h - low, image_bgr[h - low :, :low]), (w - low, h - low, image_bgr[h - low :, w - low :])]
    return views
