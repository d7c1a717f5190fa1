"""`fluidswarm bench-perception`: hands and persons found in ordinary rooms, per background family
(perception/composites.py), by today's reading (`find_hand`: the plain-background reading, then the learned
detector) beside the old one (the plain-background reading alone).

Accuracy is of the hands found (detection is its own column). Hands: the shared set's documented test
split (perception/dataset.py); the classifiers (ten classes, and classes 0,1,2,4,5; the silhouette's and
the landmarks') trained on its training split only. Per family: `hands` composites with a hand, as many
without (false positives: a hand reported where there is none), each through `degrade`. Persons: Weizmann
silhouettes pasted likewise, found from the single frame (perception/selfie.py). The hand photographs and
the Weizmann clips come from ../shared/datasets: without them the benchmark says so and stops (exit 1).
The same seed gives the same frames.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import numpy as np

from agent.protocol.errors import UserError
from perception.composites import HAND_ENDS, bottom_ratio

FIVE = ("0", "1", "2", "4", "5")


@dataclass
class Tally:
    hands: int = 0
    found: int = 0
    ious: list[float] = field(default_factory=list)
    right10: int = 0
    five: int = 0
    right5: int = 0
    empty: int = 0
    false: int = 0
    ms: list[float] = field(default_factory=list)
    cpu_ms: list[float] = field(default_factory=list)  # the process's CPU time (all its threads) per frame

    def row(self, name: str) -> str:
        det = self.found / max(self.hands, 1)
        iou = float(np.mean(self.ious)) if self.ious else 0.0
        acc10 = self.right10 / max(self.found, 1)
        acc5 = self.right5 / max(self.five, 1)
        fp = self.false / max(self.empty, 1)
        ms = float(np.median(self.ms)) if self.ms else 0.0
        return (
            f"| {name} | {self.hands} | {det:.3f} | {self.false}/{self.empty} ({fp:.3f}) | {iou:.3f} | "
            f"{acc10:.3f} | {acc5:.3f} | {ms:.0f} |"
        )

    def add(self, other: Tally) -> None:
        for k in ("hands", "found", "right10", "five", "right5", "empty", "false"):
            setattr(self, k, getattr(self, k) + getattr(other, k))
        self.ious += other.ious
        self.ms += other.ms
        self.cpu_ms += other.cpu_ms


def hand_end(mask: np.ndarray) -> str:
    """Which of HAND_ENDS a hand's mask (bool, the photograph's: its wrist or cut at the bottom) falls in."""
    ratio = bottom_ratio(mask)
    return next(name for limit, name in HAND_ENDS if ratio < limit)


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    u = np.logical_or(a, b).sum()
    return float(np.logical_and(a, b).sum() / u) if u else 0.0


def _shared():
    from perception.dataset import SHARED_HANDS

    weizmann = SHARED_HANDS.parent / "weizmann-actions-64"
    missing = [p for p in (SHARED_HANDS, weizmann) if not p.is_dir()]
    if missing:
        raise UserError(
            "bench-perception: the shared data set folder "
            + " and ".join(str(p) for p in missing)
            + " is missing: the benchmark pastes its hands and persons into the backgrounds; nothing measured"
        )
    return SHARED_HANDS, weizmann


def run(hands: int = 20, seed: int = 0, families: tuple[str, ...] | None = None, held: bool = False) -> int:
    from threadpoolctl import threadpool_limits

    from perception import composites as cm
    from perception.dataset import is_test_file, shared_split
    from perception.eigen import EigenClassifier
    from perception.features import to_work_size
    from perception.hand import NoHandError, find_hand
    from perception.hand_pose import pose_classifier
    from perception.io import load_frames
    from perception.segmentation import SegmentationError, hand_mask, person_regions
    from perception.selfie import person_silhouette

    _, weizmann = _shared()
    rng = np.random.default_rng(seed)
    photos = cm.skimage_photos(cm.HELD_PHOTOS if held else cm.PHOTOS)
    fams = list(families or cm.FAMILIES)
    if photos is None and "photo" in fams:
        print("photo: scikit-image is not installed (pip install 'fluidswarm[test]'): family left out")
        fams.remove("photo")
    with threadpool_limits(1):
        tr, ytr, te, yte, names = shared_split()
        clf10 = EigenClassifier("best").fit(tr, [names[y] for y in ytr])
        idx5 = [i for i, y in enumerate(ytr) if names[y] in FIVE]
        clf5 = EigenClassifier("best").fit([tr[i] for i in idx5], [names[ytr[i]] for i in idx5])
        poses10 = pose_classifier(files=lambda name: not is_test_file(name))  # the landmarks' classifier
        poses5 = poses10.only(FIVE)
        # persons: (frame, silhouette) of every 10th frame of each clip, the project's own silhouettes; walls:
        # the clips' medians without their persons. Building: persons 0-3; --held-out: persons 4-6.
        walls, people = [], []
        for path in sorted(weizmann.glob("*/person*.png")):
            if (int(path.stem.removeprefix("person")) >= 4) != held:
                continue
            frames = load_frames(path)
            only = list(range(0, len(frames), 10))
            try:
                regions = person_regions(frames, only=only)
            except SegmentationError:
                continue
            found = [(frames[k], r.silhouette) for k, r in zip(only, regions, strict=True) if r.silhouette.sum() > 50]
            people += found
            walls.append(cm.weizmann_wall(frames, np.any([s for _, s in found], axis=0)))
        # the models load on first use: not part of a frame's time
        warm = cm.degrade(cm.background_maker("noise")(rng), rng)
        for _ in range(2):
            try:
                find_hand(warm, clf10)
            except NoHandError:
                pass
            try:
                person_silhouette(warm)
            except SegmentationError:
                pass
        # the machine's load: a frame's wall time grows with other work on its cores, its CPU time (cpu_ms) less so
        load = os.getloadavg()[0]
        print(
            f"seed={seed} hands_per_family={hands} train={len(ytr)} test={len(yte)} held_out_backgrounds={held} "
            f"load={load:.2f}"
        )
        new_all, old_all, person_rows = Tally(), Tally(), []
        by_end = {name: [0, 0] for _, name in HAND_ENDS}  # today's reading: [hands, found] by hand_end
        lines = []
        for fam in fams:
            make = cm.background_maker(fam, photos, walls)
            new, old = Tally(), Tally()
            p_found, p_ious, p_ms, p_n, p_false = 0, [], [], 0, 0
            for k in range(hands):
                i = int(rng.integers(len(te)))
                photo = to_work_size(te[i])
                label = names[yte[i]]
                pmask = hand_mask(photo)
                frame, truth = cm.paste_hand(make(rng), photo, pmask, rng)
                scored = cm.scored_rows(truth)
                frame = cm.degrade(frame, rng)
                empty = cm.degrade(make(rng), rng)
                end = by_end[hand_end(pmask)]
                end[0] += 1
                for tally, learned in ((new, True), (old, False)):
                    tally.hands += 1
                    t0, c0 = time.perf_counter(), time.process_time()
                    try:
                        h = find_hand(frame, clf10, learned, poses10)
                    except NoHandError:
                        h = None
                    tally.ms.append(1000 * (time.perf_counter() - t0))
                    tally.cpu_ms.append(1000 * (time.process_time() - c0))
                    if h is not None:
                        tally.found += 1
                        end[1] += learned
                        tally.ious.append(_iou(h.mask[scored], truth[scored]))
                        tally.right10 += h.label == label
                    if label in FIVE:  # the five-class classifier's accuracy on the hands it found
                        try:
                            right = find_hand(frame, clf5, learned, poses5).label == label
                            tally.five += 1
                            tally.right5 += right
                        except NoHandError:
                            pass
                    tally.empty += 1
                    try:
                        find_hand(empty, clf10, learned, poses10)
                        tally.false += 1
                    except NoHandError:
                        pass
                if people and k % 2 == 0:  # persons: half as many
                    f, s = people[int(rng.integers(len(people)))]
                    pframe, ptruth = cm.paste_person(make(rng), f, s, rng)
                    pframe = cm.degrade(pframe, rng)
                    p_n += 1
                    t0 = time.perf_counter()
                    try:
                        pm = person_silhouette(pframe)
                        p_found += 1
                        p_ious.append(_iou(pm, ptruth))
                    except SegmentationError:
                        pass
                    p_ms.append(1000 * (time.perf_counter() - t0))
                    try:
                        person_silhouette(cm.degrade(make(rng), rng))
                        p_false += 1
                    except SegmentationError:
                        pass
            lines += [new.row(f"{fam}, now"), old.row(f"{fam}, before")]
            new_all.add(new)
            old_all.add(old)
            person_rows.append((fam, p_n, p_found, p_ious, p_ms, p_false))
            print(f"family {fam} done", flush=True)
    print()
    print(
        "| family, reading | hands | detected | false positives (hand-free frames) | mask IoU | accuracy, 10 classes "
        "| accuracy, classes 0,1,2,4,5 | ms per frame (median) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for line in lines + [new_all.row("**all, now**"), old_all.row("all, before")]:
        print(line)
    print()
    print("| family | persons | detected | silhouette IoU | false positives (person-free frames) | ms per frame |")
    print("|---|---|---|---|---|---|")
    pn = pf = pfalse = 0
    pious: list[float] = []
    for fam, n, found, ious, ms, false in person_rows:
        print(
            f"| {fam} | {n} | {found / max(n, 1):.3f} | {np.mean(ious) if ious else 0:.3f} | {false}/{n} | "
            f"{np.median(ms) if ms else 0:.0f} |"
        )
        pn, pf, pfalse = pn + n, pf + found, pfalse + false
        pious += ious
    print()
    print(
        "detection_by_hand_end: "
        + ", ".join(f"{name} {f}/{n} ({f / max(n, 1):.3f})" for name, (n, f) in by_end.items())
        + " (the photograph's hand: its bottom rows over its widest row)"
    )
    a = new_all
    print(
        f"hand_detection={a.found / max(a.hands, 1):.4f} mask_iou={np.mean(a.ious) if a.ious else 0:.4f} "
        f"accuracy10={a.right10 / max(a.found, 1):.4f} accuracy5={a.right5 / max(a.five, 1):.4f} "
        f"false_positives={a.false / max(a.empty, 1):.4f} ms_per_frame={np.median(a.ms):.1f} "
        f"ms_per_frame_p90={np.percentile(a.ms, 90):.1f} cpu_ms_per_frame={np.median(a.cpu_ms):.1f} "
        f"load={os.getloadavg()[0]:.2f}"
    )
    print(
        f"person_detection={pf / max(pn, 1):.4f} person_iou={np.mean(pious) if pious else 0:.4f} "
        f"person_false_positives={pfalse / max(pn, 1):.4f}"
    )
    return 0
