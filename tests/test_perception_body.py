"""People in the shared Weizmann clips: arm ellipses on labelled frames, regions, tracking, no motion."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from perception.ellipses import body_regions
from perception.io import load_frames
from perception.segmentation import NoMotionError, person_regions
from perception.tracking import track_boxes

LABELS = Path(__file__).resolve().parents[1] / "perception" / "data" / "weizmann_wave2_labels.json"


def from_horizontal(e) -> float:
    return min(e.orientation_deg, 180 - e.orientation_deg)


def test_wave2_arm_ellipses_follow_the_labelled_arm_poses(weizmann):
    labels = json.loads(LABELS.read_text())["frames"]
    angles = {"sideways": [], "up": []}
    found = total = 0
    for person, poses in labels.items():
        regions = person_regions(load_frames(weizmann / "wave2" / f"{person}.png"))
        for pose, frames in poses.items():
            for i in frames:
                ells = body_regions(regions[i])
                for arm in ("left_arm", "right_arm"):
                    total += 1
                    if ells[arm] is not None:
                        found += 1
                        angles[pose].append(from_horizontal(ells[arm]))
    side, up = np.array(angles["sideways"]), np.array(angles["up"])
    print(
        f"arms found {found}/{total}; sideways mean {side.mean():.1f} max {side.max():.1f}; "
        f"up mean {up.mean():.1f} min {up.min():.1f} (degrees from horizontal)"
    )
    assert found >= 0.95 * total
    assert side.max() < 35 and side.mean() < 20  # near horizontal when the arms are sideways
    assert up.min() > 35 and up.mean() > 55  # steep when the arms are up


def test_body_regions_have_head_above_torso_and_arms_either_side(weizmann):
    regions = person_regions(load_frames(weizmann / "wave2" / "person3.png"))
    ells = body_regions(regions[30])  # arms sideways (labelled)
    assert ells["head"].y_c < ells["torso"].y_c
    assert ells["left_arm"].x_c < ells["torso"].x_c < ells["right_arm"].x_c


def test_kalman_tracking_smooths_noisy_boxes_and_bridges_missed_frames():
    rng = np.random.default_rng(0)
    truth = np.array([(10 + 0.8 * t, 20 + 0.3 * t, 30, 40) for t in range(60)], float)
    dets = [tuple(b + rng.normal(0, 2, 4)) for b in truth]
    dets[30] = dets[31] = None
    tracked = track_boxes(dets)
    raw = np.mean([np.abs(np.array(d) - b).mean() for d, b in zip(dets, truth) if d is not None])
    kf = np.mean([np.abs(np.array(t) - b).mean() for t, b in zip(tracked[10:], truth[10:])])
    assert kf < 0.8 * raw
    assert tracked[30] is not None and np.abs(np.array(tracked[31]) - truth[31]).max() < 4


def test_tracking_follows_the_person_in_a_real_clip(weizmann):
    regions = person_regions(load_frames(weizmann / "wave1" / "person2.png"))
    tracked = track_boxes([r.bbox for r in regions])
    assert all(t is not None for t in tracked[1:])
    centres = np.array([(x + w / 2, y + h / 2) for x, y, w, h in tracked[1:]])
    assert np.all((centres > 5) & (centres < 59))  # stays on the person, inside the picture


def test_still_frames_are_no_motion():
    frame = np.random.default_rng(1).integers(0, 255, (64, 64, 3), dtype=np.uint8)
    with pytest.raises(NoMotionError, match="no motion"):
        person_regions([frame.copy() for _ in range(20)])
