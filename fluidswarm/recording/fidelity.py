"""Imitation fidelity: how well the alive particles' formation covers the target silhouette.

The thesis (Tilki 2012) judged the imitation by eye; we measure it. With T the target mask mapped into the
domain by the same `ImageToDomain` the controller used, N the number of alive particles and
F the union of discs of radius r_d = sqrt(area(T) / (pi * N)) around them (so the discs together could
just cover T):

- iou      = |T ∩ F| / |T ∪ F|
- inside   = fraction of particles inside T dilated by r_d (as in swarm shape-assembly papers)
- coverage = fraction of T's skeleton pixels within 2 * r_d of a particle

Everything is rasterised in pixel space on one grid: the mask's own resolution, refined by an integer
factor when the mask is tiny or r_d is under a few pixels, coarsened only when the particles are spread so
far from the picture that the grid would exceed `_MAX_GRID_PIXELS`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial import cKDTree

from fluidswarm.geometry import ImageToDomain
from fluidswarm.recording.skeleton import skeletonize

_MIN_DISC_RADIUS_PX = 4.0  # refine the grid until a disc spans at least this many grid pixels
_MIN_MASK_SIDE_PX = 64  # ... and the mask's shorter side at least this many
_MAX_REFINE = 16
_MAX_GRID_PIXELS = 4_000_000
_SUBPIXEL_BITS = 4  # cv2.circle fixed-point precision
_MAX_SKELETON_SIDE = 160  # thin large masks at a reduced resolution


@dataclass(frozen=True)
class Fidelity:
    iou: float
    inside: float
    coverage: float


@dataclass(frozen=True)
class _Grid:
    """Grid pixel (row i, col j) covers mask-pixel coordinates u in [u0 + j*s, u0 + (j+1)*s), same for v."""

    u0: float
    v0: float
    s: float  # grid pixel size in mask pixels (< 1 refines, > 1 coarsens)
    rows: int
    cols: int

    def to_grid(self, uv: np.ndarray) -> np.ndarray:
        """Continuous mask-pixel coordinates -> continuous grid coordinates (pixel centres at k + 0.5)."""
        return np.stack([(uv[:, 0] - self.u0) / self.s, (uv[:, 1] - self.v0) / self.s], axis=1)

    def sample(self, mask: np.ndarray) -> np.ndarray:
        """The mask resampled onto this grid (nearest: the mask pixel under each grid pixel's centre)."""
        u = self.u0 + (np.arange(self.cols) + 0.5) * self.s
        v = self.v0 + (np.arange(self.rows) + 0.5) * self.s
        uj, vi = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
        col_ok = (uj >= 0) & (uj < mask.shape[1])
        row_ok = (vi >= 0) & (vi < mask.shape[0])
        out = np.zeros((self.rows, self.cols), dtype=bool)
        out[np.ix_(row_ok, col_ok)] = mask[np.ix_(vi[row_ok], uj[col_ok])]
        return out


def _make_grid(mask_shape: tuple[int, int], uv: np.ndarray, r_px: float) -> _Grid:
    rows, cols = mask_shape
    refine = max(1.0, _MIN_DISC_RADIUS_PX / r_px, _MIN_MASK_SIDE_PX / min(rows, cols))
    s = 1.0 / min(math.ceil(refine), _MAX_REFINE)
    pad = r_px + 2 * s
    umin = min(0.0, float(uv[:, 0].min()) - r_px) - pad
    vmin = min(0.0, float(uv[:, 1].min()) - r_px) - pad
    umax = max(float(cols), float(uv[:, 0].max()) + r_px) + pad
    vmax = max(float(rows), float(uv[:, 1].max()) + r_px) + pad
    # keep grid lines on mask-pixel boundaries so sampling the mask is exact
    umin, vmin = math.floor(umin), math.floor(vmin)
    while math.ceil((umax - umin) / s) * math.ceil((vmax - vmin) / s) > _MAX_GRID_PIXELS:
        s *= 2
    return _Grid(u0=umin, v0=vmin, s=s, rows=math.ceil((vmax - vmin) / s), cols=math.ceil((umax - umin) / s))


def _skeleton_points(mask: np.ndarray) -> np.ndarray:
    """Centres (u, v) in mask pixels of T's skeleton, thinned at most `_MAX_SKELETON_SIDE` pixels across.

    Thinning costs one pass per pixel of half-thickness, so a large mask is cropped to its bounding box
    and shrunk by an integer factor first (the skeleton's pixels then stand for blocks of mask pixels).
    """
    rows, cols = np.nonzero(mask)
    r0, c0 = rows.min(), cols.min()
    crop = mask[r0 : rows.max() + 1, c0 : cols.max() + 1]
    k = max(1, math.ceil(max(crop.shape) / _MAX_SKELETON_SIDE))
    if k > 1:
        h, w = math.ceil(crop.shape[0] / k), math.ceil(crop.shape[1] / k)
        padded = np.zeros((h * k, w * k), dtype=np.float32)
        padded[: crop.shape[0], : crop.shape[1]] = crop
        crop = cv2.resize(padded, (w, h), interpolation=cv2.INTER_AREA) >= 0.5
        if not crop.any():  # a thin shape vanished when shrunk: thin it at full size
            k, crop = 1, mask[r0 : rows.max() + 1, c0 : cols.max() + 1]
    sv, su = np.nonzero(skeletonize(crop))
    return np.stack([c0 + (su + 0.5) * k, r0 + (sv + 0.5) * k], axis=1)


def fidelity(target_mask: np.ndarray, transform: ImageToDomain, positions: np.ndarray) -> Fidelity:
    """Score the alive particles' `positions` (N, 2, domain metres) against `target_mask` (image pixels).

    `transform` is the image-to-domain map the controller used. An empty formation scores 0 on all terms.
    """
    mask = np.asarray(target_mask)
    if mask.ndim != 2 or mask.size == 0:
        raise ValueError(f"target mask must be a non-empty 2-D array, got shape {mask.shape}")
    mask = mask.astype(bool)
    area_px = int(mask.sum())
    if area_px == 0:
        raise ValueError("target mask has no foreground pixel")
    xy = np.asarray(positions, dtype=float).reshape(-1, 2)
    if not np.isfinite(xy).all():
        raise ValueError("positions must be finite")
    n = len(xy)
    if n == 0:
        return Fidelity(iou=0.0, inside=0.0, coverage=0.0)

    r_px = math.sqrt(area_px / (math.pi * n))  # r_d = sqrt(area(T) / (pi N)), in mask pixels
    uv = transform.to_pixels(xy)
    grid = _make_grid(mask.shape, uv, r_px)
    t_grid = grid.sample(mask)
    centres = grid.to_grid(uv)
    r_grid = r_px / grid.s

    # F: union of discs. cv2 puts pixel centres at integer coordinates, ours are at k + 0.5.
    f_grid = np.zeros((grid.rows, grid.cols), dtype=np.uint8)
    one = 1 << _SUBPIXEL_BITS
    fixed = np.round((centres - 0.5) * one).astype(np.int64)
    radius = max(1, int(round(r_grid * one)))
    for cx, cy in fixed:
        cv2.circle(f_grid, (int(cx), int(cy)), radius, 1, thickness=-1, lineType=cv2.LINE_8, shift=_SUBPIXEL_BITS)
    f_bool = f_grid.astype(bool)
    inter = np.count_nonzero(t_grid & f_bool)
    union = np.count_nonzero(t_grid | f_bool)
    iou = inter / union if union else 0.0

    # inside: distance from each particle's grid pixel to the nearest T pixel <= r_d
    dist_to_t = cv2.distanceTransform((~t_grid).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    cell = np.floor(centres).astype(np.int64)
    on_grid = (cell[:, 0] >= 0) & (cell[:, 0] < grid.cols) & (cell[:, 1] >= 0) & (cell[:, 1] < grid.rows)
    inside = np.zeros(n, dtype=bool)
    inside[on_grid] = dist_to_t[cell[on_grid, 1], cell[on_grid, 0]] <= r_grid

    # coverage: skeleton pixels of T within 2 r_d of a particle
    nearest, _ = cKDTree(uv).query(_skeleton_points(mask), k=1)
    coverage = float(np.mean(nearest <= 2 * r_px))

    return Fidelity(iou=float(iou), inside=float(inside.mean()), coverage=coverage)


def format_fidelity(f: Fidelity) -> str:
    """The three lines `fidelity_iou=...`, `fidelity_inside=...`, `fidelity_coverage=...` (no trailing newline)."""
    return f"fidelity_iou={f.iou:.4f}\nfidelity_inside={f.inside:.4f}\nfidelity_coverage={f.coverage:.4f}"
