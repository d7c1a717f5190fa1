"""The hand-photograph sets: one sub-folder per class; a fixed, documented train/test split.

The default split of the shared set (`../shared/datasets/sign-language-digits`) puts a file in the test
set when the first byte of the MD5 of its *file name* is below 64 (about 25%): stable over time and
independent of the folder order, so results are comparable between runs and machines.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import cv2
import numpy as np

from perception.io import IMAGE_SUFFIXES, InputError

SHARED_HANDS = Path(__file__).resolve().parent.parent.parent / "shared" / "datasets" / "sign-language-digits"


def is_test_file(name: str) -> bool:
    return hashlib.md5(name.encode()).digest()[0] < 64


def load_folder(root: str | Path, classes: list[str] | None = None):
    """(images BGR list, labels array, class names, file names) from ROOT/<class>/*.jpg."""
    root = Path(root)
    if not root.is_dir():
        raise InputError(f"{root}: no such folder")
    names = sorted(p.name for p in root.iterdir() if p.is_dir())
    if classes is not None:
        missing = [c for c in classes if c not in names]
        if missing:
            raise InputError(f"{root}: no class folder {missing[0]!r}")
        names = [c for c in names if c in classes]
    if len(names) < 2:
        raise InputError(f"{root}: expected one sub-folder per class (at least 2), found {len(names)}")
    images, labels, files = [], [], []
    for k, c in enumerate(names):
        paths = sorted(p for p in (root / c).iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not paths:
            raise InputError(f"{root / c}: class folder holds no images")
        for p in paths:
            img = cv2.imread(str(p), cv2.IMREAD_COLOR)
            if img is None:
                raise InputError(f"{p}: unreadable image")
            images.append(img)
            labels.append(k)
            files.append(p.name)
    return images, np.array(labels), names, files


def shared_split(classes: list[str] | None = None):
    """(train images, train labels, test images, test labels, class names) of the documented split."""
    if not SHARED_HANDS.is_dir():
        raise InputError(f"{SHARED_HANDS}: the shared hand set is missing; pass --train and --test")
    images, labels, names, files = load_folder(SHARED_HANDS, classes)
    test = np.array([is_test_file(f) for f in files])
    tr = [im for im, t in zip(images, test) if not t]
    te = [im for im, t in zip(images, test) if t]
    return tr, labels[~test], te, labels[test], names
