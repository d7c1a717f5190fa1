"""Eigen-image hand classifier (thesis ch. 4), the thesis baseline and a better PCA pipeline.

Thesis §4.3-4.4, method ``"eigen"`` (the thesis baseline; ``"baseline"`` is the same): every training image
becomes a column of S (here: a row), grey
levels normalised; the mean image psi is subtracted (phi_i = img_i - psi); the eigenvectors u_k of the
covariance C = (1/M) sum phi phi^T are found by the snapshot method (eigenvectors v of the M x M matrix
A^T A give u = A v / |A v|, §4.3), the K with the largest eigenvalues are kept; an image's weights are
omega_k = u_k^T (Gamma - psi); the label is that of the training image with the smallest Euclidean distance
between weight vectors (eq. epsilon_k = |Omega - Omega_k|).

Method ``"best"`` keeps the same eigen-image core but feeds it better vectors and a better decision:
segment the hand, crop a 48 px square around it (position and scale invariance), HOG of the grey crop and
of the silhouette crop at cells 8 and 16 (`perception.features.hand_hog`); for training also each hand
turned by -8 and +8 degrees (features.TRAINING_ANGLES); PCA (randomized SVD) to 150 components; an RBF
SVM on those weights. Cross-validated figures are in docs/perception.md.

A trained classifier saves to / loads from one ``.npz`` (no pickles).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.linalg import eigh
from threadpoolctl import ThreadpoolController

from perception import features
from perception.dataset import load_folder, shared_hands_root
from perception.io import InputError

_blas: ThreadpoolController | None = None


def one_blas_thread():
    """threadpoolctl's threadpool_limits(1) without its cost per call: it finds the process's BLAS libraries
    each time (~0.9 ms, read from /proc; a room frame's classifier call is ~1 ms of work). Found once here, on
    first use: numpy's, scipy's and OpenCV's are all loaded by this module's imports by then."""
    global _blas
    if _blas is None:
        _blas = ThreadpoolController()
    return _blas.limit(limits=1)


METHODS = ("eigen", "best")
ALIASES = {"baseline": "eigen"}  # the eigen method's earlier name
DEFAULT_COMPONENTS = {"eigen": 35, "best": 150}  # thesis: best rate from 35 components on; best: 100-200 alike
DEFAULT_NEIGHBOURS = {"eigen": 1, "best": 1}
SVM_C = 10.0  # the SVM's penalty; 3..30 cross-validate alike (0.967-0.968 on one cell size)
# A picture farther than this from the hand space (relative residual |x - psi - U U^T (x - psi)| / |x|) is
# no hand. Trained on four fifths of the shared set (folds by file-name hash), the other fifth's hands lie at
# 0.11-0.27 (99.9th percentile 0.26). The Weizmann wave2 person of tests/test_camera_hand.py lies at 0.26-0.28
# (its first 12 frames; 0.26-0.33 before hand_mask grew pale parts back): this limit alone does not tell it
# from a hand, find_hand's skin and background checks do.
HAND_SPACE_LIMIT = 0.30
FORMAT_VERSION = 3  # 3: the SVM works on the PCA weights
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


def pca_randomized(x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """pca_snapshot's (psi, U, eigenvalues) by a randomized SVD (Halko et al. 2011, scikit-learn's; fixed
    seed): for thousands of vectors of thousands of numbers the exact eigen-decomposition costs seconds."""
    from sklearn.utils.extmath import randomized_svd

    x = np.asarray(x, np.float64)
    psi = x.mean(axis=0)
    k = min(k, *x.shape)
    # 2 power iterations, not scikit-learn's 7: 0.9 s less on the whole set; 5-fold cross-validation on the
    # documented split's training part alike (ten classes 0.979 vs 0.980, classes 0,1,2,4,5 0.998 both)
    _u, s, vt = randomized_svd(x - psi, k, n_iter=2, random_state=0)
    return psi, vt.T, s**2 / len(x)


@dataclass
class EigenClassifier:
    """Eigen-image classifier. ``method``: "eigen" (thesis plain pixels, 1-NN) or "best" (HOG, SVM).

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
    projection: np.ndarray | None = field(
        default=None, repr=False
    )  # identity (the eigen weights are the decision space)
    train_weights: np.ndarray | None = field(default=None, repr=False)
    train_labels: np.ndarray | None = field(default=None, repr=False)
    svm: dict | None = field(default=None, repr=False)  # best: support vectors, coefficients, gamma, classes

    def __post_init__(self) -> None:
        self.method = ALIASES.get(self.method, self.method)
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
        return features.pixels(images) if self.method == "eigen" else features.hand_hog(images)

    # -- training -------------------------------------------------------------------------------------
    def default_components(self) -> int:
        return DEFAULT_COMPONENTS[self.method]

    def training_features(self, images: list[np.ndarray]) -> np.ndarray:
        """The vectors training uses: `features`, and for "best" also each hand turned by the other
        features.TRAINING_ANGLES, angle-major ((len(angles) * N, D); labels repeat with np.tile)."""
        if self.method == "eigen":
            return self.features(images)
        return features.hand_hog(images, angles=features.TRAINING_ANGLES)

    def fit(self, images: list[np.ndarray] | None, labels, features: np.ndarray | None = None) -> EigenClassifier:
        """Train on images (or on their precomputed `training_features(images)`) with one label each."""
        x = self.training_features(images) if features is None else features
        y = np.asarray(labels)
        if len(y) and len(x) != len(y) and len(x) % len(y) == 0:
            y = np.tile(y, len(x) // len(y))  # the turned copies carry their image's label
        return self.fit_features(x, y)

    def fit_features(self, x: np.ndarray, labels) -> EigenClassifier:
        # One BLAS thread: for these small matrices on 2 shared cores, threaded BLAS only adds overhead.
        with one_blas_thread():
            return self._fit_features(x, labels)

    def _fit_features(self, x: np.ndarray, labels) -> EigenClassifier:
        y = np.asarray(labels)
        if len(x) != len(y) or len(y) < 2:
            raise ValueError(f"need >= 2 images with one label each (got {len(x)} images, {len(y)} labels)")
        if self.method == "best":
            self.psi, self.eigenimages, self.eigenvalues = pca_randomized(x, self.n_components)
        else:
            self.psi, self.eigenimages, self.eigenvalues = pca_snapshot(x, self.n_components)
        w = (x - self.psi) @ self.eigenimages
        self.projection = np.eye(w.shape[1])
        self.train_labels = y
        if self.method == "best":
            # the SVM decides in the PCA weights (150 numbers instead of ~2000: 5x faster, a smaller model)
            self.svm = fit_svm(w, y)
            self.train_weights = np.zeros((0, w.shape[1]), np.float32)  # not used by the SVM: not shipped
        else:
            self.svm = None
            self.train_weights = w.astype(np.float32)
        return self

    # -- inference ------------------------------------------------------------------------------------
    def weights(self, x: np.ndarray) -> np.ndarray:
        """Omega: the weights of feature vectors x (N, D) in the decision space."""
        if self.psi is None:
            raise ValueError("the classifier is not trained")
        return ((np.asarray(x, np.float64) - self.psi) @ self.eigenimages) @ self.projection

    def predict_features(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(labels, confidence in 0..1 = share of the k nearest training images that voted for it)."""
        with one_blas_thread():
            return self._predict_features(x)

    def _predict_features(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        omega = self.weights(x)
        if self.svm is not None:
            return svm_predict(self.svm, omega)
        tw = self.train_weights.astype(np.float64)
        d2 = (omega**2).sum(1)[:, None] - 2 * omega @ tw.T + (tw**2).sum(1)[None, :]
        k = min(self.n_neighbours, len(tw))
        nearest = np.argsort(d2, axis=1)[:, :k]
        classes = np.unique(self.train_labels)
        labels, conf = [], []
        for row, idx in zip(d2, nearest):
            votes = np.array([np.sum(self.train_labels[idx] == c) for c in classes], np.float64)
            # ties: the class with the smaller summed distance among its voters wins
            dist = np.array(
                [row[idx][self.train_labels[idx] == c].sum() if votes[i] else np.inf for i, c in enumerate(classes)]
            )
            best = np.lexsort((dist, -votes))[0]
            labels.append(classes[best])
            conf.append(votes[best] / k)
        return np.array(labels), np.array(conf)

    def predict(self, images: list[np.ndarray] | None = None, features: np.ndarray | None = None) -> np.ndarray:
        """Labels of images (or of their precomputed `features(images)`)."""
        return self.predict_features(self.features(images) if features is None else features)[0]

    def predict_confidence(self, images: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        return self.predict_features(self.features(images))

    def hand_space_distance(self, x: np.ndarray) -> np.ndarray:
        """Per feature vector (N, D): |x - psi - U U^T (x - psi)| / |x|, how far it lies from the space the
        training hands span (0: in it). Compare with HAND_SPACE_LIMIT ("best" features)."""
        if self.psi is None:
            raise ValueError("the classifier is not trained")
        a = np.asarray(x, np.float64) - self.psi
        residual = a - (a @ self.eigenimages) @ self.eigenimages.T
        return np.linalg.norm(residual, axis=1) / np.maximum(np.linalg.norm(x, axis=1), 1e-12)

    # -- persistence ----------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        if self.psi is None:
            raise ValueError("the classifier is not trained")
        np.savez_compressed(
            path,
            version=np.int64(FORMAT_VERSION),
            method=np.str_(self.method),
            n_components=np.int64(self.n_components),
            n_neighbours=np.int64(self.n_neighbours),
            psi=self.psi.astype(np.float32),
            eigenimages=self.eigenimages.astype(np.float32),
            eigenvalues=self.eigenvalues,
            projection=self.projection,
            train_weights=self.train_weights,
            train_labels=self.train_labels,
            **{f"svm_{k}": v for k, v in (self.svm or {}).items()},
        )

    @classmethod
    def load(cls, path: str | Path) -> EigenClassifier:
        path = Path(path)
        if not path.is_file():
            raise InputError(f"{path}: no such model file")
        try:
            with np.load(path, allow_pickle=False) as z:
                if int(z["version"]) != FORMAT_VERSION:
                    raise InputError(f"{path}: model format {int(z['version'])}, expected {FORMAT_VERSION}")
                clf = cls(
                    method=str(z["method"]), n_components=int(z["n_components"]), n_neighbours=int(z["n_neighbours"])
                )
                clf.psi = z["psi"].astype(np.float64)
                clf.eigenimages = z["eigenimages"].astype(np.float64)
                clf.eigenvalues = z["eigenvalues"]
                clf.projection = z["projection"]
                clf.train_weights = z["train_weights"]
                clf.train_labels = z["train_labels"]
                if clf.method == "best":
                    clf.svm = {k: z[f"svm_{k}"] for k in SVM_FIELDS}
        except (OSError, KeyError, ValueError) as exc:
            raise InputError(f"{path}: not an eigen classifier model ({exc})") from None
        return clf


SVM_FIELDS = ("classes", "support", "n_support", "dual_coef", "intercept", "gamma")


def fit_svm(x: np.ndarray, y: np.ndarray) -> dict:
    """An RBF SVM (scikit-learn SVC, gamma "scale" = 1 / (D var(x))) on the rows of x, as plain arrays."""
    from sklearn.svm import SVC

    m = SVC(C=SVM_C, kernel="rbf", gamma="scale").fit(np.asarray(x, np.float64), y)
    return {
        "classes": m.classes_,
        "support": m.support_vectors_.astype(np.float32),
        "n_support": m.n_support_.astype(np.int64),
        "dual_coef": m.dual_coef_,
        "intercept": m.intercept_,
        "gamma": np.float64(m._gamma),
    }


def svm_predict(svm: dict, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(labels, confidence = share of the one-vs-one duels the label won) of the rows of x, computed as
    libsvm does: for classes i < j, sum of dual_coef * K(sv, x) over both classes' support vectors +
    intercept; > 0 votes for i. Ties go to the lower class index (libsvm's argmax)."""
    sv = np.asarray(svm["support"], np.float64)
    x = np.asarray(x, np.float64)
    d2 = (x**2).sum(1)[:, None] - 2 * x @ sv.T + (sv**2).sum(1)[None, :]
    k = np.exp(-float(svm["gamma"]) * np.maximum(d2, 0.0))  # (N, n_sv)
    classes, n_sv, coef, b = svm["classes"], svm["n_support"], svm["dual_coef"], svm["intercept"]
    start = np.concatenate([[0], np.cumsum(n_sv)])
    c = len(classes)
    votes = np.zeros((len(x), c), np.int64)
    p = 0
    for i in range(c):
        for j in range(i + 1, c):
            si, sj = slice(start[i], start[i + 1]), slice(start[j], start[j + 1])
            dec = k[:, si] @ coef[j - 1, si] + k[:, sj] @ coef[i, sj] + b[p]
            votes[:, i] += dec > 0
            votes[:, j] += dec <= 0
            p += 1
    best = np.argmax(votes, axis=1)
    return classes[best], votes[np.arange(len(x)), best] / max(c - 1, 1)


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
