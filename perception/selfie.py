"""A person's silhouette from one frame, in front of any background: MediaPipe's selfie segmentation
(`selfie_segmentation.tflite`, the 256 x 256 general model, perception/models.py).

The frame is letterboxed into the model's square (its aspect kept, padded black), the model's per-pixel
person probability mapped back to the frame and thresholded at 0.5; the person is the largest component
(a second person or a poster is not the subject) with its holes filled. No person: fewer than
MIN_PERSON_SHARE of the frame (`NoPersonError`, as `person_regions` says it). Background subtraction
(perception/segmentation.py `person_regions`) stays the reading of a static camera's clip; this one needs
no clip (a moving camera, a changing room).
"""

from __future__ import annotations

import cv2
import numpy as np

from perception.body_parts import split_body
from perception.landmarks import letterbox
from perception.models import run_model
from perception.segmentation import NoPersonError, PersonRegions

MODEL = "selfie_segmentation.tflite"
SIZE = 256
THRESHOLD = 0.5
MIN_PERSON_SHARE = 0.01  # of the frame


def person_probability(frame_bgr: np.ndarray) -> np.ndarray:
    """(rows, cols) float32 in 0..1: the model's probability that each pixel is a person."""
    rgb = cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2RGB)
    square, s, px, py = letterbox(rgb, SIZE)
    (out,) = run_model(MODEL, square, ("activation_10",))
    prob = out.reshape(SIZE, SIZE).astype(np.float32)
    h, w = frame_bgr.shape[:2]
    x0, y0 = int(round(px)), int(round(py))
    x1, y1 = x0 + max(1, round(w * s)), y0 + max(1, round(h * s))
    return cv2.resize(prob[y0:y1, x0:x1], (w, h), interpolation=cv2.INTER_LINEAR)


def person_silhouette(frame_bgr: np.ndarray) -> np.ndarray:
    """The person's silhouette (bool, the frame's shape). Raises NoPersonError."""
    fg = (person_probability(frame_bgr) >= THRESHOLD).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(fg, connectivity=8)
    if n <= 1 or stats[1:, cv2.CC_STAT_AREA].max() < MIN_PERSON_SHARE * fg.size:
        raise NoPersonError("no person found: the person segmentation sees nobody in the frame")
    mask = (labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))).astype(np.uint8)
    padded = np.pad(mask, 1)
    cv2.floodFill(padded, None, (0, 0), 1)
    return mask.astype(bool) | (padded[1:-1, 1:-1] == 0)


def person_in_frame(frame_bgr: np.ndarray) -> PersonRegions:
    """One frame's person with its parts (`split_body` without motion: an arm is what lies beside the
    torso band or above the head, still or not), as `person_regions` gives a clip's. Raises NoPersonError."""
    sil = person_silhouette(frame_bgr)
    parts = split_body(sil)
    ys, xs = np.nonzero(sil)
    bbox = (int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1))
    return PersonRegions(sil, sil, parts.head, parts.torso, parts.left_arm, parts.right_arm, bbox)
