"""Eigen-image hand classifier (thesis ch. 4), the thesis baseline and a better PCA pipeline.

Thesis §4.3-4.4, method ``"baseline"``: every training image becomes a column of S (here: a row), grey
levels normalised; the mean image psi is subtracted (phi_i = img_i - psi); the eigenvectors u_k of the
covariance C = (1/M) sum phi phi^T are found by the snapshot method (eigenvectors v of the M x M matrix
A^T A give u = A v / |A v|, §4.3), the K with the largest eigenvalues are kept; an image's weights are
omega_k = u_k^T (Gamma - psi); the label is that of the training image with the smallest Euclidean distance
between weight vectors (eq. epsilon_k = |Omega - Omega_k|).

Method ``"best"`` keeps the same eigen-image core but feeds it better vectors and a better decision:
segment the hand, crop a square around it (position and scale invariance), HOG of the grey crop and of
the silhouette crop (`perception.features.hand_hog`); PCA (snapshot) to K components; Fisher's linear
discriminant (LDA) on the PCA weights to at most C - 1 dimensions; the 5 nearest training images in that
space vote. Cross-validated figures are in docs/perception.md.

A trained classifier saves to / loads from one ``.npz`` (no pickles).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.linalg import eigh
from threadpoolctl import threadpool_limits

from perception import features
from perception.dataset import load_folder, shared_hands_root
from perception.io import InputError

METHODS = ("baseline", "best")
DEFAULT_COMPONENTS = {"baseline": 35, "best": 100}  # thesis: best rate from 35 components on
DEFAULT_NEIGHBOURS = {"baseline": 1, "best": 5}
FORMAT_VERSION = 1
MODEL_PATH = Path(__file__).resolve().parent / "data" / "eigen_best.npz"


def pca_snapshot(x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean psi (D,), eigen-images U (D, K), eigenvalues (K,)) of the rows of x, largest first.

    Uses the M x M snapshot matrix when there are fewer images than pixels (thesis §4.3), else the D x D
    covariance. Directions with a (numerically) zero eigenvalue are dropped, so K may come out smaller.
    """
    x = np.asarray(x, np.float64)
    m, d = x.shape
    psi = x.mean(axis=0)
    a = x - psi
    if m <= d:
        lam, v = eigh(a @ a.T / m)
        order = np.argsort(lam)[::-1]
        lam, v = lam[order], v[:, order]
        keep = lam > lam[0] * 1e-10 if lam[0] > 0 else np.zeros_like(lam, bool)
        lam, v = lam[keep][:k], v[:, keep][:, :k]
        u = a.T @ v
        u /= np.linalg.norm(u, axis=0, keepdims=True)
    else:
        lam, u = eigh(a.T @ a / m)
        order = np.argsort(lam)[::-1][:k]
        lam, u = lam[order], u[:, order]
    return psi, u, lam


def fisher_lda(w: np.ndarray, y: np.ndarray, reg: float = 1e-3) -> np.ndarray:
    """Fisher's discriminant directions (K, C-1) of weights w (M, K) with labels y.

    Maximises between-class over within-class scatter: generalized eigenproblem S_b v = lambda S_w v, with
    S_w shrunk by reg * mean eigenvalue so it stays invertible.
    """
    classes = np.unique(y)
    mu = w.mean(axis=0)
    k = w.shape[1]
    sw = np.zeros((k, k))
    sb = np.zeros((k, k))
    for c in classes:
        wc = w[y == c]
        mc = wc.mean(axis=0)
        dc = wc - mc
        sw += dc.T @ dc
        sb += len(wc) * np.outer(mc - mu, mc - mu)
    sw += np.eye(k) * reg * np.trace(sw) / k
    lam, v = eigh(sb, sw)
    order = np.argsort(lam)[::-1][: max(1, min(len(classes) - 1, k))]
    return v[:, order]


@dataclass
class EigenClassifier:
    """Eigen-image classifier. ``method``: "baseline" (thesis plain pixels, 1-NN) or "best".

    fit(images, labels) -> self; predict(images) -> labels; predict_proba-like `predict_confidence`;
    save(path) / EigenClassifier.load(path). Images are BGR uint8 arrays of any size.
    """

    method: str = "best"
    n_components: int | None = None
    n_neighbours: int | None = None
    # trained state
    psi: np.ndarray | None = field(default=None, repr=False)
    eigenimages: np.ndarray | None = field(default=None, repr=False)
    eigenvalues: np.ndarray | None = field(default=None, repr=False)
    projection: np.ndarray | None = field(default=None, repr=False)  # LDA directions (best) or identity
    train_weights: np.ndarray | None = field(default=None, repr=False)
    train_labels: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if self.n_components is None:
            self.n_components = DEFAULT_COMPONENTS[self.method]
        if self.n_neighbours is None:
            self.n_neighbours = DEFAULT_NEIGHBOURS[self.method]
        if self.n_components < 1 or self.n_neighbours < 1:
            raise ValueError("n_components and n_neighbours must be >= 1")

    # -- features -------------------------------------------------------------------------------------
    def features(self, images: list[np.ndarray]) -> np.ndarray:
        """The vectors this method feeds to PCA: normalised pixels or hand HOG."""
        if len(images) == 0:
            raise ValueError("no images")
        return features.pixels(images) if self.method == "baseline" else features.hand_hog(images)

    # -- training -------------------------------------------------------------------------------------
    def default_components(self) -> int:
        return DEFAULT_COMPONENTS[self.method]

    def fit(self, images: list[np.ndarray] | None, labels, features: np.ndarray | None = None) -> "EigenClassifier":
        """Train on images (or on their precomputed `features(images)`) with one label each."""
        return self.fit_features(self.features(images) if features is None else features, labels)

    def fit_features(self, x: np.ndarray, labels) -> "EigenClassifier":
        # One BLAS thread: for these small matrices on 2 shared cores, threaded BLAS only adds overhead.
        with threadpool_limits(1):
            return self._fit_features(x, labels)

    def _fit_features(self, x: np.ndarray, labels) -> "EigenClassifier":
        y = np.asarray(labels)
        if len(x) != len(y) or len(y) < 2:
            raise ValueError(f"need >= 2 images with one label each (got {len(x)} images, {len(y)} labels)")
        self.psi, self.eigenimages, self.eigenvalues = pca_snapshot(x, self.n_components)
        w = (x - self.psi) @ self.eigenimages
        if self.method == "best" and len(np.unique(y)) > 1:
            self.projection = fisher_lda(w, y)
        else:
            self.projection = np.eye(w.shape[1])
        self.train_weights = (w @ self.projection).astype(np.float32)
        self.train_labels = y
        return self

    # -- inference ------------------------------------------------------------------------------------
    def weights(self, x: np.ndarray) -> np.ndarray:
        """Omega: the weights of feature vectors x (N, D) in the decision space."""
        if self.psi is None:
            raise ValueError("the classifier is not trained")
        return ((np.asarray(x, np.float64) - self.psi) @ self.eigenimages) @ self.projection

    def predict_features(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(labels, confidence in 0..1 = share of the k nearest training images that voted for it)."""
        with threadpool_limits(1):
            return self._predict_features(x)

    def _predict_features(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        omega = self.weights(x)
        tw = self.train_weights.astype(np.float64)
        d2 = (omega ** 2).sum(1)[:, None] - 2 * omega @ tw.T + (tw ** 2).sum(1)[None, :]
        k = min(self.n_neighbours, len(tw))
        nearest = np.argsort(d2, axis=1)[:, :k]
        classes = np.unique(self.train_labels)
        labels, conf = [], []
        for row, idx in zip(d2, nearest):
            votes = np.array([np.sum(self.train_labels[idx] == c) for c in classes], float)
            # ties: the class with the smaller summed distance among its voters wins
            dist = np.array([row[idx][self.train_labels[idx] == c].sum() if votes[i] else np.inf
                             for i, c in enumerate(classes)])
            best = np.lexsort((dist, -votes))[0]
            labels.append(classes[best])
            conf.append(votes[best] / k)
        return np.array(labels), np.array(conf)

    def predict(self, images: list[np.ndarray] | None = None, features: np.ndarray | None = None) -> np.ndarray:
        """Labels of images (or of their precomputed `features(images)`)."""
        return self.predict_features(self.features(images) if features is None else features)[0]

    def predict_confidence(self, images: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        return self.predict_features(self.features(images))

    # -- persistence ----------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        if self.psi is None:
            raise ValueError("the classifier is not trained")
        np.savez_compressed(
            path, version=np.int64(FORMAT_VERSION), method=np.str_(self.method),
            n_components=np.int64(self.n_components), n_neighbours=np.int64(self.n_neighbours),
            psi=self.psi.astype(np.float32), eigenimages=self.eigenimages.astype(np.float32),
            eigenvalues=self.eigenvalues, projection=self.projection, train_weights=self.train_weights,
            train_labels=self.train_labels)

    @classmethod
    def load(cls, path: str | Path) -> "EigenClassifier":
        path = Path(path)
        if not path.is_file():
            raise InputError(f"{path}: no such model file")
        try:
            with np.load(path, allow_pickle=False) as z:
                if int(z["version"]) != FORMAT_VERSION:
                    raise InputError(f"{path}: model format {int(z['version'])}, expected {FORMAT_VERSION}")
                clf = cls(method=str(z["method"]), n_components=int(z["n_components"]),
                          n_neighbours=int(z["n_neighbours"]))
                clf.psi = z["psi"].astype(np.float64)
                clf.eigenimages = z["eigenimages"].astype(np.float64)
                clf.eigenvalues = z["eigenvalues"]
                clf.projection = z["projection"]
                clf.train_weights = z["train_weights"]
                clf.train_labels = z["train_labels"]
        except (OSError, KeyError, ValueError) as exc:
            raise InputError(f"{path}: not an eigen classifier model ({exc})") from None
        return clf


def train_default(method: str = "best", verbose: bool = False) -> EigenClassifier:
    """Train on the whole shared hand set (../shared/datasets/sign-language-digits), labelled by class
    name as the shipped model is."""
    images, labels, names, _files = load_folder(shared_hands_root())
    t = time.perf_counter()
    clf = EigenClassifier(method=method).fit(images, np.array(names)[labels])
    if verbose:
        print(f"trained {method} on {len(images)} images in {time.perf_counter() - t:.2f} s")
    return clf


def default_model() -> EigenClassifier:
    """The shipped model (perception/data/eigen_best.npz), else one trained now from the shared set."""
    if MODEL_PATH.is_file():
        return EigenClassifier.load(MODEL_PATH)
    return train_default("best")
