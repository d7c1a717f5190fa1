"""Imitation fidelity: how well the alive particles' formation covers the target silhouette.

The thesis (Tilki 2012) judged the imitation by eye; we measure it. With T the target mask mapped into the
domain by the same `ImageToDomain` the controller used, N the number of alive particles and
F the union of discs of radius r_d = sqrt(area(T) / (pi * N)) around them (so the discs together could
just cover T):

- iou      = |T ∩ F| / |T ∪ F|
- inside   = fraction of particles inside T dilated by r_d (as in swarm shape-assembly papers)
- coverage = fraction of T's skeleton pixels within 2 * r_d of a particle
- nn_cv    = coefficient of variation (std / mean) of each particle's nearest-neighbour distance: 0 for a
             perfect lattice, high when particles sit in clumps (the region controller's clumps of three: ~0.7)

Areas are counted in cells of one grid in pixel space: the mask's own pixels, split k x k when the mask
is tiny or r_d is under a few pixels. A disc covers the cells whose centres it contains; the grid is
unbounded, so particles far outside the picture still count fully in |T ∪ F|. The skeleton (Zhang-Suen)
is taken at the mask's resolution, shrunk for masks over `_MAX_SKELETON_SIDE` pixels across.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial import cKDTree

from coordinator.control.geometry import ImageToDomain
from perception.skeleton import thin

_MIN_DISC_RADIUS_PX = 4.0  # refine the grid until a disc spans at least this many grid pixels
_MIN_MASK_SIDE_PX = 64  # ... and the mask's shorter side at least this many
_MAX_REFINE = 16
_MAX_SKELETON_SIDE = 160  # thin large masks at a reduced resolution


@dataclass(frozen=True)
class Fidelity:
    iou: float
    inside: float
    coverage: float
    nn_cv: float = 0.0


def nn_cv(positions: np.ndarray) -> float:
    """std / mean of the nearest-neighbour distances (0 with fewer than 2 particles or all coincident)."""
    xy = np.asarray(positions, dtype=float).reshape(-1, 2)
    if len(xy) < 2:
        return 0.0
    d = cKDTree(xy).query(xy, k=2)[0][:, 1]
    mean = float(d.mean())
    return float(d.std() / mean) if mean > 0.0 else 0.0


def _disc_cells(centres: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid cells (row, col) whose centre (k + 0.5) lies within r of each centre, and each cell's particle.

    Works on an unbounded grid, so particles far from the picture cost no more than near ones; the cell
    under a centre always counts, so a sub-cell disc is never empty.
    """
    reach = math.ceil(r) + 1
    off = np.arange(-reach, reach + 1)
    dj, di = (a.ravel() for a in np.meshgrid(off, off))
    base = np.floor(centres).astype(np.int64)
    cols = base[:, :1] + dj[None, :]
    rows = base[:, 1:] + di[None, :]
    d2 = (cols + 0.5 - centres[:, :1]) ** 2 + (rows + 0.5 - centres[:, 1:]) ** 2
    hit = (d2 <= r * r) | ((di == 0) & (dj == 0))[None, :]
    particle = np.nonzero(hit)[0]
    return rows[hit], cols[hit], particle


def _count_distinct(rows: np.ndarray, cols: np.ndarray) -> int:
    """Number of distinct (row, col) cells."""
    if len(rows) == 0:
        return 0
    rows0, cols0 = rows - rows.min(), cols - cols.min()
    width = int(cols0.max()) + 1
    if (int(rows0.max()) + 1) * width < 2**62:
        return len(np.unique(rows0 * width + cols0))
    return len(np.unique(np.stack([rows0, cols0], axis=1), axis=0))


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
    sv, su = np.nonzero(thin(crop))
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
    k = min(_MAX_REFINE, math.ceil(max(1.0, _MIN_DISC_RADIUS_PX / r_px, _MIN_MASK_SIDE_PX / min(mask.shape))))
    t_fine = np.repeat(np.repeat(mask, k, axis=0), k, axis=1)  # T on the grid, k x k cells per pixel

    # F = union of discs, as the set of grid cells they cover; T ∩ F = those cells that lie in T
    rows, cols, particle = _disc_cells(uv * k, r_px * k)
    in_picture = (rows >= 0) & (rows < t_fine.shape[0]) & (cols >= 0) & (cols < t_fine.shape[1])
    in_t = np.zeros(len(rows), dtype=bool)
    in_t[in_picture] = t_fine[rows[in_picture], cols[in_picture]]
    f_cells, inter = _count_distinct(rows, cols), _count_distinct(rows[in_t], cols[in_t])
    union = area_px * k * k + f_cells - inter
    iou = inter / union

    # inside: a particle lies in T dilated by r_d iff its disc meets T
    inside = np.bincount(particle[in_t], minlength=n) > 0

    # coverage: skeleton pixels of T within 2 r_d of a particle
    nearest, _ = cKDTree(uv).query(_skeleton_points(mask), k=1)
    coverage = float(np.mean(nearest <= 2 * r_px))

    return Fidelity(iou=float(iou), inside=float(inside.mean()), coverage=coverage, nn_cv=nn_cv(xy))


def format_fidelity(f: Fidelity) -> str:
    """The lines `fidelity_iou=`, `fidelity_inside=`, `fidelity_coverage=`, `nn_cv=` (no trailing newline)."""
    return (
        f"fidelity_iou={f.iou:.4f}\nfidelity_inside={f.inside:.4f}\nfidelity_coverage={f.coverage:.4f}"
        f"\nnn_cv={f.nn_cv:.4f}"
    )
