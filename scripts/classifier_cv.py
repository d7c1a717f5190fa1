"""Cross-validate the hand classifier on the documented split's TRAINING part only (the held-out files of
`perception.dataset.is_test_file` are dropped before anything is computed), the figure every choice of
docs/perception.md is made on:

    flock /tmp/fluidswarm-cpu.lock .venv/bin/python scripts/classifier_cv.py [--train FOLDER] \\
        [--classes 0,1,2,4,5] [--method best|eigen] [--folds 5]

Folds by a hash of the file name (sha1(name)[1] % folds, as tests/test_perception_classifier.py's), all classes
in every fold. Each fold's classifier is trained on the other folds (with the turned copies the method trains
on) and names its fold's photographs. Prints each fold's rate, the mean and the smallest, and the files it got
wrong (true -> predicted). --train: a class-folder set to cross-validate whole instead (no split applied).
"""

from __future__ import annotations

import argparse
import hashlib
import sys

import numpy as np
from threadpoolctl import threadpool_limits

from perception.dataset import is_test_file, load_folder, shared_hands_root
from perception.eigen import EigenClassifier
from perception.io import InputError


def folds_of(files: list[str], folds: int) -> np.ndarray:
    return np.array([hashlib.sha1(f.encode()).digest()[1] % folds for f in files])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", help="class-folder set, cross-validated whole (default: the shared set's training part)")
    ap.add_argument("--classes", help="comma-separated class folder names (default: all)")
    ap.add_argument("--method", choices=["best", "eigen"], default="best")
    ap.add_argument("--folds", type=int, default=5)
    args = ap.parse_args(argv)
    if args.folds < 2:
        print(f"--folds: need at least 2, got {args.folds}", file=sys.stderr)
        return 2
    classes = [c.strip() for c in args.classes.split(",") if c.strip()] if args.classes else None
    try:
        images, labels, names, files = load_folder(args.train or shared_hands_root(), classes)
    except InputError as exc:
        print(exc, file=sys.stderr)
        return 2
    if not args.train:  # the documented split's training part: the held-out files play no part
        keep = [not is_test_file(f) for f in files]
        images = [im for im, k in zip(images, keep) if k]
        labels, files = labels[np.array(keep)], [f for f, k in zip(files, keep) if k]
    y = np.array(names)[labels]
    folds = folds_of(files, args.folds)
    print(f"images={len(y)} classes={','.join(names)} method={args.method} folds={args.folds}")
    with threadpool_limits(1):
        clf = EigenClassifier(args.method)
        x = clf.training_features(images)  # angle-major copies when the method trains on turned hands
        copies = x.reshape(len(x) // len(y), len(y), -1)
        rates, wrong = [], []
        for k in range(args.folds):
            test = folds == k
            fold_clf = EigenClassifier(args.method).fit(None, y[~test], copies[:, ~test].reshape(-1, x.shape[1]))
            pred = fold_clf.predict(features=copies[0, test])
            rates.append(float((pred == y[test]).mean()))
            wrong += [f"{f}:{t}->{p}" for f, t, p in zip(np.array(files)[test], y[test], pred) if t != p]
            print(f"  fold {k}: rate={rates[-1]:.4f} n={int(test.sum())}")
    print("wrong: " + (" ".join(wrong) if wrong else "none"))
    print(f"cv_errors={len(wrong)} of {len(y)}")
    print(f"cv_min_fold={min(rates):.4f}")
    print(f"cv_accuracy={np.mean(rates):.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
