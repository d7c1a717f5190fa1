"""A hand in one picture (a camera frame): its silhouette and recognised class, or why there is none.

Each frame is read on its own -- a hand does not stand still like a person's torso, so nothing is assumed
of the frames before. The picture must show what the shared photographs show: a hand in front of a plain,
bright background. `find_hand` says "no hand found: ..." (`NoHandError`) when

- nothing stands out of the background (an empty picture: `hand_mask` finds no foreground),
- what stands out is too small a part of the picture (a hand leaving it),
- what stands out is not skin-saturated (a hand's silhouette is: the shared photographs' hands have a
  mean saturation of 73-125; the shared Weizmann persons, clothes and all, 41-69), or the background
  around it is not plain (grey: the photographs' 3-17; a cluttered scene's more),
- what stands out does not reach the picture's edge (a held-up hand comes in with its wrist or arm;
  a person standing in a room, seen whole, does not),
- its vectors lie far from the space the training hands span (`EigenClassifier.hand_space_distance`:
  a person, a cluttered background whose segmentation is not a hand).
"""

from __future__ import annotations

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


class NoHandError(SegmentationError):
    """The picture shows no hand in front of a plain background; the message says what was not found."""


@dataclass(frozen=True)
class Hand:
    mask: np.ndarray  # bool, the picture's shape
    label: str  # the classifier's class (the shared set's class folder name: the digit shown)
    confidence: float  # share of the one-vs-one duels the label won (0..1)
    distance: float  # from the hand space (HAND_SPACE_LIMIT and below: a hand)


def find_hand(frame_bgr: np.ndarray, classifier: EigenClassifier) -> Hand:
    """The hand in `frame_bgr` with its class ("best" classifier). Raises NoHandError."""
    try:
        mask = hand_mask(frame_bgr)
    except SegmentationError as exc:
        raise NoHandError(f"no hand found: {exc}") from None
    share = float(mask.mean())
    if share < MIN_HAND_SHARE:
        raise NoHandError(
            f"no hand found: what stands out covers {100 * share:.1f} % of the picture "
            f"(a hand covers at least {100 * MIN_HAND_SHARE:.0f} %; one leaving the picture?)"
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
            f"one's at most {MAX_BACKGROUND_SATURATION:.0f}; clutter?)"
        )
    skin = float(sat[mask].mean())
    if skin < MIN_SKIN_SATURATION:
        raise NoHandError(
            f"no hand found: what stands out is not skin-coloured (saturation {skin:.0f}, a hand's "
            f"at least {MIN_SKIN_SATURATION:.0f}; a person?)"
        )
    if not (mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any()):
        raise NoHandError(
            "no hand found: what stands out does not reach the picture's edge (a hand held up "
            "comes in with its wrist; a person seen whole?)"
        )
    x = hand_hog([frame_bgr], [mask])
    distance = float(classifier.hand_space_distance(x)[0])
    if distance > HAND_SPACE_LIMIT:
        raise NoHandError(
            f"no hand found: the silhouette is not a hand's (distance from the hand space "
            f"{distance:.2f} > {HAND_SPACE_LIMIT}; a person, or a cluttered background?)"
        )
    label, conf = classifier.predict_features(x)
    return Hand(mask, str(label[0]), float(conf[0]), distance)
