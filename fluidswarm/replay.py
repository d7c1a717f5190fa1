"""`fluidswarm replay`: turn a recorded run into pictures, an animation, the thesis' plots and the
fidelity score; or, with `--check`, verify that the recording is complete."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from agent.protocol.errors import UserError
from coordinator.control.fidelity import Fidelity, fidelity
from fluidswarm.recording.analysis import Series, series
from fluidswarm.recording.progress import Progress
from fluidswarm.recording.reader import Recording, as_fidelity, load_run
from fluidswarm.recording.render import GIF_SIZE, SNAPSHOT_SIZE, FormationRenderer, plot_series, save_gif, save_png

SNAPSHOT_FRACTIONS = (0.0, 0.25, 0.5, 0.75, 1.0)


@dataclass(frozen=True)
class ReplayResult:
    snapshots: list[Path]
    gif: Path
    plots: dict[str, Path]  # "speed" | "pressure" | "distance" -> PNG
    series: Series
    fidelity: Fidelity | None  # None when the run recorded no target

    @property
    def paths(self) -> list[Path]:
        return [*self.snapshots, self.gif, *self.plots.values()]


def final_fidelity(run: Recording) -> Fidelity | None:
    """Fidelity of the last recorded step's particles against the last target: the recorder's own score
    when the file holds it (scored once, at the end of the run), else (older files) scored here."""
    recorded = as_fidelity(run.fidelity)
    if recorded is not None:
        return recorded
    if run.target is None or not run.frames:
        return None
    return fidelity(run.target.mask, run.target.transform, run.frames[-1].positions)


def _evenly(n: int, k: int) -> list[int]:
    """k indices spread evenly over range(n), first and last included."""
    return sorted({int(round(i)) for i in np.linspace(0, n - 1, min(n, k))})


def replay(
    path: str | Path,
    out: str | Path | None = None,
    *,
    max_frames: int = 120,
    fps: float = 10.0,
    progress: TextIO | None = None,
) -> ReplayResult:
    """Render `path` into `out` (default: `<RUN>_replay/` beside the file) and score the final formation."""
    if max_frames < 2 or not fps > 0:
        raise UserError(f"need --max-frames >= 2 and --fps > 0, got {max_frames} and {fps}")
    path = Path(path)
    run = load_run(path, images=False)
    if not run.frames:
        raise UserError(f"{path}: the recording holds no particle state")
    out = Path(out) if out is not None else path.with_name(f"{path.stem}_replay")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"{out}: cannot create output directory ({exc.strerror})") from None

    frames = run.frames
    snap_idx = sorted({int(round(f * (len(frames) - 1))) for f in SNAPSHOT_FRACTIONS})
    gif_idx = _evenly(len(frames), max_frames)
    snapshots, gif_frames = [], []
    with Progress(len(snap_idx) + len(gif_idx) + 1, "replay", stream=progress) as bar:
        snap = FormationRenderer(run, SNAPSHOT_SIZE)
        for i in snap_idx:
            snapshots.append(save_png(snap.render(frames[i]), out / f"snapshot_step{frames[i].step:06d}.png"))
            bar.update()
        anim = FormationRenderer(run, GIF_SIZE)
        for i in gif_idx:
            gif_frames.append(anim.render(frames[i]))
            bar.update()
        gif = save_gif(gif_frames, out / "formation.gif", fps)
        s = series(run)
        plots = plot_series(s, out)
        bar.update()
    return ReplayResult(snapshots=snapshots, gif=gif, plots=plots, series=s, fidelity=final_fidelity(run))
