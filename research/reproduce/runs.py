"""Run a set-up on the vectorised reference driver and record per-class means at every step."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from agent.sph.particle import FROZEN, VX, VY, P
from agent.sph.reference import VectorisedDriver
from agent.sph.setups import Setup


@dataclass
class Series:
    """Per-step, per-class means of a run (arrays of shape (steps + 1, n_classes); row 0 is the start).

    speed [m/s] mean |v|; vx, vy [m/s] mean velocity components; p [N/m] mean Tait pressure (of the
    previous configuration, as the state carries it); final: the last states (N, NFIELDS).
    Frozen particles (left the domain) count with their zero velocity, as in the thesis' Fig. 4.12.
    """

    speed: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    avy: np.ndarray  # mean |vy|: the sideways speed (the signed means of two mirrored bands cancel)
    p: np.ndarray
    final: np.ndarray
    frozen: np.ndarray  # (steps + 1,) number of frozen particles

    def ratio(self, a, b, field: str = "speed", start: int = 1) -> float:
        """Time mean of class group `a` over time mean of class group `b` (each a list of class indices)."""
        arr = getattr(self, field)[start:]
        return float(arr[:, a].mean() / arr[:, b].mean())


def class_means(values: np.ndarray, classes: np.ndarray, n_classes: int) -> np.ndarray:
    counts = np.bincount(classes, minlength=n_classes)
    return np.bincount(classes, values, minlength=n_classes) / np.maximum(counts, 1)


def record(setup: Setup, steps: int, controls=None, classes: np.ndarray | None = None, driver=None) -> Series:
    """Run `steps` steps of `setup` (or of a given driver) and record the per-class means."""
    classes = setup.classes if classes is None else classes
    k = int(classes.max()) + 1
    d = driver or VectorisedDriver(setup.ids, setup.states, controls or setup.controls, setup.params)
    rows: dict[str, list[np.ndarray]] = {name: [] for name in ("speed", "vx", "vy", "avy", "p")}
    frozen: list[int] = []

    def sample(s):
        rows["speed"].append(class_means(np.hypot(s[:, VX], s[:, VY]), classes, k))
        rows["vx"].append(class_means(s[:, VX], classes, k))
        rows["vy"].append(class_means(s[:, VY], classes, k))
        rows["avy"].append(class_means(np.abs(s[:, VY]), classes, k))
        rows["p"].append(class_means(s[:, P], classes, k))
        frozen.append(int((s[:, FROZEN] != 0).sum()))

    sample(d.states)
    for _ in range(steps):
        d.step()
        sample(d.states)
    speed, vx, vy, avy, p = (np.array(rows[n]) for n in ("speed", "vx", "vy", "avy", "p"))
    return Series(speed, vx, vy, avy, p, d.states.copy(), np.array(frozen))
