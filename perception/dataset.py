"""The hand-photograph sets: one sub-folder per class; a fixed, documented train/test split.

Layout: ``ROOT/<class>/<image>``, at least two class folders, each holding images. Anything else (no
class folders, images lying next to the class folders, a class folder without images) is an
`InputError` "unknown class folder layout" naming the folder.

The default split of the shared set (`../shared/datasets/sign-language-digits`) puts a file in the test
set when the first byte of the MD5 of its *file name* is below 64 (about 25%): stable over time and
independent of the folder order, so results are comparable between runs and machines.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from perception.io import IMAGE_SUFFIXES, InputError, load_image

SHARED_HANDS = Path(__file__).resolve().parent.parent.parent / "shared" / "datasets" / "sign-language-digits"


def is_test_file(name: str) -> bool:
    """The documented split: test when md5(file name)[0] < 64 (about one file in four)."""
    return hashlib.md5(name.encode()).digest()[0] < 64


def shared_hands_root() -> Path:
    if not SHARED_HANDS.is_dir():
        raise InputError(f"{SHARED_HANDS}: the shared hand set is missing; pass --train and --test")
    return SHARED_HANDS


def _sort_key(name: str):
    return (0, int(name), name) if name.isdigit() else (1, 0, name)


def class_folders(root: str | Path, classes: list[str] | None = None) -> list[str]:
    """The class folder names under ROOT (sorted, digits numerically); refuses any other layout."""
    root = Path(root)
    if not root.exists():
        raise InputError(f"{root}: no such folder")
    if not root.is_dir():
        raise InputError(f"{root}: not a folder (expected one sub-folder per class)")
    entries = [p for p in root.iterdir() if not p.name.startswith(".")]
    names = sorted((p.name for p in entries if p.is_dir()), key=_sort_key)
    stray = sorted(p.name for p in entries if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
    if stray:
        raise InputError(
            f"{root}: unknown class folder layout: images ({stray[0]}, ...) next to the class "
            "folders; expected one sub-folder per class"
        )
    if classes is not None:
        missing = [c for c in classes if c not in names]
        if missing:
            raise InputError(f"{root}: no class folder {missing[0]!r}")
        names = [c for c in names if c in classes]
    if len(names) < 2:
        raise InputError(
            f"{root}: unknown class folder layout: expected one sub-folder per class (at least 2), found {len(names)}"
        )
    for c in names:
        if not any(p.suffix.lower() in IMAGE_SUFFIXES for p in (root / c).iterdir() if p.is_file()):
            raise InputError(f"{root / c}: unknown class folder layout: class folder holds no images")
    return names


def load_folder(root: str | Path, classes: list[str] | None = None):
    """(images BGR list, labels array of indices into names, class names, file names) from ROOT/<class>/."""
    root = Path(root)
    names = class_folders(root, classes)
    images, labels, files = [], [], []
    for k, c in enumerate(names):
        for p in sorted(p for p in (root / c).iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES):
            images.append(load_image(p))
            labels.append(k)
            files.append(p.name)
    return images, np.array(labels), names, files


def shared_split(classes: list[str] | None = None):
    """(train images, train labels, test images, test labels, class names) of the documented split."""
    images, labels, names, files = load_folder(shared_hands_root(), classes)
    test = np.array([is_test_file(f) for f in files])
    tr = [im for im, t in zip(images, test) if not t]
    te = [im for im, t in zip(images, test) if t]
    return tr, labels[~test], te, labels[test], names
