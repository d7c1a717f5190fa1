"""The comparison plots of the report (matplotlib, headless): thin helpers, one figure each."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fluidswarm.recording.render import class_colours


def _pyplot():
    """matplotlib's pyplot, headless: imported on the first figure, not with the module (the CLI imports this
    module for `reproduce`'s parser; matplotlib costs every other command ~0.45 s of CPU)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    _pyplot().close(fig)
    return path


def time_series(
    path: Path, panels: list[tuple[str, float, dict[str, np.ndarray], dict[str, float]]], ylabel: str
) -> Path:
    """One panel per (title, dt, {label: series}, {label: thesis level}); thesis levels as dashed lines."""
    fig, axes = _pyplot().subplots(1, len(panels), figsize=(5.2 * len(panels), 3.6), squeeze=False)
    for ax, (title, dt, curves, levels) in zip(axes[0], panels):
        for k, (label, y) in enumerate(curves.items()):
            ax.plot(np.arange(len(y)) * dt, y, color=class_colours([k])[0], label=label, lw=1.3)
        for k, (label, level) in enumerate(levels.items()):
            ax.axhline(level, color=class_colours([k])[0], ls="--", lw=0.9, label=label)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=7)
    return save(fig, path)


def formations(path: Path, panels: list[tuple[str, np.ndarray, np.ndarray, tuple[str, ...]]]) -> Path:
    """Final particle positions, one panel per (title, positions (N, 2), classes, class names)."""
    cols = min(len(panels), 4)
    rows = (len(panels) + cols - 1) // cols
    fig, axes = _pyplot().subplots(rows, cols, figsize=(4.2 * cols, 3.2 * rows), squeeze=False)
    for ax in axes.flat[len(panels) :]:
        ax.axis("off")
    for ax, (title, pos, classes, names) in zip(axes.flat, panels):
        for k in np.unique(classes):
            sel = classes == k
            ax.scatter(
                pos[sel, 0], pos[sel, 1], s=5, color=class_colours([k])[0], label=names[k] if k < len(names) else str(k)
            )
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=8)
        ax.tick_params(labelsize=7)
    axes.flat[0].legend(fontsize=6, loc="best")
    return save(fig, path)


def bars(path: Path, title: str, groups: dict[str, dict[str, float]], ylabel: str) -> Path:
    """Grouped bars: {group label: {series label: value}} (e.g. thesis vs ours per item)."""
    labels = list(groups)
    series = list(dict.fromkeys(s for g in groups.values() for s in g))
    width = 0.8 / max(len(series), 1)
    fig, ax = _pyplot().subplots(figsize=(max(5.0, 1.2 * len(labels) * max(1, len(series)) * 0.6), 3.6))
    x = np.arange(len(labels))
    for k, s in enumerate(series):
        vals = [groups[g].get(s, np.nan) for g in labels]
        ax.bar(x + (k - (len(series) - 1) / 2) * width, vals, width, color=class_colours([k])[0], label=s)
    ax.set_xticks(x)
    ax.set_xticklabels(labels, fontsize=7, rotation=15)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)
    return save(fig, path)


def lines(
    path: Path,
    title: str,
    x,
    curves: dict[str, np.ndarray],
    xlabel: str,
    ylabel: str,
    markers: dict[str, tuple] | None = None,
) -> Path:
    """Curves over a shared x; `markers` {label: (xs, ys)} drawn as points (e.g. the thesis' table)."""
    fig, ax = _pyplot().subplots(figsize=(5.6, 3.6))
    for k, (label, y) in enumerate(curves.items()):
        ax.plot(x, y, "o-", color=class_colours([k])[0], label=label, lw=1.2, ms=3)
    for k, (label, (xs, ys)) in enumerate((markers or {}).items()):
        ax.plot(xs, ys, "s--", color="black" if k == 0 else class_colours([k + 5])[0], label=label, lw=0.9, ms=4)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)
    return save(fig, path)
