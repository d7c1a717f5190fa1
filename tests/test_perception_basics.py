"""Perception on the real hand photographs: segmentation, eigen-image classifier, bad input."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from perception.dataset import SHARED_HANDS, load_folder
from perception.io import InputError, load_frames, load_image
from perception.segmentation import SegmentationError, hand_mask


def need_shared():
    if not SHARED_HANDS.is_dir():
        pytest.fail(f"this test needs the shared hand set at {SHARED_HANDS}")


def test_segmentation_plausible_for_98_percent_of_the_shared_hands():
    need_shared()
    images, labels, names, files = load_folder(SHARED_HANDS)
    ok = 0
    for img in images:
        try:
            m = hand_mask(img)
        except SegmentationError:
            continue
        h, w = m.shape
        area = m.mean()
        border = {"top": m[0].any(), "left": m[:, 0].any(), "right": m[:, -1].any(), "bottom": m[-1].any()}
        # The wrist leaves the picture at the bottom (or a side); a hand touching the top and the bottom
        # and both sides is a failed segmentation (background taken as hand).
        touches = sum(border.values())
        if 0.05 <= area <= 0.6 and touches <= 2 and not (border["top"] and border["bottom"] and touches > 2):
            ok += 1
    rate = ok / len(images)
    print(f"plausible silhouettes: {ok}/{len(images)} = {rate:.3f}")
    assert rate >= 0.98


@pytest.mark.swarm
def test_eval_classifier_best_pipeline_beats_the_thesis_baseline():
    need_shared()
    r = subprocess.run([sys.executable, "-m", "fluidswarm", "eval-classifier", "--classes", "0,1,2,4,5", "--method", "best"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    acc = float(lines[-1].split("=")[1])
    base = [float(l.split("rate=")[1].split()[0]) for l in lines if "components=  50" in l][0]
    print(f"best={acc:.3f} baseline(50)={base:.3f}")
    assert acc >= 0.95 and acc > base


@pytest.mark.swarm
def test_bad_inputs_give_one_line_errors(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_image(tmp_path / "missing.jpg")
    trunc = tmp_path / "trunc.jpg"
    ok, buf = cv2.imencode(".jpg", np.random.default_rng(0).integers(0, 255, (100, 100, 3), dtype=np.uint8))
    trunc.write_bytes(buf.tobytes()[:200])
    with pytest.raises(InputError):
        load_image(trunc)
    white = tmp_path / "white.png"
    cv2.imwrite(str(white), np.full((100, 100, 3), 255, np.uint8))
    with pytest.raises(InputError, match="empty"):
        load_image(white)
    huge = tmp_path / "huge.png"
    # A valid PNG header announcing 20000 x 20000 pixels: refused before decoding.
    header = b"\x89PNG\r\n\x1a\n" + (13).to_bytes(4, "big") + b"IHDR" + (20000).to_bytes(4, "big") * 2 + b"\x08\x02\x00\x00\x00"
    huge.write_bytes(header + b"\x00" * 100)
    with pytest.raises(InputError, match="too large"):
        load_image(huge)
    empty_dir = tmp_path / "frames"
    empty_dir.mkdir()
    with pytest.raises(InputError, match="no images"):
        load_frames(empty_dir)
    flat = tmp_path / "layout"
    (flat / "only").mkdir(parents=True)
    with pytest.raises(InputError, match="one sub-folder per class"):
        load_folder(flat)
    r = subprocess.run([sys.executable, "-m", "fluidswarm", "imitate", str(white)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 1 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert str(white) in r.stderr
