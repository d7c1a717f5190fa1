"""Image -> vector, for the eigen-image classifier.

Two preprocessing chains:

- `pixels` (thesis §4.4.1): grey levels at a fixed size, each image normalised to zero mean and unit norm
  (the thesis' "image normalisation to reduce the error because of the lighting condition").
- `hand_hog`: segment the hand (`perception.segmentation.hand_mask`), crop a square around its bounding
  box so position and scale no longer matter, then histograms of oriented gradients (HOG, Dalal & Triggs
  2005, written here in numpy) of both the grey crop and the silhouette crop.
"""

from __future__ import annotations

import cv2
import numpy as np

from perception.segmentation import SegmentationError, hand_mask

WORK_SIZE = 100  # every photograph is first brought to 100 x 100 (the shared set's size)
PIXEL_SIZE = 50  # the baseline's grey image side
CROP_SIZE = 64  # the best pipeline's crop side
CELL = 8  # HOG cell side in pixels
BINS = 9  # HOG unsigned orientation bins over 0..180 degrees
CROP_MARGIN = 0.08  # crop side = (1 + 2 * margin) * the longer side of the hand's bounding box


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


def hog(gray: np.ndarray, cell: int = CELL, bins: int = BINS, block: int = 2) -> np.ndarray:
    """HOG of one image or a stack (N, H, W): unsigned gradients, linear bin interpolation,
    2x2-cell blocks with L2-Hys normalisation (clip 0.2). Returns (D,) or (N, D)."""
    g = np.asarray(gray, np.float32)
    single = g.ndim == 2
    if single:
        g = g[None]
    n, h, w = g.shape
    gx = np.zeros_like(g)
    gy = np.zeros_like(g)
    gx[:, :, 1:-1] = g[:, :, 2:] - g[:, :, :-2]
    gy[:, 1:-1, :] = g[:, 2:, :] - g[:, :-2, :]
    ch, cw = h // cell, w // cell
    mag = np.hypot(gx, gy)[:, : ch * cell, : cw * cell]
    pos = (np.degrees(np.arctan2(gy, gx)) % 180.0)[:, : ch * cell, : cw * cell] / (180.0 / bins)
    lo = np.floor(pos).astype(np.int64)
    frac = (pos - lo).astype(np.float32)
    lo %= bins
    hi = (lo + 1) % bins
    hist = np.zeros((n, ch, cw, bins), np.float32)
    for b in range(bins):
        m = mag * ((lo == b) * (1.0 - frac) + (hi == b) * frac)
        hist[..., b] = m.reshape(n, ch, cell, cw, cell).sum(axis=(2, 4))
    nb_r, nb_c = ch - block + 1, cw - block + 1
    blocks = np.concatenate([hist[:, i:i + nb_r, j:j + nb_c] for i in range(block) for j in range(block)], axis=-1)
    blocks /= np.sqrt((blocks ** 2).sum(-1, keepdims=True) + 1e-6)
    np.minimum(blocks, 0.2, out=blocks)
    blocks /= np.sqrt((blocks ** 2).sum(-1, keepdims=True) + 1e-6)
    out = blocks.reshape(n, -1)
    return out[0] if single else out


def crop_square(image: np.ndarray, mask: np.ndarray, size: int = CROP_SIZE, margin: float = CROP_MARGIN) -> np.ndarray:
    """A size x size crop centred on the mask's bounding box, scaled so its longer side fits with margin."""
    ys, xs = np.nonzero(mask)
    if len(ys) == 0:
        return cv2.resize(image, (size, size), interpolation=cv2.INTER_AREA)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    side = max(y1 - y0, x1 - x0) * (1 + 2 * margin)
    cy, cx = (y0 + y1) / 2.0, (x0 + x1) / 2.0
    s = size / side
    m = np.float32([[s, 0, size / 2 - cx * s], [0, s, size / 2 - cy * s]])
    return cv2.warpAffine(image, m, (size, size), flags=cv2.INTER_AREA, borderMode=cv2.BORDER_REPLICATE)


def safe_mask(image_bgr: np.ndarray) -> np.ndarray:
    """The hand mask, or the whole picture if segmentation finds nothing (the classifier never fails on it)."""
    try:
        return hand_mask(image_bgr)
    except SegmentationError:
        return np.ones(image_bgr.shape[:2], bool)


def hand_hog(images: list[np.ndarray]) -> np.ndarray:
    """Best pipeline's features: [HOG(grey crop), HOG(silhouette crop)] per image, (N, D) float32."""
    greys, sils = [], []
    for im in images:
        img = to_work_size(im)
        mask = safe_mask(img)
        greys.append(crop_square(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY), mask))
        sils.append(crop_square(mask.astype(np.uint8) * 255, mask))
    return np.hstack([hog(np.stack(greys)), hog(np.stack(sils))]).astype(np.float32)
