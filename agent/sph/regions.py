"""A start layout split into compact regions, one per host of a multi-host run (docs/multi-host.md).

Recursive coordinate bisection (Berger & Bokhari, "A partitioning strategy for nonuniform problems on
multiprocessors", IEEE Trans. Computers 36(5), 1987): the positions are sorted along the longer side of their
bounding box and cut where the first part holds the share of the regions it is to make (the median when both
halves make as many); each part is cut again the same way until there are `m`. A region's agents are each
other's neighbours, so only the agents along a cut hear agents of another region. Shares differ by at most
one agent: the n = q·m + r positions make r regions of q + 1 and m - r of q, the larger ones first.

Pure (arrays in, arrays out) and deterministic: ties in a coordinate are broken by the position's index, so
the same layout gives the same regions on every host. Where a cut falls inside a row of equal coordinates the
two regions' bounding boxes share that edge; their interiors never overlap.
"""

from __future__ import annotations

import numpy as np


def region_sizes(n: int, m: int) -> list[int]:
    """How many of `n` positions each of `m` regions gets: q + 1 for the first r, q for the rest (n = q·m + r)."""
    if not 1 <= m <= n:
        raise ValueError(f"{m} regions of {n} positions: the number of regions must be 1..{n}")
    q, r = divmod(n, m)
    return [q + 1 if k < r else q for k in range(m)]


def regions(positions: np.ndarray, m: int) -> list[np.ndarray]:
    """The indices (into `positions`, (n, 2)) of each of `m` compact regions, each sorted; region k's size is
    region_sizes(n, m)[k]. ValueError for positions that are not (n, 2) finite numbers or m outside 1..n."""
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"positions: expected an (n, 2) array, got shape {pos.shape}")
    if not np.isfinite(pos).all():
        raise ValueError("positions: every coordinate must be a finite number")
    sizes = region_sizes(len(pos), m)
    out: list[np.ndarray] = []
    _bisect(pos, np.arange(len(pos)), sizes, out)
    return out


def _bisect(pos: np.ndarray, idx: np.ndarray, sizes: list[int], out: list[np.ndarray]) -> None:
    if len(sizes) == 1:
        out.append(np.sort(idx))
        return
    half = len(sizes) // 2
    below = sum(sizes[:half])
    p = pos[idx]
    extent = p.max(axis=0) - p.min(axis=0)
    axis = 0 if extent[0] >= extent[1] else 1
    order = idx[np.lexsort((idx, p[:, 1 - axis], p[:, axis]))]  # along the axis, then across it, then by index
    _bisect(pos, order[:below], sizes[:half], out)
    _bisect(pos, order[below:], sizes[half:], out)


def share(positions: np.ndarray, k: int, m: int) -> np.ndarray:
    """The indices of region `k` (1..m) of `m`: what `--share K/M` starts on one host."""
    if not 1 <= k <= m:
        raise ValueError(f"share {k}/{m}: K must be 1..{m}")
    return regions(positions, m)[k - 1]


def part_labels(parts: list[np.ndarray], n: int) -> np.ndarray:
    """For each of `n` positions, the index of the part (index arrays) that holds it; -1 for none."""
    label = np.full(n, -1, dtype=int)
    for k, part in enumerate(parts):
        label[part] = k
    return label


def central_first(positions: np.ndarray, parts: list[np.ndarray], radius: float) -> list[np.ndarray]:
    """`parts` (index arrays into `positions`) with the part that has the most pairs within `radius` of the
    other parts moved first, the others in their order (ties: the earlier part).

    Why: a run's workers connect their routers to the main host's, which runs the first part. A pair of agents on
    two workers then crosses two router links (through the main host's router), a pair between a worker and the
    main host one: the main host takes the part that borders the most others. On the three-host test's recording
    (90 agents, three regions of its formation, one pair of them not touching) the links carried 3,079 neighbour
    pairs with the middle region on the hub against 4,476 with the first (scripts/share_cuts_over_run.py)."""
    from scipy.spatial import cKDTree

    pos = np.asarray(positions, dtype=float)
    label = part_labels(parts, len(pos))
    pairs = cKDTree(pos).query_pairs(radius, output_type="ndarray")
    pairs = pairs.reshape(-1, 2)  # (0, 2) when no pair is that close
    a, b = label[pairs[:, 0]], label[pairs[:, 1]]
    across = (a != b) & (a >= 0) & (b >= 0)
    border = np.bincount(np.concatenate([a[across], b[across]]), minlength=len(parts))
    hub = int(np.argmax(border))  # the first of equals
    return [parts[hub]] + [p for k, p in enumerate(parts) if k != hub]
