"""The per-step series behind the thesis' analysis plots, one value per recorded step.

- average speed |v| per particle class over time (thesis Fig. 4.12, 6.15)
- average pressure over time (Fig. 6.15a, 6.17)
- average inter-particle distance over time (Fig. 6.16). Two measures: `nn_distance`, the mean distance
  from each particle to its nearest neighbour (cKDTree; the formation's spacing, comparable to the
  smoothing length h), and `pair_distance`, the mean over all pairs (scipy pdist; the formation's size).
  A step with fewer than two particles has NaN distances.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.distance import pdist

from fluidswarm.recording.reader import Recording


@dataclass(frozen=True)
class Series:
    steps: np.ndarray  # (S,)
    t: np.ndarray  # (S,) seconds
    speed_by_class: dict[int, np.ndarray]  # class id -> (S,) mean |v|, NaN where the class has no particle
    pressure: np.ndarray  # (S,) mean p
    nn_distance: np.ndarray  # (S,) mean nearest-neighbour distance
    pair_distance: np.ndarray  # (S,) mean pairwise distance


def series(run: Recording) -> Series:
    frames = run.frames
    n = len(frames)
    classes = sorted({int(c) for f in frames for c in np.unique(f.class_ids)})
    speed = {c: np.full(n, np.nan) for c in classes}
    pressure = np.full(n, np.nan)
    nn = np.full(n, np.nan)
    pair = np.full(n, np.nan)
    for k, f in enumerate(frames):
        v = np.linalg.norm(f.velocities, axis=1)
        for c in classes:
            sel = f.class_ids == c
            if sel.any():
                speed[c][k] = v[sel].mean()
        if len(f.pressure):
            pressure[k] = f.pressure.mean()
        if len(f.positions) >= 2:
            d, _ = cKDTree(f.positions).query(f.positions, k=2)
            nn[k] = d[:, 1].mean()
            pair[k] = pdist(f.positions).mean()
    return Series(
        steps=run.steps, t=run.times, speed_by_class=speed, pressure=pressure, nn_distance=nn, pair_distance=pair
    )
