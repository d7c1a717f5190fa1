"""Zhang-Suen thinning of a binary mask, vectorised with a neighbourhood code and two lookup tables.

T. Y. Zhang and C. Y. Suen, "A fast parallel algorithm for thinning digital patterns", Commun. ACM 27(3),
1984. For a foreground pixel P1 with neighbours P2..P9 (clockwise from north), let B = number of
foreground neighbours and A = number of 0->1 transitions in the cyclic sequence P2, P3, ..., P9, P2.
P1 is removed when 2 <= B <= 6, A == 1 and
  sub-iteration 1: P2*P4*P6 == 0 and P4*P6*P8 == 0
  sub-iteration 2: P2*P4*P8 == 0 and P2*P6*P8 == 0
until neither sub-iteration removes a pixel. (opencv-python-headless ships no `cv2.ximgproc.thinning`.)
"""

from __future__ import annotations

import cv2
import numpy as np

# Bit k of the neighbourhood code is neighbour P(k+2); cv2.filter2D correlates, so kernel[dy+1, dx+1]
# weighs the pixel at (row + dy, col + dx).
_CODE_KERNEL = np.array(
    [[128, 1, 2],  # P9 (NW), P2 (N), P3 (NE)
     [64, 0, 4],  # P8 (W),         P4 (E)
     [32, 16, 8]],  # P7 (SW), P6 (S), P5 (SE)
    dtype=np.float32,
)


def _removal_tables() -> tuple[np.ndarray, np.ndarray]:
    first = np.zeros(256, dtype=bool)
    second = np.zeros(256, dtype=bool)
    for code in range(256):
        p = [(code >> k) & 1 for k in range(8)]  # p[0] = P2 ... p[7] = P9
        p2, p3, p4, p5, p6, p7, p8, p9 = p
        b = sum(p)
        a = sum(1 for k in range(8) if p[k] == 0 and p[(k + 1) % 8] == 1)
        if not (2 <= b <= 6 and a == 1):
            continue
        first[code] = p2 * p4 * p6 == 0 and p4 * p6 * p8 == 0
        second[code] = p2 * p4 * p8 == 0 and p2 * p6 * p8 == 0
    return first, second


_REMOVE_FIRST, _REMOVE_SECOND = _removal_tables()


def skeletonize(mask: np.ndarray) -> np.ndarray:
    """One-pixel-wide skeleton of a 2-D boolean mask (Zhang-Suen); returns a boolean array of the same shape."""
    mask = np.asarray(mask)
    if mask.ndim != 2:
        raise ValueError(f"mask must be 2-D, got shape {mask.shape}")
    img = mask.astype(np.float32, copy=True) > 0
    img = img.astype(np.float32)
    while True:
        changed = False
        for table in (_REMOVE_FIRST, _REMOVE_SECOND):
            code = cv2.filter2D(img, cv2.CV_32F, _CODE_KERNEL, borderType=cv2.BORDER_CONSTANT)
            remove = table[code.astype(np.uint8)] & (img > 0)
            if remove.any():
                img[remove] = 0
                changed = True
        if not changed:
            return img > 0
