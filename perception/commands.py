"""`fluidswarm eval-classifier` (thesis Tables 4.1-4.2 style report) and `fluidswarm perceive`."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from fluidswarm.errors import UserError

COMPONENTS = (5, 15, 30, 35, 50, 100)


def register(sub) -> None:
    p = sub.add_parser("eval-classifier", help="eigen-image classifier: recognition rate vs components, times, confusion")
    p.add_argument("--train", help="folder with one sub-folder per class (default: the documented split of the shared set)")
    p.add_argument("--test", help="folder with one sub-folder per class")
    p.add_argument("--classes", help="comma-separated class folder names, e.g. 0,1,2,4,5 (default: all)")
    p.add_argument("--method", choices=["baseline", "best"], default="best")
    p.set_defaults(func=_eval)
    p = sub.add_parser("perceive", help="segment a hand photograph, print and draw what was found")
    p.add_argument("input", help="image file")
    p.add_argument("--out", default="out/perceive.png")
    p.set_defaults(func=_perceive)


def _eval(args) -> int:
    from threadpoolctl import threadpool_limits

    from perception.dataset import load_folder, shared_split
    from perception.eigen import EigenClassifier
    from perception.io import InputError

    classes = [c.strip() for c in args.classes.split(",")] if args.classes else None
    if bool(args.train) != bool(args.test):
        raise UserError("--train and --test go together (or neither, for the documented shared split)")
    try:
        if args.train:
            tr, ytr, names_tr, _ = load_folder(args.train, classes)
            te, yte, names_te, _ = load_folder(args.test, classes)
            if names_tr != names_te:
                raise UserError(f"{args.test}: class folders {names_te} differ from {args.train}'s {names_tr}")
            names = names_tr
        else:
            tr, ytr, te, yte, names = shared_split(classes)
    except InputError as exc:
        raise UserError(str(exc)) from None
    # One BLAS thread: on 2 shared cores, threaded BLAS was 5x slower for these small matrices.
    with threadpool_limits(1):
        print(f"train={len(ytr)} test={len(yte)} classes={','.join(names)} method={args.method}")
        results = {}
        for method in ("baseline", "best"):
            clf = EigenClassifier(method)
            t0 = time.perf_counter()
            ftr = clf.features(tr)
            t_feat = time.perf_counter() - t0
            t0 = time.perf_counter()
            fte = clf.features(te)
            t_feat_test = time.perf_counter() - t0
            print(f"\n{method}: recognition rate vs principal components (Table 4.1)")
            for k in COMPONENTS:
                c = EigenClassifier(method, k)
                t0 = time.perf_counter()
                c.fit(None, ytr, ftr)
                t_fit = time.perf_counter() - t0
                t0 = time.perf_counter()
                pred = c.predict(features=fte)
                t_pred = time.perf_counter() - t0
                acc = float((pred == yte).mean())
                results[(method, k)] = (acc, t_feat + t_fit, t_feat_test + t_pred, pred)
                print(f"  components={k:4d}  rate={acc:.3f}  train_s={t_feat + t_fit:.2f}  test_s={t_feat_test + t_pred:.2f}")
        k = EigenClassifier(args.method).default_components()
        acc, t_train, t_test, pred = results[(args.method, k)]
        print(f"\n{args.method} at {k} components: training {t_train:.2f} s, testing {t_test:.2f} s "
              f"({1000 * t_test / max(len(yte), 1):.2f} ms/image) (Table 4.2)")
        print("confusion matrix (rows: true, columns: predicted): " + " ".join(names))
        cm = np.zeros((len(names), len(names)), dtype=int)
        np.add.at(cm, (yte, pred), 1)
        for name, row in zip(names, cm):
            print(f"  {name:>4} " + " ".join(f"{v:4d}" for v in row))
    print(f"training_seconds={t_train:.3f}")
    print(f"accuracy={acc:.4f}")
    return 0


def _perceive(args) -> int:
    import cv2

    from perception.io import InputError, load_image
    from perception.segmentation import SegmentationError, hand_mask

    try:
        img = load_image(args.input)
        mask = hand_mask(img)
    except (InputError, SegmentationError) as exc:
        raise UserError(str(exc) if args.input in str(exc) else f"{args.input}: {exc}") from None
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    out = img.copy()
    cv2.drawContours(out, contours, -1, (0, 0, 255), 1)
    c = max(contours, key=cv2.contourArea)
    if len(c) >= 5:
        (x, y), (a, b), ang = cv2.fitEllipse(c)
        cv2.ellipse(out, ((x, y), (a, b), ang), (255, 0, 0), 1)
        print(f"ellipse l_major={max(a, b):.1f} l_minor={min(a, b):.1f} orientation={ang:.1f} x_c={x:.1f} y_c={y:.1f}")
    print(f"silhouette_area={int(mask.sum())}")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(args.out), cv2.resize(out, None, fx=4, fy=4, interpolation=cv2.INTER_NEAREST))
    print(f"png={args.out}")
    return 0
