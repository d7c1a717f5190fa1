"""The shipped TFLite models run by either runner (perception/models.py): LiteRT (the models' own runtime, the
default where it is installed) and OpenCV's DNN module (where it is not) find the same palms, hands and
persons on real frames; OpenCV's landmarks stray from LiteRT's by a few pixels of the 224-px crop (its
importer's padding), so the figures are LiteRT's. A missing or corrupt model file is one line naming it,
for both runners."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from perception import composites as cm
from perception import models
from perception.dataset import is_test_file
from perception.features import to_work_size
from perception.io import load_image
from perception.landmarks import PALM_SIZE, find_landmarks, letterbox
from perception.segmentation import hand_mask
from perception.selfie import person_probability


def room_with_a_hand(shared_hands, cls: int, family: str, seed: int) -> np.ndarray:
    files = sorted(p for p in (shared_hands / str(cls)).iterdir() if is_test_file(p.name))
    photo = to_work_size(load_image(files[0]))
    rng = np.random.default_rng(seed)
    frame, _ = cm.paste_hand(cm.background_maker(family)(rng), photo, hand_mask(photo), rng)
    return cm.degrade(frame, rng, 0.5)


def test_litert_is_the_default_runner_here():
    # the project's environment installs ai-edge-litert (pyproject.toml): the figures are measured with it
    assert models.default_runner() == "litert"


def test_both_runners_give_the_same_outputs_on_real_frames(shared_hands, monkeypatch):
    frames = [room_with_a_hand(shared_hands, c, f, c) for c, f in ((5, "plain"), (2, "skin"), (1, "stripes"))]
    for frame in frames:
        square = letterbox(frame[..., ::-1], PALM_SIZE)[0]
        a = models.run_model("palm_detection_lite.tflite", square, ("Identity", "Identity_1"), "litert")
        b = models.run_model("palm_detection_lite.tflite", square, ("Identity", "Identity_1"), "opencv")
        for x, y in zip(a, b, strict=True):
            assert x.size == y.size and np.allclose(x.ravel(), y.ravel(), atol=2e-3 * max(1.0, np.abs(x).max()))
    hands = {}
    for runner in ("litert", "opencv"):
        monkeypatch.setattr(models, "default_runner", lambda r=runner: r)
        hands[runner] = [find_landmarks(f) for f in frames]
        probs = [person_probability(f) for f in frames]
        hands[runner + " person"] = probs
    for lite, cv in zip(hands["litert"], hands["opencv"], strict=True):
        assert len(lite) == len(cv) >= 1
        # measured: 1-2 px apart on average, 6.5 px at most (0.07 of the hand's palm length: the crop's 1-3 px)
        apart = np.linalg.norm(lite[0].points - cv[0].points, axis=1) / lite[0].palm_length()
        assert apart.mean() < 0.04 and apart.max() < 0.12, apart
        assert abs(lite[0].presence - cv[0].presence) < 0.05  # measured: at most 0.024
    for p, q in zip(hands["litert person"], hands["opencv person"], strict=True):
        assert np.abs(p - q).max() < 1e-3


@pytest.mark.parametrize("runner", models.RUNNERS)
def test_a_missing_or_corrupt_model_file_is_one_line_naming_it(tmp_path, runner):
    name = "hand_landmark_lite.tflite"
    with pytest.raises(models.ModelError) as exc:
        models.load_net(name, tmp_path, runner)
    assert str(tmp_path / name) in str(exc.value) and "\n" not in str(exc.value)
    shutil.copy(cm.__file__, tmp_path / name)  # any other bytes
    with pytest.raises(models.ModelError, match="corrupt") as exc:
        models.load_net(name, tmp_path, runner)
    assert "\n" not in str(exc.value)
    unknown = tmp_path / "other.tflite"
    unknown.write_bytes(b"TFL3 not a model")
    with pytest.raises(models.ModelError, match="does not load"):
        models.load_net("other.tflite", tmp_path, runner)
    shipped = Path(cm.__file__).parent / "data" / "models"
    assert set(models.SHA256) == {p.name for p in shipped.glob("*.tflite")}
