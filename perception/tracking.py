"""A person's bounding box over a clip's frames with a Kalman filter (thesis §5.2, step 4).

State (cx, cy, w, h, vx, vy, vw, vh): box centre and size in pixels with a constant-velocity model.
Each frame's detection (the box of the person's silhouette, `perception.segmentation.PersonRegions.bbox`)
is the measurement; a frame without a detection is bridged by the prediction. The filter smooths the
detector's noise, as the thesis' Simulink Kalman Filter block does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class BoxKalman:
    """Constant-velocity Kalman filter on (cx, cy, w, h). q: process noise, r: measurement noise (px^2)."""

    q: float = 0.5
    r: float = 4.0

    def __post_init__(self) -> None:
        self.F = np.eye(8)
        self.F[:4, 4:] = np.eye(4)
        self.H = np.hstack([np.eye(4), np.zeros((4, 4))])
        self.Q = np.eye(8) * self.q
        self.Q[4:, 4:] *= 0.5
        self.R = np.eye(4) * self.r
        self.x: np.ndarray | None = None
        self.P = np.eye(8) * 100.0

    def predict(self) -> np.ndarray | None:
        if self.x is None:
            return None
        self.x = self.F @ self.x
        self.P = self.F @ self.P @ self.F.T + self.Q
        return self.x[:4].copy()

    def update(self, z: np.ndarray) -> np.ndarray:
        z = np.asarray(z, float)
        if self.x is None:
            self.x = np.concatenate([z, np.zeros(4)])
            self.P = np.diag([self.r] * 4 + [25.0] * 4)
            return self.x[:4].copy()
        s = self.H @ self.P @ self.H.T + self.R
        k = self.P @ self.H.T @ np.linalg.inv(s)
        self.x = self.x + k @ (z - self.H @ self.x)
        self.P = (np.eye(8) - k @ self.H) @ self.P
        return self.x[:4].copy()


def box_to_centre(box) -> np.ndarray:
    x, y, w, h = box
    return np.array([x + w / 2.0, y + h / 2.0, float(w), float(h)])


def centre_to_box(c) -> tuple[float, float, float, float]:
    cx, cy, w, h = c
    return (float(cx - w / 2.0), float(cy - h / 2.0), float(w), float(h))


def track_boxes(detections: list, q: float = 0.5, r: float = 4.0) -> list[tuple[float, float, float, float] | None]:
    """Filtered (x, y, w, h) per frame from per-frame detections (x, y, w, h) or None (missed)."""
    kf = BoxKalman(q=q, r=r)
    out: list[tuple[float, float, float, float] | None] = []
    for det in detections:
        pred = kf.predict()
        if det is not None:
            out.append(centre_to_box(kf.update(box_to_centre(det))))
        else:
            out.append(centre_to_box(pred) if pred is not None else None)
    return out
