"""Perception on the real hand photographs: segmentation, eigen-image classifier, bad input."""

from __future__ import annotations

import subprocess
import sys

import cv2
import numpy as np
import pytest

from perception.dataset import load_folder
from perception.io import InputError, load_frames, load_image


@pytest.mark.swarm
def test_eval_classifier_best_pipeline_beats_the_thesis_baseline(shared_hands):
    # the plausibility of the shared hands' silhouettes: tests/test_perception_classifier.py
    r = subprocess.run(
        [sys.executable, "-m", "fluidswarm", "eval-classifier", "--classes", "0,1,2,4,5", "--method", "best"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    acc = float(lines[-1].split("=")[1])
    base = next(float(l.split("rate=")[1].split()[0]) for l in lines if "components=  50" in l)
    print(f"best={acc:.3f} baseline(50)={base:.3f}")
    assert acc >= 0.95 and acc > base


@pytest.mark.swarm
def test_bad_inputs_give_one_line_errors(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_image(tmp_path / "missing.jpg")
    trunc = tmp_path / "trunc.jpg"
    _ok, buf = cv2.imencode(".jpg", np.random.default_rng(0).integers(0, 255, (100, 100, 3), dtype=np.uint8))
    trunc.write_bytes(buf.tobytes()[:200])
    with pytest.raises(InputError):
        load_image(trunc)
    white = tmp_path / "white.png"
    cv2.imwrite(str(white), np.full((100, 100, 3), 255, np.uint8))
    with pytest.raises(InputError, match="empty"):
        load_image(white)
    huge = tmp_path / "huge.png"
    # A valid PNG header announcing 20000 x 20000 pixels: refused before decoding.
    header = (
        b"\x89PNG\r\n\x1a\n"
        + (13).to_bytes(4, "big")
        + b"IHDR"
        + (20000).to_bytes(4, "big") * 2
        + b"\x08\x02\x00\x00\x00"
    )
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
    r = subprocess.run(
        [sys.executable, "-m", "fluidswarm", "imitate", str(white)], capture_output=True, text=True, timeout=60
    )
    assert r.returncode == 1 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert str(white) in r.stderr
