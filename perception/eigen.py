"""Eigen-image classification (thesis ch. 4) and our better PCA-based pipeline.

baseline (the thesis): grey pixels normalised to zero mean / unit norm, mean image, eigenvectors of the
covariance by an SVD of the centred data (equivalent to the snapshot M x M method), projection weights,
nearest neighbour by Euclidean distance.

best: segment the hand, crop and scale its bounding box to a square, histogram-of-oriented-gradient
features (our numpy implementation; OpenCV 5 drops HOG), PCA on those, LDA on the PCA weights, nearest
class mean in LDA space is replaced by an RBF-SVM (scikit-learn) on the LDA weights.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import cv2
import numpy as np

BASE_SIZE = 50
CROP_SIZE = 64


def baseline_features(img: np.ndarray) -> np.ndarray:
    g = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img
    v = cv2.resize(g, (BASE_SIZE, BASE_SIZE), interpolation=cv2.INTER_AREA).astype(np.float64).ravel()
    v -= v.mean()
    n = np.linalg.norm(v)
    return v / n if n > 0 else v


def hog(gray: np.ndarray, cell: int = 8, bins: int = 9) -> np.ndarray:
    """Histogram of oriented gradients: unsigned orientation, `bins` per cell, 2x2-cell blocks L2-normed."""
    g = gray.astype(np.float32)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=1)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=1)
    mag, ang = cv2.cartToPolar(gx, gy, angleInDegrees=True)
    ang = np.mod(ang, 180.0)
    b = np.minimum((ang / (180.0 / bins)).astype(int), bins - 1)
    h, w = g.shape
    cy, cx = h // cell, w // cell
    rows = (np.arange(h) // cell)[:, None].repeat(w, 1)
    cols = (np.arange(w) // cell)[None, :].repeat(h, 0)
    ok = (rows < cy) & (cols < cx)
    flat = (rows[ok] * cx + cols[ok]) * bins + b[ok]
    hist = np.bincount(flat, weights=mag[ok], minlength=cy * cx * bins).reshape(cy, cx, bins)
    blocks = []
    for i in range(cy - 1):
        for j in range(cx - 1):
            v = hist[i:i + 2, j:j + 2].ravel()
            blocks.append(v / (np.linalg.norm(v) + 1e-6))
    return np.concatenate(blocks)


def best_features(img: np.ndarray) -> np.ndarray:
    from perception.segmentation import SegmentationError, hand_mask

    gray = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    try:
        mask = hand_mask(img)
        ys, xs = np.nonzero(mask)
        y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
        side = max(y1 - y0, x1 - x0)
        cy, cx = (y0 + y1) // 2, (x0 + x1) // 2
        half = side // 2 + 2
        pad = cv2.copyMakeBorder(gray, half, half, half, half, cv2.BORDER_REPLICATE)
        crop = pad[cy:cy + 2 * half, cx:cx + 2 * half]
    except SegmentationError:
        crop = gray
    crop = cv2.resize(crop, (CROP_SIZE, CROP_SIZE), interpolation=cv2.INTER_AREA)
    crop = cv2.equalizeHist(crop)
    small = cv2.resize(gray, (32, 32), interpolation=cv2.INTER_AREA)
    return np.concatenate([hog(crop), 0.5 * hog(small, cell=4)])


@dataclass
class EigenClassifier:
    method: str = "best"  # "baseline" | "best"
    components: int | None = None

    def default_components(self) -> int:
        return 50 if self.method == "baseline" else 100

    def features(self, images) -> np.ndarray:
        f = baseline_features if self.method == "baseline" else best_features
        return np.array([f(im) for im in images])

    def fit(self, images, labels, features: np.ndarray | None = None) -> "EigenClassifier":
        X = self.features(images) if features is None else features
        y = np.asarray(labels)
        k = min(self.components or self.default_components(), X.shape[0] - 1, X.shape[1])
        self.mean_ = X.mean(axis=0)
        # Snapshot method (thesis §4.3): eigenvectors of the small M x M matrix A A^T give those of the
        # covariance A^T A as A^T u / |A^T u|, for M images of D features with M < D.
        A = X - self.mean_
        if A.shape[0] < A.shape[1]:
            vals, vecs = np.linalg.eigh(A @ A.T)
            order = np.argsort(vals)[::-1][:k]
            E = (A.T @ vecs[:, order]).T
            self.eigen_ = E / np.linalg.norm(E, axis=1, keepdims=True)
        else:
            self.eigen_ = np.linalg.svd(A, full_matrices=False)[2][:k]
        W = (X - self.mean_) @ self.eigen_.T
        self.labels_ = y
        if self.method == "baseline":
            self.weights_ = W
        else:
            from sklearn.discriminant_analysis import LinearDiscriminantAnalysis
            from sklearn.svm import SVC

            self.lda_ = LinearDiscriminantAnalysis().fit(W, y)
            self.svm_ = SVC(kernel="rbf", C=10.0, gamma="scale").fit(self.lda_.transform(W), y)
        return self

    def predict(self, images=None, features: np.ndarray | None = None) -> np.ndarray:
        X = self.features(images) if features is None else features
        W = (X - self.mean_) @ self.eigen_.T
        if self.method == "baseline":
            d = ((W[:, None, :] - self.weights_[None, :, :]) ** 2).sum(axis=2)
            return self.labels_[np.argmin(d, axis=1)]
        return self.svm_.predict(self.lda_.transform(W))

    def save(self, path) -> None:
        import pickle

        np.savez(path, method=self.method, mean=self.mean_, eigen=self.eigen_, labels=self.labels_,
                 weights=getattr(self, "weights_", np.empty(0)),
                 models=np.frombuffer(pickle.dumps((getattr(self, "lda_", None), getattr(self, "svm_", None))), dtype=np.uint8))

    @classmethod
    def load(cls, path) -> "EigenClassifier":
        import pickle

        with np.load(path, allow_pickle=False) as z:
            c = cls(method=str(z["method"]))
            c.mean_, c.eigen_, c.labels_, c.weights_ = z["mean"], z["eigen"], z["labels"], z["weights"]
            c.lda_, c.svm_ = pickle.loads(z["models"].tobytes())
        return c
