"""Pictures of a particle formation (matplotlib, headless)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

CLASS_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f")


def class_colour(k: int) -> str:
    return CLASS_COLOURS[int(k) % len(CLASS_COLOURS)]


def plot_formation(path: str | Path, positions: np.ndarray, classes: np.ndarray, class_names=None, title: str = "",
                   background: np.ndarray | None = None, extent=None, waypoints: np.ndarray | None = None,
                   outline=()) -> Path:
    """Write a PNG of particles coloured by class, optionally over a background image (extent in metres),
    with the command's waypoints or the fill controller's shape (`outline`: rings of (x, y))."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(7, 5), dpi=100)
    if background is not None:
        ax.imshow(background, extent=extent, cmap="Greys", alpha=0.35, origin="upper")
    for k in np.unique(classes):
        sel = classes == k
        label = class_names[k] if class_names is not None and k < len(class_names) else f"class {k}"
        ax.scatter(positions[sel, 0], positions[sel, 1], s=14, color=class_colour(k), label=label)
    for k, ring in enumerate(outline):
        closed = np.array(list(ring) + [ring[0]])
        ax.plot(closed[:, 0], closed[:, 1], color="black", lw=0.6, alpha=0.6, label="fill shape" if k == 0 else None)
    if waypoints is not None and len(waypoints):
        ax.scatter(waypoints[:, 0], waypoints[:, 1], marker="x", color="black", s=30, label="waypoints")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title)
    ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
