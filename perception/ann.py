"""The supervisor network of thesis §3.1: feature vector (6) -> 5 hidden nodes -> body-force command.

A feed-forward network with one hidden layer of 5 tanh nodes and a linear output layer, in numpy,
trained by L-BFGS (scipy) on the mean squared error with a small weight decay.

Outputs (our reading of §3.4, where the thesis prints body-force vectors [F_x, F_y]): ``F_along`` is the
body force along the hand's pointing direction, ``F_split`` the lateral force that divides the swarm
into two branches (0 for a single finger). The training pairs live in ``perception/data/ann_training.json``
(each with its source); the trained weights ship as ``perception/data/gesture_ann.npz``. Regenerate
both with ``python -m perception.ann`` (deterministic).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from perception.io import InputError
from perception.skeleton import feature_vector

DATA = Path(__file__).resolve().parent / "data"
TRAINING_PATH = DATA / "ann_training.json"
WEIGHTS_PATH = DATA / "gesture_ann.npz"
N_IN, N_HIDDEN = 6, 5
OUTPUTS = ("F_along", "F_split")


@dataclass
class GestureANN:
    """6 -> 5 (tanh) -> len(OUTPUTS) (linear). Inputs are scaled by x_scale before the hidden layer."""

    w1: np.ndarray  # (6, 5)
    b1: np.ndarray  # (5,)
    w2: np.ndarray  # (5, n_out)
    b2: np.ndarray  # (n_out,)
    x_scale: np.ndarray  # (6,)

    @classmethod
    def initial(cls, n_out: int = len(OUTPUTS), seed: int = 0) -> GestureANN:
        rng = np.random.default_rng(seed)
        return cls(
            rng.normal(0, 0.5, (N_IN, N_HIDDEN)),
            np.zeros(N_HIDDEN),
            rng.normal(0, 0.5, (N_HIDDEN, n_out)),
            np.zeros(n_out),
            np.ones(N_IN),
        )

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Body-force command(s) for feature vector(s) x: (6,) -> (n_out,), (N, 6) -> (N, n_out)."""
        x = np.asarray(x, float)
        if x.shape[-1] != N_IN:
            raise ValueError(f"feature vectors have {N_IN} entries, got shape {x.shape}")
        h = np.tanh((x / self.x_scale) @ self.w1 + self.b1)
        return h @ self.w2 + self.b2

    # -- training ------------------------------------------------------------------------------------
    def _pack(self) -> np.ndarray:
        return np.concatenate([self.w1.ravel(), self.b1, self.w2.ravel(), self.b2])

    def _unpack(self, p: np.ndarray) -> None:
        n_out = self.b2.size
        i = 0
        for name, shape in (("w1", (N_IN, N_HIDDEN)), ("b1", (N_HIDDEN,)), ("w2", (N_HIDDEN, n_out)), ("b2", (n_out,))):
            size = int(np.prod(shape))
            setattr(self, name, p[i : i + size].reshape(shape).copy())
            i += size

    def fit(self, x: np.ndarray, y: np.ndarray, decay: float = 1e-4, restarts: int = 5) -> float:
        """Train on pairs (x (N, 6), y (N, n_out)); keeps the best of a few seeded restarts. Returns the MSE."""
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        self.x_scale = np.maximum(np.abs(x).max(axis=0), 1e-6)
        xs = x / self.x_scale
        n = len(x)

        def loss(p):
            self._unpack(p)
            z = xs @ self.w1 + self.b1
            h = np.tanh(z)
            err = h @ self.w2 + self.b2 - y
            g_out = 2 * err / (n * y.shape[1])
            gw2 = h.T @ g_out + 2 * decay * self.w2
            gb2 = g_out.sum(0)
            gh = g_out @ self.w2.T * (1 - h**2)
            gw1 = xs.T @ gh + 2 * decay * self.w1
            gb1 = gh.sum(0)
            val = float((err**2).mean() + decay * ((self.w1**2).sum() + (self.w2**2).sum()))
            return val, np.concatenate([gw1.ravel(), gb1, gw2.ravel(), gb2])

        best = None
        for seed in range(restarts):
            start = GestureANN.initial(y.shape[1], seed)._pack()
            res = minimize(loss, start, jac=True, method="L-BFGS-B", options={"maxiter": 3000})
            if best is None or res.fun < best.fun:
                best = res
        assert best is not None  # restarts >= 1
        self._unpack(best.x)
        return float(((self(x) - y) ** 2).mean())

    # -- persistence ---------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        np.savez(path, w1=self.w1, b1=self.b1, w2=self.w2, b2=self.b2, x_scale=self.x_scale, outputs=np.array(OUTPUTS))

    @classmethod
    def load(cls, path: str | Path = WEIGHTS_PATH) -> GestureANN:
        path = Path(path)
        if not path.is_file():
            raise InputError(f"{path}: no such network file")
        try:
            with np.load(path, allow_pickle=False) as z:
                net = cls(z["w1"], z["b1"], z["w2"], z["b2"], z["x_scale"])
        except (OSError, KeyError, ValueError) as exc:
            raise InputError(f"{path}: not a gesture network ({exc})") from None
        if net.w1.shape != (N_IN, N_HIDDEN) or net.w2.shape[0] != N_HIDDEN:
            raise InputError(f"{path}: network shape {net.w1.shape} -> {net.w2.shape}, expected 6 -> 5 -> k")
        return net


def load_training(path: str | Path = TRAINING_PATH) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """(inputs (N, 6), targets (N, 2), the pairs with their sources) of the shipped training set."""
    pairs = json.loads(Path(path).read_text())["pairs"]
    return (np.array([p["features"] for p in pairs], float), np.array([p["force"] for p in pairs], float), pairs)


# -- the training set ----------------------------------------------------------------------------------


def _target(fv: np.ndarray) -> list[float]:
    """Our body-force rule per template (documented in docs/perception.md, from thesis §3.4):
    line -> [2, 0] (§3.4.1: force along the finger, none across); U -> [1.5, 1.0 a]; V -> [1.0, 1.5 b]
    (§3.4.3: split into two branches, wider for a wider aperture); two curves (pinch, §3.4.4) ->
    [1.0, 0.8 ap]; line + one curve -> [1.2, 0.5 ap]; one curve alone -> [1.5, 0.3 ap]."""
    line, u, v, two, one, d = fv
    if u:
        return [1.5, 1.0 * d]
    if v:
        return [1.0, 1.5 * d]
    if two:
        return [1.0, 0.8 * d]
    if line and one:
        return [1.2, 0.5 * d]
    if one:
        return [1.5, 0.3 * d]
    return [2.0, 0.0]


def build_training_set() -> list[dict]:
    """Pairs from: the thesis' printed examples (§3.2, §3.4) and drawn template shapes (lines, Vs, Us and
    arcs of several sizes) whose feature vectors come from `perception.skeleton.feature_vector`."""
    import cv2

    pairs = []
    for fv, src in (
        ([1, 0, 0, 0, 0, 0], "thesis §3.4.1 horizontal pointing, fv [1 0 0 0 0 0], force [2 0]"),
        ([0, 0, 1, 0, 0, 0.5], "thesis §3.4.3 separation of fingers, fv [0 0 1 0 0 b], b = 0.5"),
        ([1, 0, 0, 0, 1, 0.3], "thesis §3.4.4 pinching, fv [1 0 0 0 1 ap], ap = 0.3"),
        ([0, 0, 0, 1, 1, 0.2], "thesis §3.2 Fig. 3.3a pinching fingers, fv [0 0 0 1 1 ap1], ap1 = 0.2"),
        ([0, 1, 0, 0, 0, 0.3], "thesis §3.2 Fig. 3.2b U shape, fv [0 1 0 0 0 a], a = 0.3"),
    ):
        pairs.append({"features": fv, "force": [round(v, 4) for v in _target(np.array(fv, float))], "source": src})
    n = 160
    for t in (8, 14):
        for ang in (0, 45, 90):
            im = np.zeros((n, n), np.uint8)
            d = np.array([np.cos(np.radians(ang)), -np.sin(np.radians(ang))]) * n * 0.38
            cv2.line(im, tuple((n // 2 - d).astype(int)), tuple((n // 2 + d).astype(int)), 1, t)
            pairs.append(_drawn(im, f"drawn line, thickness {t} px, {ang} deg", feature_vector))
        for opening in (30, 50, 70):
            im = np.zeros((n, n), np.uint8)
            apex = (n // 2, int(n * 0.85))
            for s in (-1, 1):
                a = np.radians(90 + s * opening / 2)
                cv2.line(im, apex, (int(apex[0] + 0.7 * n * np.cos(a)), int(apex[1] - 0.7 * n * np.sin(a))), 1, t)
            pairs.append(_drawn(im, f"drawn V, opening {opening} deg, thickness {t} px", feature_vector))
        for gap in (24, 40, 60):
            im = np.zeros((n, n), np.uint8)
            x0, x1, top, bot = n // 2 - gap // 2, n // 2 + gap // 2, int(n * 0.12), int(n * 0.7)
            cv2.line(im, (x0, top), (x0, bot), 1, t)
            cv2.line(im, (x1, top), (x1, bot), 1, t)
            cv2.ellipse(im, (n // 2, bot), (gap // 2, gap // 2), 0, 0, 180, 1, t)
            pairs.append(_drawn(im, f"drawn U, gap {gap} px, thickness {t} px", feature_vector))
        for span in (200, 260):
            im = np.zeros((n, n), np.uint8)
            cv2.ellipse(im, (n // 2, n // 2), (n // 3, n // 3), 0, 90 - span // 2, 90 + span // 2, 1, t)
            pairs.append(_drawn(im, f"drawn C (pinch) arc of {span} deg, thickness {t} px", feature_vector))
    return pairs


def _drawn(im: np.ndarray, source: str, feature_vector) -> dict:
    fv = feature_vector(im.astype(bool), hand=False)
    return {"features": [round(float(v), 4) for v in fv], "force": [round(v, 4) for v in _target(fv)], "source": source}


def train_shipped() -> tuple[GestureANN, float]:
    """Rebuild ann_training.json from the drawn templates and the thesis examples, train, save the weights."""
    DATA.mkdir(exist_ok=True)
    pairs = build_training_set()
    TRAINING_PATH.write_text(
        json.dumps(
            {
                "about": "I/O pairs of the gesture ANN (perception/ann.py): 6-entry skeleton feature vector -> "
                "body-force command [F_along, F_split]. 'source' says where each pair comes from; the force "
                "rule is perception.ann._target. Regenerate with: python -m perception.ann",
                "outputs": list(OUTPUTS),
                "pairs": pairs,
            },
            indent=1,
        )
        + "\n"
    )
    x, y, _ = load_training()
    net = GestureANN.initial()
    mse = net.fit(x, y)
    net.save(WEIGHTS_PATH)
    return net, mse


if __name__ == "__main__":
    _net, _mse = train_shipped()
    print(f"trained on {len(load_training()[0])} pairs, mse={_mse:.5f}, weights {WEIGHTS_PATH}")
