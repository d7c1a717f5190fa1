"""Hand silhouette from a photograph on a plain, white-ish background.

The background is bright and grey (low saturation); skin is saturated. Otsu's threshold on a blend of
saturation and darkness separates them despite the set's shadows and vignetting; morphology closes gaps
and the largest component is the hand.
"""

from __future__ import annotations

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
