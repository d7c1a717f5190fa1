"""A synthetic run written with `RunWriter`, for tests, timing and trying `replay` without the swarm.

Particles start scattered and relax exponentially onto points spread evenly over a silhouette (a disc on
a bar); some may be killed mid-run (their last state precedes their `died` event). No physics here.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording.writer import RunWriter

DOMAIN = (0.0, 2.0, 0.0, 2.0)


def silhouette(shape: tuple[int, int] = (100, 100)) -> np.ndarray:
    """A disc on a bar, as a boolean image mask."""
    rows, cols = shape
    m = np.zeros(shape, np.uint8)
    cv2.circle(m, (cols // 2, rows * 3 // 10), max(1, min(rows, cols) // 5), 1, -1)
    cv2.rectangle(m, (cols // 5, rows // 2), (cols * 4 // 5, rows * 7 // 10), 1, -1)
    return m.astype(bool)


def spread_over(mask: np.ndarray, transform: ImageToDomain, n: int) -> np.ndarray:
    """About n domain points on a square lattice over the mask (cell area = area(mask) / n), exactly n."""
    area = float(mask.sum())
    a = np.sqrt(area / n)
    while True:
        u, v = np.meshgrid(np.arange(a / 2, mask.shape[1], a), np.arange(a / 2, mask.shape[0], a))
        uv = np.stack([u.ravel(), v.ravel()], axis=1)
        uv = uv[mask[uv[:, 1].astype(int), uv[:, 0].astype(int)]]
        if len(uv) >= n:
            return transform.to_domain(uv[np.linspace(0, len(uv) - 1, n).round().astype(int)])
        a *= 0.97


def write_synthetic_run(
    path: str | Path,
    *,
    steps: int = 50,
    n: int = 30,
    dt: float = 0.05,
    seed: int = 0,
    kill: dict[int, int] | None = None,
    classes: int = 3,
    scenario: str = "synthetic",
    stop_after: int | None = None,
) -> RunWriter:
    """Write `steps` steps of `n` particles to `path` and close it.

    `kill` maps agent id -> first step without a state. `stop_after` returns (closed) after that many
    steps, as an interrupted recorder would. Returns the (closed) writer.
    """
    kill = dict(kill or {})
    rng = np.random.default_rng(seed)
    mask = silhouette()
    tf = ImageToDomain.fit(mask.shape, DOMAIN)
    goal = spread_over(mask, tf, n)
    start = rng.uniform(0.2, 1.8, size=(n, 2))
    ids = np.arange(n)
    cls = ids % classes
    tau = max(dt, steps * dt / 5)
    meta = {
        "run": Path(path).stem,
        "scenario": scenario,
        "seed": seed,
        "domain": list(DOMAIN),
        "parameters": {"n": n, "dt": dt, "steps": steps},
        "agent_ids": ids.tolist(),
    }
    with RunWriter(path, meta) as w:
        w.write_target(0.0, mask, tf)
        for i in ids:
            w.write_event(0.0, "info", f"agent/{i}", "started", kind="started", agent=int(i), step=0)
        w.write_command(0.0, '{"gesture": "open_hand", "confidence": 0.9}')
        for step in range(steps):
            if stop_after is not None and step >= stop_after:
                break
            t = step * dt
            for agent, at in kill.items():
                if at == step:
                    w.write_event(t, "warning", f"agent/{agent}", "died", kind="died", agent=agent, step=step)
            decay = np.exp(-t / tau)
            pos = goal + (start - goal) * decay
            vel = -(start - goal) * decay / tau
            rho = 1000 + rng.normal(0, 5, n)
            p = 10 * (rho / 1000 - 1) + 50 * decay
            alive = np.array([kill.get(int(i), steps + 1) > step for i in ids])
            w.write_states(step, t, ids, pos, vel, rho, p, cls, alive=alive)
            if step % 10 == 0:
                waypoints = [(float(x), float(y), 0.1) for x, y in goal[:: max(1, n // 5)]]
                w.write_scene(t, waypoints=waypoints, ellipses=[(1.0, 1.2, 0.6, 0.3, 30.0)])
    return w
