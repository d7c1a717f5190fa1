"""`fluidswarm eval-classifier` (thesis Tables 4.1-4.2 style report) and `fluidswarm perceive`.

The command line imports every package's `commands` to build its parser, so perception's modules (OpenCV,
scipy, the classifier) are imported inside the subcommands that use them: `fluidswarm --help` and the
other subcommands start without them.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from agent.protocol.errors import UserError

COMPONENTS = (5, 15, 30, 35, 50, 100)


def register(sub) -> None:
    p = sub.add_parser(
        "eval-classifier", help="eigen-image classifier: recognition rate vs components, times, confusion"
    )
    p.add_argument(
        "--train", help="folder with one sub-folder per class (default: the documented split of the shared set)"
    )
    p.add_argument("--test", help="folder with one sub-folder per class (the same class names as --train)")
    p.add_argument("--classes", help="comma-separated class folder names, e.g. 0,1,2,4,5 (default: all)")
    p.add_argument(
        "--method",
        choices=["eigen", "best", "baseline"],
        default="best",
        help="the method whose accuracy is the last line (both are reported): eigen = the thesis' "
        "eigen-image method (also called baseline), best = hand HOG + SVM",
    )
    p.set_defaults(func=_eval)
    p = sub.add_parser("perceive", help="hand photograph or person video: print what was found, draw it")
    p.add_argument("input", help="image file, folder of frames, video file, or Weizmann strip PNG")
    p.add_argument("--out", default="out/perceive.png", help="annotated picture / contact sheet (PNG)")
    p.add_argument("--model", help="eigen classifier .npz (default: the shipped model)")
    p.set_defaults(func=_perceive)
    p = sub.add_parser(
        "bench-perception",
        help="hands and persons pasted into ordinary rooms: detection, false positives, mask IoU, accuracy, ms",
    )
    p.add_argument("--hands", type=int, default=20, help="hand composites per background family (default 20)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--families", help="comma-separated background families (default: all)")
    p.add_argument(
        "--held-out", action="store_true", help="the photographs and Weizmann clips kept apart while building"
    )
    p.set_defaults(func=_bench)


def _user_error(path, exc: Exception) -> UserError:
    msg = str(exc)
    return UserError(msg if str(path) in msg else f"{path}: {msg}")


def _eval(args) -> int:
    from threadpoolctl import threadpool_limits

    from perception.dataset import load_folder, shared_split
    from perception.eigen import ALIASES, DEFAULT_COMPONENTS, EigenClassifier
    from perception.io import InputError

    classes = [c.strip() for c in args.classes.split(",") if c.strip()] if args.classes else None
    if classes is not None and len(classes) < 2:
        raise UserError(f"--classes: need at least two classes, got {args.classes!r}")
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
    # One BLAS thread: on 2 shared cores, threaded BLAS was much slower for these small matrices.
    method_asked = ALIASES.get(args.method, args.method)
    with threadpool_limits(1):
        print(f"train={len(ytr)} test={len(yte)} classes={','.join(names)} method={method_asked}")
        results = {}
        for method in ("eigen", "best"):
            clf = EigenClassifier(method)
            t0, c0 = time.perf_counter(), time.process_time()
            ftr = clf.training_features(tr)  # best: with the turned copies of each training hand
            t_feat, c_feat = time.perf_counter() - t0, time.process_time() - c0
            t0 = time.perf_counter()
            fte = clf.features(te)
            t_feat_test = time.perf_counter() - t0
            # best's SVM works on the HOG vectors themselves: its components only measure the hand space
            comps = COMPONENTS if method == "eigen" else (DEFAULT_COMPONENTS[method],)
            print(f"\n{method}: recognition rate vs principal components (Table 4.1)")
            for k in comps:
                c = EigenClassifier(method, k)
                t0, c0 = time.perf_counter(), time.process_time()
                c.fit(None, ytr, ftr)
                t_fit, c_fit = time.perf_counter() - t0, time.process_time() - c0
                t0 = time.perf_counter()
                pred = c.predict(features=fte)
                t_pred = time.perf_counter() - t0
                acc = float((pred == yte).mean())
                results[(method, k)] = (acc, t_feat + t_fit, t_feat_test + t_pred, pred, c_feat + c_fit)
                print(
                    f"  components={k:4d}  rate={acc:.3f}  correct={int((pred == yte).sum())}/{len(yte)}  "
                    f"train_s={t_feat + t_fit:.2f}  test_s={t_feat_test + t_pred:.2f}"
                )
        for method in ("eigen", "best"):
            print(f"{method}_accuracy={results[(method, DEFAULT_COMPONENTS[method])][0]:.4f}")
        clf = EigenClassifier(method_asked)
        k = clf.default_components()
        acc, t_train, t_test, pred, cpu_train = results[(method_asked, k)]
        print(
            f"\n{method_asked} at {k} components: training {t_train:.2f} s (cpu {cpu_train:.2f} s), "
            f"testing {t_test:.2f} s ({1000 * t_test / max(len(yte), 1):.2f} ms/image) (Table 4.2)"
        )
        print("confusion matrix (rows: true, columns: predicted): " + " ".join(names))
        cm = np.zeros((len(names), len(names)), dtype=int)
        np.add.at(cm, (yte, pred), 1)
        for name, row in zip(names, cm):
            print(f"  {name:>4} " + " ".join(f"{v:4d}" for v in row))
        # Training on everything given (train + test images), features included: the thesis' Table 4.2 figure.
        t0, c0 = time.perf_counter(), time.process_time()
        EigenClassifier(method_asked).fit(list(tr) + list(te), np.concatenate([ytr, yte]))
        t_all, c_all = time.perf_counter() - t0, time.process_time() - c0
    print(f"training_seconds_all_images={t_all:.3f} cpu_seconds={c_all:.3f} images={len(ytr) + len(yte)}")
    print(f"training_seconds={t_train:.3f} cpu_seconds={cpu_train:.3f}")
    print(f"accuracy={acc:.4f}")
    return 0


def _perceive(args) -> int:
    from perception.io import InputError, is_clip, load_frames
    from perception.segmentation import SegmentationError

    path = Path(args.input)
    try:
        # `perceive` looks at a person in a folder of frames too (imitate reads a folder as hand photographs)
        if path.is_dir() or is_clip(path, load_frames(path)):
            from perception.perceive import perceive_clip

            lines, picture = perceive_clip(path)
        else:
            from perception.perceive import perceive_hand

            lines, picture = perceive_hand(path, model=args.model)
    except (InputError, SegmentationError, ValueError) as exc:
        raise _user_error(path, exc) from None
    import cv2

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), picture):
        raise UserError(f"{out}: cannot write the picture")
    for line in lines:
        print(line)
    print(f"png={out}")
    return 0


def _bench(args) -> int:
    from perception.bench_room import run
    from perception.composites import FAMILIES

    fams = tuple(f.strip() for f in args.families.split(",") if f.strip()) if args.families else None
    bad = [f for f in fams or () if f not in FAMILIES]
    if bad:
        raise UserError(f"--families: unknown {', '.join(bad)} (known: {', '.join(FAMILIES)})")
    if args.hands < 1:
        raise UserError(f"--hands: at least 1, got {args.hands}")
    return run(args.hands, args.seed, fams, args.held_out)
