"""Image -> vector, for the eigen-image classifier.

Two preprocessing chains:

- `pixels` (thesis §4.4.1): grey levels at a fixed size, each image normalised to zero mean and unit norm
  (the thesis' "image normalisation to reduce the error because of the lighting condition").
- `hand_hog`: segment the hand (`perception.segmentation.hand_mask`), crop a square around its bounding
  box so position and scale no longer matter, then histograms of oriented gradients (HOG, Dalal & Triggs
  2005, OpenCV's `HOGDescriptor`) of both the grey crop and the silhouette crop, at two cell sizes (8 and
  16 px: the fingers' edges and the hand's coarse outline), square-rooted (Hellinger / power
  normalisation: large bins no longer dominate the distances). The silhouette's half weighs half.
  5-fold cross-validation on the shared set, RBF SVM on top (docs/perception.md): one cell size 0.972,
  both 0.976, square-rooted 0.976 (best min fold).
"""

from __future__ import annotations

import cv2
import numpy as np

from perception.segmentation import SegmentationError, hand_mask

WORK_SIZE = 100  # every photograph is first brought to 100 x 100 (the shared set's size)
PIXEL_SIZE = 50  # the baseline's grey image side
CROP_SIZE = 48  # the best pipeline's crop side (64 cross-validated alike, at twice the HOG cost)
BINS = 9  # HOG unsigned orientation bins over 0..180 degrees
CROP_MARGIN = 0.08  # crop side = (1 + 2 * margin) * the longer side of the hand's bounding box
HOG_CELLS = (8, 16)  # hand_hog's cell sides [px] on the CROP_SIZE crop
# Training copies of each hand turned by these angles [deg] (hands are held tilted; the shared set's few
# tilted ones were the errors): 5-fold cross-validation on the documented split's training part, all ten
# classes 0.972 -> 0.983, classes 0,1,2,4,5 0.992 -> 0.998; +-12 or four angles no better.
TRAINING_ANGLES = (0.0, -8.0, 8.0)
SILHOUETTE_WEIGHT = 0.5  # of the silhouette crop's HOG beside the grey crop's (chosen by cross-validation)


def to_work_size(image_bgr: np.ndarray) -> np.ndarray:
    """The picture as 3-channel BGR at WORK_SIZE x WORK_SIZE (area interpolation)."""
    img = image_bgr if image_bgr.ndim == 3 else cv2.cvtColor(image_bgr, cv2.COLOR_GRAY2BGR)
    if img.shape[:2] != (WORK_SIZE, WORK_SIZE):
        img = cv2.resize(img, (WORK_SIZE, WORK_SIZE), interpolation=cv2.INTER_AREA)
    return img


def pixels(images: list[np.ndarray], size: int = PIXEL_SIZE) -> np.ndarray:
    """Thesis baseline: (N, size*size) grey images, each with zero mean and unit Euclidean norm."""
    out = np.empty((len(images), size * size), np.float32)
    for i, im in enumerate(images):
        g = cv2.cvtColor(to_work_size(im), cv2.COLOR_BGR2GRAY)
        v = cv2.resize(g, (size, size), interpolation=cv2.INTER_AREA).astype(np.float32).ravel()
        v -= v.mean()
        out[i] = v / max(float(np.linalg.norm(v)), 1e-6)
    return out


def crop_square(
    image: np.ndarray, mask: np.ndarray, size: int = CROP_SIZE, margin: float = CROP_MARGIN, angle: float = 0.0
) -> np.ndarray:
    """A size x size crop centred on the mask's bounding box, scaled so its longer side fits with margin,
    turned by `angle` degrees (counter-clockwise) about that centre."""
    ys, xs = np.nonzero(mask)
    if len(ys) == 0:
        return cv2.resize(image, (size, size), interpolation=cv2.INTER_AREA)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    side = max(y1 - y0, x1 - x0) * (1 + 2 * margin)
    cy, cx = (y0 + y1) / 2.0, (x0 + x1) / 2.0
    if angle == 0.0:
        s = size / side
        m = np.array([[s, 0, size / 2 - cx * s], [0, s, size / 2 - cy * s]], dtype=np.float32)
        return cv2.warpAffine(image, m, (size, size), flags=cv2.INTER_AREA, borderMode=cv2.BORDER_REPLICATE)
    m = cv2.getRotationMatrix2D((float(cx), float(cy)), angle, size / side)
    m[0, 2] += size / 2 - cx
    m[1, 2] += size / 2 - cy
    return cv2.warpAffine(image, m, (size, size), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def safe_mask(image_bgr: np.ndarray) -> np.ndarray:
    """The hand mask, or the whole picture if segmentation finds nothing (the classifier never fails on it)."""
    try:
        return hand_mask(image_bgr)
    except SegmentationError:
        return np.ones(image_bgr.shape[:2], bool)


def _descriptor(cell: int, size: int = CROP_SIZE) -> cv2.HOGDescriptor:
    # 2 x 2-cell blocks moved by one cell, BINS unsigned bins, L2-Hys: Dalal & Triggs' choices
    return cv2.HOGDescriptor((size, size), (2 * cell, 2 * cell), (cell, cell), (cell, cell), BINS)


def hand_crops(
    image_bgr: np.ndarray, mask: np.ndarray | None = None, angle: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """(grey crop, silhouette crop) of the hand, CROP_SIZE square, uint8; `mask` default: hand_mask's."""
    img = to_work_size(image_bgr)
    if mask is None:
        mask = safe_mask(img)
    elif mask.shape != img.shape[:2]:
        mask = cv2.resize(mask.astype(np.uint8), img.shape[1::-1], interpolation=cv2.INTER_NEAREST).astype(bool)
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    return crop_square(grey, mask, angle=angle), crop_square(mask.astype(np.uint8) * 255, mask, angle=angle)


def hand_hog(
    images: list[np.ndarray], masks: list[np.ndarray | None] | None = None, angles: tuple[float, ...] = (0.0,)
) -> np.ndarray:
    """Best pipeline's features per image, (len(angles) * N, D) float32, angle-major (all images at
    angles[0], then at angles[1], ...): sqrt of [HOG(grey crop), w * HOG(silhouette crop)] at each of
    HOG_CELLS. `masks`: the hands' silhouettes if already known (default hand_mask's). The hand is
    segmented once per image whatever the number of angles."""
    descriptors = [_descriptor(c) for c in HOG_CELLS]
    out: list[list[np.ndarray]] = [[] for _ in angles]
    for k, im in enumerate(images):
        img = to_work_size(im)
        mask = safe_mask(img) if masks is None or masks[k] is None else masks[k]
        for a, angle in enumerate(angles):
            grey, sil = hand_crops(img, mask, angle)
            parts = []
            for d in descriptors:
                parts += [np.asarray(d.compute(grey)).ravel(), SILHOUETTE_WEIGHT * np.asarray(d.compute(sil)).ravel()]
            out[a].append(np.sqrt(np.concatenate(parts)))
    return np.array([v for per_angle in out for v in per_angle], np.float32).reshape(len(angles) * len(images), -1)
