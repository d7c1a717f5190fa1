"""Pictures of a formation and of a run: `plot_formation` (one formation over its target, the PNG of
`imitate` and `simulate`), the frames of a recorded run (target silhouette, particles by class, waypoints,
ellipses) and the analysis plots. One class colour table (schemas.CLASS_COLOURS, also in the MCAP file and
Foxglove). Matplotlib's object API with the Agg canvas (no pyplot state); images are saved with Pillow
(PNG, animated GIF)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image

from fluidswarm.recording import schemas as sc
from fluidswarm.recording.preload import preload
from fluidswarm.recording.reader import Frame, Recording, Scene, Target

# matplotlib (~0.45 s of CPU to import) and the analysis (scipy.spatial, ~0.3 s) are imported where a picture is
# drawn, not with the module: every `fluidswarm` command imports this one (imitate, simulate, replay register
# their subcommands), and most never draw.
if TYPE_CHECKING:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.image import AxesImage

    from fluidswarm.recording.analysis import Series

FORMATION_SIZE = (700, 500)  # width, height in pixels
SNAPSHOT_SIZE = (640, 640)
GIF_SIZE = (480, 480)
PLOT_SIZE = (800, 500)
_DPI = 100


def domain_extent(run: Recording, margin: float = 0.05) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax): metadata `domain` if recorded, else what the particles and target span."""
    dom = run.metadata.get("domain")
    if isinstance(dom, (list, tuple)) and len(dom) == 4:
        xmin, xmax, ymin, ymax = (float(v) for v in dom)
        return xmin, xmax, ymin, ymax
    pts = [f.positions for f in run.frames if len(f.positions)]
    for tg in run.targets:
        rows, cols = tg.mask.shape
        pts.append(tg.transform.to_domain(np.array([[0, 0], [cols, rows]], dtype=float)))
    if not pts:
        return (0.0, 1.0, 0.0, 1.0)
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    half = max(float((hi - lo).max()) / 2 * (1 + margin), 1e-6)
    c = (lo + hi) / 2
    return (c[0] - half, c[0] + half, c[1] - half, c[1] + half)


def preload_figures() -> None:
    """Import matplotlib's figure, Agg canvas and patches on a thread of their own: started when a run's
    processes are being stopped (mostly waiting), the formation picture drawn after them (`plot_formation`)
    finds them loaded instead of spending ~0.3 s importing them then."""
    preload("matplotlib.backends.backend_agg", "matplotlib.figure", "matplotlib.patches")


def _figure(size: tuple[int, int]) -> tuple[Figure, FigureCanvasAgg]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
    return fig, FigureCanvasAgg(fig)


def _domain_axes(ax) -> None:
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def class_colours(class_ids) -> np.ndarray:
    """(N, 3) RGB in 0..1 of each class id, for matplotlib."""
    return sc.class_colour(class_ids) / 255.0


def plot_formation(
    path: str | Path,
    positions: np.ndarray,
    classes: np.ndarray,
    class_names=None,
    title: str = "",
    background: np.ndarray | None = None,
    extent=None,
    waypoints: np.ndarray | None = None,
    outline=(),
) -> Path:
    """Write a PNG of particles coloured by class, optionally over a background image (extent in metres),
    with the command's waypoints or the fill controller's shape (`outline`: rings of (x, y))."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, canvas = _figure(FORMATION_SIZE)
    ax = fig.add_subplot(1, 1, 1)
    if background is not None:
        ax.imshow(background, extent=extent, cmap="Greys", alpha=0.35, origin="upper")
    classes = np.asarray(classes)
    for k in np.unique(classes):
        sel = classes == k
        label = class_names[k] if class_names is not None and k < len(class_names) else f"class {k}"
        ax.scatter(positions[sel, 0], positions[sel, 1], s=14, color=class_colours([k])[0], label=label)
    for k, ring in enumerate(outline):
        closed = np.array(list(ring) + [ring[0]])
        ax.plot(closed[:, 0], closed[:, 1], color="black", lw=0.6, alpha=0.6, label="fill shape" if k == 0 else None)
    if waypoints is not None and len(waypoints):
        ax.scatter(waypoints[:, 0], waypoints[:, 1], marker="x", color="black", s=30, label="waypoints")
    _domain_axes(ax)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    canvas.print_png(str(path))
    return path


class FormationRenderer:
    """Draws frames of one run on one reused figure of `size` pixels; `render` returns an RGB array.

    The axes, ticks, labels and target silhouette are drawn once per target and kept as pixels; each frame
    restores them and draws only what moves (scene, particles, title): a full Agg draw per frame (ticks and
    text laid out again) took ~50 ms, most of the time of a scenario run's replay."""

    def __init__(self, run: Recording, size: tuple[int, int]):
        self.fig, self.canvas = _figure(size)
        self.ax = self.fig.add_axes((0.1, 0.08, 0.85, 0.85))
        xmin, xmax, ymin, ymax = domain_extent(run)
        self.ax.set_xlim(xmin, xmax)
        self.ax.set_ylim(ymin, ymax)
        _domain_axes(self.ax)
        self._target_img: AxesImage | None = None
        self._target: Target | None = None
        self._run = run
        self._scatter = self.ax.scatter([], [], s=12, zorder=3, animated=True)
        self._patches: list = []
        self._title = self.ax.set_title("")
        self._title.set_animated(True)
        self._background = None  # the static pixels for the current target (None: draw them again)

    def _set_target(self, tg: Target | None) -> None:
        if tg is self._target:
            return
        self._target = tg
        self._background = None
        if self._target_img is not None:
            self._target_img.remove()
            self._target_img = None
        if tg is not None:
            rows, cols = tg.mask.shape
            (x0, y1), (x1, y0) = tg.transform.to_domain(np.array([[0, 0], [cols, rows]], dtype=float))
            self._target_img = self.ax.imshow(
                np.where(tg.mask, 0.3, np.nan),
                cmap="Greys",
                vmin=0,
                vmax=1,
                extent=(x0, x1, y0, y1),
                origin="upper",
                interpolation="nearest",
                zorder=1,
            )

    def _set_scene(self, scene: Scene | None) -> None:
        from matplotlib.patches import Circle, Ellipse

        for p in self._patches:
            p.remove()
        self._patches = []
        if scene is None:
            return
        for x, y, r in scene.waypoints:
            self._patches.append(
                self.ax.add_patch(
                    Circle(
                        (x, y), r, facecolor=(0, 0, 0, 0.08), edgecolor=(0, 0, 0, 0.6), lw=0.8, zorder=2, animated=True
                    )
                )
            )
        for x, y, major, minor, angle in scene.ellipses:
            self._patches.append(
                self.ax.add_patch(
                    Ellipse(
                        (x, y),
                        major,
                        minor,
                        angle=angle,
                        fill=False,
                        edgecolor="tab:red",
                        lw=1.2,
                        zorder=2,
                        animated=True,
                    )
                )
            )

    def render(self, frame: Frame) -> np.ndarray:
        shown = [tg for tg in self._run.targets if tg.t <= frame.t]
        self._set_target(shown[-1] if shown else None)
        if self._background is None:
            self.canvas.draw()  # animated artists are left out of a full draw
            self._background = self.canvas.copy_from_bbox(self.fig.bbox)
        else:
            self.canvas.restore_region(self._background)
        self._set_scene(self._run.scene_at(frame.t))
        self._scatter.set_offsets(frame.positions if len(frame.positions) else np.empty((0, 2)))
        # matplotlib's stubs take a sequence of colours, not the (N, 4) array the method takes too
        self._scatter.set_facecolor(class_colours(frame.class_ids) if len(frame.class_ids) else [])  # type: ignore[arg-type]
        self._scatter.set_edgecolor("none")
        self._title.set_text(f"{self._run.name}  step {frame.step}  t = {frame.t:.2f} s  N = {len(frame.ids)}")
        for artist in (*self._patches, self._scatter, self._title):  # in zorder, as a full draw would
            self.ax.draw_artist(artist)
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()


def save_png(rgb: np.ndarray, path: Path) -> Path:
    Image.fromarray(rgb).save(path, format="PNG")
    return path


def save_gif(frames: list[np.ndarray], path: Path, fps: float) -> Path:
    """Animated GIF; all frames share the first frame's adaptive palette (fast, no flicker)."""
    first = Image.fromarray(frames[0]).quantize(colors=128, method=Image.Quantize.MEDIANCUT)
    rest = [Image.fromarray(f).quantize(palette=first, dither=Image.Dither.NONE) for f in frames[1:]]
    first.save(path, format="GIF", save_all=True, append_images=rest, duration=int(round(1000 / fps)), loop=0)
    return path


def _plot(path: Path, title: str, ylabel: str, lines: list[tuple[np.ndarray, np.ndarray, str, object]]) -> Path:
    fig, canvas = _figure(PLOT_SIZE)
    ax = fig.add_subplot(1, 1, 1)
    for x, y, label, colour in lines:
        ax.plot(x, y, label=label, color=colour, lw=1.5)
    ax.set_title(title)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    if len(lines) > 1:
        ax.legend(loc="best")
    fig.tight_layout()
    canvas.print_png(str(path))
    return path


def plot_series(s: Series, out: Path) -> dict[str, Path]:
    """The three analysis plots; returns {"speed": path, "pressure": path, "distance": path}."""
    speed_lines = [(s.t, v, f"class {c}", class_colours([c])[0]) for c, v in s.speed_by_class.items()]
    return {
        "speed": _plot(out / "speed_by_class.png", "Average speed per class", "mean |v| [m/s]", speed_lines),
        "pressure": _plot(
            out / "pressure.png", "Average pressure", "mean p", [(s.t, s.pressure, "pressure", "tab:purple")]
        ),
        "distance": _plot(
            out / "distance.png",
            "Average inter-particle distance",
            "distance [m]",
            [
                (s.t, s.nn_distance, "nearest neighbour (mean)", "tab:blue"),
                (s.t, s.pair_distance, "all pairs (mean)", "tab:orange"),
            ],
        ),
    }
