"""The digit a hand shows, read from its 21 landmarks (perception/landmarks.py): the learned reading's second
opinion beside the silhouette's classifier (perception/hand_detector.py).

Features: the landmarks with the wrist at the origin, turned so the wrist -> middle knuckle points up,
scaled by that length (42 numbers), and the ten distances between the five fingertips (a thumb touching a
finger is what tells 6-9 apart). Classifier: the 5 nearest training hands vote (numpy; the training set is
an .npz, no pickle). Training set `perception/data/hand_landmarks.npz`: the landmarks of every shared
photograph (../shared/datasets/sign-language-digits, 1449), each read on a 640 x 480 grey frame at 240 px
(MediaPipe misses some 100-px photographs), with its class and file name (the benchmark keeps to the
documented split's training part). Regenerate with `.venv/bin/python -m perception.hand_pose`.

On the documented split (trained on its training photographs, tested on the others; 1448 of the 1449 have
landmarks, read by LiteRT): 0.990 ten classes (395 of 399), 1.000 classes 0,1,2,4,5 (202) (the silhouette
HOG classifier: 0.990 and 0.9951). On 119 hands found in cluttered composites (OpenCV's landmarks): 104
right, the silhouette classifier 103; where both agree (100), 97 right.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent / "data" / "hand_landmarks.npz"
TIPS = (4, 8, 12, 16, 20)
NEIGHBOURS = 5


def pose_features(points: np.ndarray) -> np.ndarray:
    """(n, 21, 2) or (21, 2) landmarks -> (n, 52) features (see the module docstring)."""
    p = np.asarray(points, np.float64).reshape(-1, 21, 2)
    p = p - p[:, :1]
    v = p[:, 9]
    length = np.maximum(np.linalg.norm(v, axis=1), 1e-6)[:, None, None]
    ang = np.arctan2(v[:, 0], -v[:, 1])  # the wrist -> middle knuckle direction's angle from 'up'
    c, s = np.cos(-ang)[:, None], np.sin(-ang)[:, None]
    q = np.stack([p[..., 0] * c - p[..., 1] * s, p[..., 0] * s + p[..., 1] * c], -1) / length
    tips = q[:, list(TIPS)]
    d = np.linalg.norm(tips[:, :, None] - tips[:, None], axis=-1)
    iu = np.triu_indices(len(TIPS), 1)
    return np.concatenate([q.reshape(len(q), -1), d[:, iu[0], iu[1]]], 1)


@dataclass(frozen=True)
class PoseClassifier:
    features: np.ndarray  # (n, 52)
    labels: np.ndarray  # (n,) str

    def predict(self, points: np.ndarray) -> tuple[str, float]:
        """(class, share of the NEIGHBOURS nearest training hands that voted for it)."""
        x = pose_features(points)[0]
        near = np.argsort(np.linalg.norm(self.features - x, axis=1))[:NEIGHBOURS]
        names, votes = np.unique(self.labels[near], return_counts=True)
        best = int(np.argmax(votes))
        return str(names[best]), float(votes[best] / len(near))

    def only(self, classes) -> PoseClassifier:
        keep = np.isin(self.labels, list(classes))
        return PoseClassifier(self.features[keep], self.labels[keep])


def load_poses(path: Path = DATA) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points (n, 21, 2), labels, file names) of the shipped training set."""
    with np.load(path) as d:
        return d["points"], d["labels"].astype(str), d["files"].astype(str)


def pose_classifier(classes=None, files=None, path: Path = DATA) -> PoseClassifier:
    """The shipped training set's classifier, kept to `classes` and to the photographs for which
    `files(name)` is true (both default: all)."""
    points, labels, names = load_poses(path)
    keep = np.ones(len(labels), bool)
    if classes is not None:
        keep &= np.isin(labels, [str(c) for c in classes])
    if files is not None:
        keep &= np.array([bool(files(n)) for n in names])
    return PoseClassifier(pose_features(points[keep]), labels[keep])


def _build(out: Path = DATA) -> None:
    import cv2

    from perception.dataset import load_folder, shared_hands_root
    from perception.features import to_work_size
    from perception.landmarks import find_landmarks

    images, labels, names, files = load_folder(shared_hands_root())
    points, kept_labels, kept_files = [], [], []
    for im, y, f in zip(images, labels, files, strict=True):
        frame = np.full((480, 640, 3), 185, np.uint8)
        frame[240:480, 200:440] = cv2.resize(to_work_size(im), (240, 240), interpolation=cv2.INTER_AREA)
        hands = find_landmarks(frame)
        if hands:
            points.append(hands[0].points)
            kept_labels.append(names[y])
            kept_files.append(Path(f).name)
    np.savez_compressed(
        out, points=np.array(points, np.float32), labels=np.array(kept_labels), files=np.array(kept_files)
    )
    print(f"{out}: {len(points)} of {len(images)} photographs")


if __name__ == "__main__":
    _build()
