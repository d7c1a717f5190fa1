"""The whole person in the shared Weizmann clips (issue 20): silhouettes from head top to feet on the labelled
frames, an upright torso ellipse, and clips without a person refused in one line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from perception.body_figures import HEAD_FEET_TOLERANCE, feet_error, head_error, torso_upright
from perception.ellipses import body_regions
from perception.io import load_frames
from perception.segmentation import NoPersonError, person_regions

REPO = Path(__file__).resolve().parents[1]
ROWS = REPO / "tests" / "labels" / "weizmann_rows.json"
TORSO_STRIDE = 6  # every 6th frame of every clip for the torso figure (scripts/body_figures.py: all frames)


@pytest.fixture(scope="module")
def clips(weizmann):
    """{clip: (labels, {frame: PersonRegions})} for the labelled frames and every TORSO_STRIDE-th frame."""
    out = {}
    for name, labels in json.loads(ROWS.read_text())["clips"].items():
        frames = load_frames(weizmann / f"{name}.png")
        wanted = sorted({lab["frame"] for lab in labels} | set(range(0, len(frames), TORSO_STRIDE)))
        out[name] = (labels, dict(zip(wanted, person_regions(frames, only=wanted))))
    return out


def test_labels_cover_five_frames_of_every_wave_and_jack_clip():
    labels = json.loads(ROWS.read_text())["clips"]
    expected = {f"{a}/person{p}" for a in ("wave1", "wave2", "jack") for p in range(7)}
    assert set(labels) == expected
    assert all(len(rows) >= 5 for rows in labels.values())


def test_silhouette_spans_from_the_head_top_to_the_feet(clips):
    head = feet = both = total = 0
    for labels, regions in clips.values():
        for lab in labels:
            sil = regions[lab["frame"]].silhouette
            h = head_error(sil, lab["head_x"], lab["head_top"]) <= HEAD_FEET_TOLERANCE
            f = feet_error(sil, lab["feet"]) <= HEAD_FEET_TOLERANCE
            head, feet, both, total = head + h, feet + f, both + (h and f), total + 1
    print(f"labelled frames {total}: head top {head}, feet {feet}, both {both} within {HEAD_FEET_TOLERANCE} px")
    assert total >= 105
    assert both >= 0.9 * total


def test_torso_ellipse_is_upright_below_the_head(clips):
    ok = []
    for labels, regions in clips.values():
        for r in regions.values():
            e = body_regions(r)
            ok.append(torso_upright(e["torso"], e["head"]))
    print(f"torso upright in {sum(ok)}/{len(ok)} frames")
    assert np.mean(ok) >= 0.9


def test_torso_of_a_standing_person_holds_the_legs(clips, weizmann):
    # wave2 person3, arms sideways (labelled): the torso region reaches the picture's bottom (the legs), the
    # head sits on it, the arms leave it on either side
    r = person_regions(load_frames(weizmann / "wave2" / "person3.png"), only=[30])[0]
    e = body_regions(r)
    assert np.flatnonzero(r.torso.any(axis=1))[-1] == 63
    assert abs(e["torso"].orientation_deg - 90) < 10 and e["torso"].l_major > 30
    assert e["left_arm"].x_c < e["head"].x_c < e["right_arm"].x_c


def _pan(frame: np.ndarray, frames: int = 40, step: int = 2) -> list[np.ndarray]:
    """A camera panning over a real scene: a 64-px window sliding over the frame and its mirror image."""
    wide = np.hstack([frame, frame[:, ::-1], frame])
    return [wide[:, step * k : step * k + frame.shape[1]].copy() for k in range(frames)]


def _ball_on_the_wall(frame: np.ndarray, frames: int = 40) -> list[np.ndarray]:
    """An empty scene: the real wall beside the person (columns 0-19, mirrored to 64) and a small ball rolling."""
    wall = frame[:, :20]
    scene = np.hstack([wall, wall[:, ::-1], wall, wall[:, ::-1]])[:, : frame.shape[1]]
    out = []
    for k in range(frames):
        f = scene.copy()
        cv2.circle(f, (4 + k, 50), 3, (40, 40, 40), -1)
        out.append(f)
    return out


def test_moving_camera_and_empty_scene_have_no_person(weizmann):
    frame = load_frames(weizmann / "wave2" / "person0.png")[0]
    with pytest.raises(NoPersonError, match="no person found: the camera moves"):
        person_regions(_pan(frame))
    with pytest.raises(NoPersonError, match="no person found"):
        person_regions(_ball_on_the_wall(frame))


@pytest.mark.swarm
def test_perceive_a_clip_without_a_person_is_one_line_exit_1(tmp_path, weizmann):
    frame = load_frames(weizmann / "wave2" / "person0.png")[0]
    strip = tmp_path / "pan.png"
    cv2.imwrite(str(strip), np.hstack(_pan(frame)))
    proc = subprocess.run(
        [sys.executable, "-m", "fluidswarm", "perceive", str(strip), "--out", str(tmp_path / "p.png")],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO,
    )
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "pan.png" in lines[0] and "no person found" in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr
