"""Issue 20's figures over every shared Weizmann clip (wave1, wave2, jack, bend; persons 0-6).

Prints, per clip: the labelled frames whose silhouette reaches within 3 px of the head top and of the feet
(tests/labels/weizmann_rows.json), the frames whose torso ellipse is upright (within 25 degrees of vertical,
l_major >= 18 px, centre below the head's), and the seconds it took; then the totals and the wave2 arm
angles on the labelled arm poses (perception/data/weizmann_wave2_labels.json).

    .venv/bin/python scripts/body_figures.py [--data DIR]     (output kept in docs/benchmarks/body_figures.txt)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from perception.body_figures import HEAD_FEET_TOLERANCE, feet_error, head_error, torso_upright
from perception.ellipses import body_regions
from perception.io import load_frames
from perception.segmentation import person_regions

ROOT = Path(__file__).resolve().parents[1]
ROWS = ROOT / "tests" / "labels" / "weizmann_rows.json"
ARMS = ROOT / "perception" / "data" / "weizmann_wave2_labels.json"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "datasets" / "weizmann-actions-64"))
    args = ap.parse_args()
    data = Path(args.data)
    rows = json.loads(ROWS.read_text())["clips"]
    arm_labels = json.loads(ARMS.read_text())["frames"]
    tot = {"labelled": 0, "head": 0, "feet": 0, "both": 0}
    upright = {}
    angles = {"sideways": [], "up": []}
    arms_found = arms_total = 0
    print(
        f"{'clip':16s} {'head':>7s} {'feet':>7s} {'both':>7s} {'torso upright':>14s} {'tilt med':>8s} "
        f"{'l_major med':>11s} {'s':>5s}"
    )
    for action in ("wave1", "wave2", "jack", "bend"):
        for person in range(7):
            name = f"{action}/person{person}"
            t0 = time.perf_counter()
            regions = person_regions(load_frames(data / action / f"person{person}.png"))
            secs = time.perf_counter() - t0
            ells = [body_regions(r) for r in regions]
            ok = [torso_upright(e["torso"], e["head"]) for e in ells]
            upright.setdefault(action, []).extend(ok)
            tilts = [abs(90 - e["torso"].orientation_deg) for e in ells if e["torso"] is not None]
            majors = [e["torso"].l_major for e in ells if e["torso"] is not None]
            h = f = b = n = 0
            for lab in rows.get(name, []):
                sil = regions[lab["frame"]].silhouette
                he = head_error(sil, lab["head_x"], lab["head_top"]) <= HEAD_FEET_TOLERANCE
                fe = feet_error(sil, lab["feet"]) <= HEAD_FEET_TOLERANCE
                n, h, f, b = n + 1, h + he, f + fe, b + (he and fe)
            for k, v in zip(("labelled", "head", "feet", "both"), (n, h, f, b)):
                tot[k] += v
            lab_txt = f"{h:>3d}/{n:<3d} {f:>3d}/{n:<3d} {b:>3d}/{n:<3d}" if n else f"{'-':>7s} {'-':>7s} {'-':>7s}"
            print(
                f"{name:16s} {lab_txt} {sum(ok):>6d}/{len(ok):<7d} {np.median(tilts):8.1f} {np.median(majors):11.1f} "
                f"{secs:5.2f}"
            )
            if action == "wave2" and f"person{person}" in arm_labels:
                for pose, frames in arm_labels[f"person{person}"].items():
                    for i in frames:
                        for arm in ("left_arm", "right_arm"):
                            arms_total += 1
                            if ells[i][arm] is not None:
                                arms_found += 1
                                e = ells[i][arm]
                                angles[pose].append(min(e.orientation_deg, 180 - e.orientation_deg))
    n = tot["labelled"]
    print(
        f"\nlabelled frames (wave1, wave2, jack): {n}; silhouette within {HEAD_FEET_TOLERANCE} px of the head top "
        f"{tot['head']}/{n} ({100 * tot['head'] / n:.1f} %), of the feet {tot['feet']}/{n} "
        f"({100 * tot['feet'] / n:.1f} %), both {tot['both']}/{n} ({100 * tot['both'] / n:.1f} %)"
    )
    for action, ok in upright.items():
        print(f"torso upright ({action}, all frames): {sum(ok)}/{len(ok)} ({100 * np.mean(ok):.1f} %)")
    stand = [v for a in ("wave1", "wave2", "jack") for v in upright[a]]
    print(f"torso upright (wave1, wave2, jack, all frames): {sum(stand)}/{len(stand)} ({100 * np.mean(stand):.1f} %)")
    side, up = np.array(angles["sideways"]), np.array(angles["up"])
    print(
        f"wave2 labelled arms found {arms_found}/{arms_total}; sideways mean {side.mean():.1f} max {side.max():.1f}; "
        f"up mean {up.mean():.1f} min {up.min():.1f} (degrees from horizontal)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
