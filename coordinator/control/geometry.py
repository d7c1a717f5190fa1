"""The one transform between image pixels and the simulation domain.

The controller that turns a picture into waypoints and the fidelity score that judges the formation must
use the same mapping, so it lives here once. Image rows grow downwards, domain y grows upwards.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ImageToDomain:
    """Affine map pixel (u = column, v = row) -> domain (x, y) in metres.

    x = x0 + scale * u ;  y = y0 - scale * v   (so row 0 is the top of the picture).
    """

    scale: float  # metres per pixel
    x0: float  # domain x of pixel column 0
    y0: float  # domain y of pixel row 0

    @classmethod
    def fit(
        cls, image_shape: tuple[int, int], domain: tuple[float, float, float, float], margin: float = 0.05
    ) -> ImageToDomain:
        """Fit an image of shape (rows, cols) centred into domain (xmin, xmax, ymin, ymax), keeping aspect."""
        rows, cols = image_shape[:2]
        xmin, xmax, ymin, ymax = domain
        w, hgt = (xmax - xmin) * (1 - 2 * margin), (ymax - ymin) * (1 - 2 * margin)
        scale = min(w / cols, hgt / rows)
        cx, cy = (xmin + xmax) / 2, (ymin + ymax) / 2
        return cls(scale=scale, x0=cx - scale * cols / 2, y0=cy + scale * rows / 2)

    def to_domain(self, uv: np.ndarray) -> np.ndarray:
        uv = np.asarray(uv, dtype=float)
        return np.stack([self.x0 + self.scale * uv[..., 0], self.y0 - self.scale * uv[..., 1]], axis=-1)

    def to_pixels(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=float)
        return np.stack([(xy[..., 0] - self.x0) / self.scale, (self.y0 - xy[..., 1]) / self.scale], axis=-1)

    def as_dict(self) -> dict:
        return {"scale": self.scale, "x0": self.x0, "y0": self.y0}
