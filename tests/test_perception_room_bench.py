"""`fluidswarm bench-perception` (perception/bench_room.py): its table and figures from a small run on the
shared data; without the shared data, one line saying which folder is missing."""

from __future__ import annotations

import re
from argparse import Namespace

import numpy as np
import pytest

import perception.dataset
from agent.protocol.errors import UserError
from perception import composites as cm
from perception.bench_room import hand_end, run
from perception.commands import _bench
from perception.dataset import is_test_file
from perception.features import to_work_size
from perception.io import load_image
from perception.segmentation import hand_mask


def test_a_small_run_prints_the_table_and_the_figures(shared_hands, weizmann, capsys):
    assert run(hands=2, seed=3, families=("skin",)) == 0
    out = capsys.readouterr().out
    assert "| skin, now | 2 |" in out and "| skin, before | 2 |" in out and "| **all, now** | 2 |" in out
    figures = dict(re.findall(r"(\w+)=([0-9.]+)", out.splitlines()[-2] + " " + out.splitlines()[-1]))
    for key in ("hand_detection", "mask_iou", "accuracy10", "false_positives", "ms_per_frame", "person_iou"):
        assert 0.0 <= float(figures[key]) <= (1e4 if key == "ms_per_frame" else 1.0), (key, figures)
    assert 0.0 < float(figures["cpu_ms_per_frame"]) < 1e4 and float(figures["load"]) >= 0.0, figures
    assert float(figures["person_detection"]) == 1.0  # one skin wall, one pasted person: found
    assert "detection_by_hand_end: wrist (< 0.7) " in out


def test_how_a_pasted_hand_ends_at_the_bottom_edge():
    """A wrist (bottom rows narrower than the palm) against a palm the photograph cut (as wide there as anywhere)."""
    hand = np.zeros((480, 640), bool)
    hand[300:440, 200:300] = True  # the palm and fingers
    hand[440:480, 230:270] = True  # a wrist of 0.4 of the palm's width
    assert hand_end(hand) == "wrist (< 0.7)"
    cut = np.zeros((480, 640), bool)
    cut[300:480, 200:300] = True  # the palm reaches the edge
    assert hand_end(cut) == "palm cut (>= 0.85)"
    cut[477:480, 200:222] = False  # bottom rows 0.78 of the widest
    assert hand_end(cut) == "0.7-0.85"


def _pasted(shared_hands, cls: int, k: int):
    """A test-split photograph pasted on a plain wall: (photo's mask, wall, frame, true mask, the hand's share)."""
    files = sorted(p for p in (shared_hands / str(cls)).iterdir() if is_test_file(p.name))
    photo = to_work_size(load_image(files[k]))
    mask = hand_mask(photo)
    wall = cm.background_maker("plain")(np.random.default_rng(0))
    frame, truth = cm.paste_hand(wall, photo, mask, np.random.default_rng(7))
    return mask, wall, frame, truth, np.random.default_rng(7).uniform(0.2, 0.5)


def test_a_photograph_cut_through_the_palm_is_raised_on_a_forearm(shared_hands):
    """A held-out 1 whose photograph cuts through the palm (its bottom rows 0.93 of its widest): the composite
    draws a forearm below the cut to the bottom edge, narrower than the cut, in the hand's colours; the true
    mask is the hand above the drawn wrist line, as tall as a hand of that share plus the rest of its palm."""
    mask, wall, frame, truth, share = _pasted(shared_hands, 1, 1)
    assert hand_end(mask) == "palm cut (>= 0.85)"
    pasted = np.abs(frame.astype(int) - wall.astype(int)).max(2) > 25
    ys = np.nonzero(truth.any(1))[0]
    h = share * 480  # the hand's height in the frame, as before
    assert abs(480 - ys.min() - (1 + cm.FOREARM_LENGTH) * h) <= 3  # raised by the forearm's length
    assert ys.max() < 479 - 0.25 * h  # the wrist line well above the bottom edge
    cut = np.count_nonzero(truth[ys.min() + int(h) - 3])  # the photograph's cut, in the frame
    assert 0 < ys.max() - ys.min() + 1 - h <= cm.WRIST_ROWS * cut + 3  # the hand and the rest of its palm
    bottom = np.count_nonzero(pasted[-2])
    assert 0.7 * cut <= bottom <= 0.95 * cut, (bottom, cut)  # the forearm reaches the edge, narrower than the cut
    assert pasted[ys.max() :].any(1).all()  # a forearm all the way down: no gap
    forearm = frame[-20:][pasted[-20:]].astype(float).mean(0)
    hand = frame[truth].astype(float).mean(0)
    assert np.abs(forearm - hand).max() < 40, (forearm, hand)  # skin, not the wall


def test_a_photograph_with_a_wrist_is_pasted_as_before(shared_hands):
    """A held-out 5 whose photograph shows its wrist (bottom rows 0.48 of its widest): its wrist on the bottom
    edge, nothing drawn below it, the true mask all of what was pasted."""
    mask, wall, frame, truth, share = _pasted(shared_hands, 5, 2)
    assert hand_end(mask) == "wrist (< 0.7)"
    ys = np.nonzero(truth.any(1))[0]
    assert ys.max() == 479 and abs(ys.max() - ys.min() + 1 - share * 480) <= 2
    pasted = np.abs(frame.astype(int) - wall.astype(int)).max(2) > 25
    assert not (pasted & ~truth).any(1)[: ys.min() - 3].any()  # nothing pasted above the hand


def test_missing_shared_data_or_a_bad_family_is_one_line(monkeypatch, tmp_path):
    monkeypatch.setattr(perception.dataset, "SHARED_HANDS", tmp_path / "sign-language-digits")
    with pytest.raises(UserError, match="is missing") as exc:
        run(hands=1)
    assert "\n" not in str(exc.value) and str(tmp_path) in str(exc.value)
    with pytest.raises(UserError, match="unknown carpet"):
        _bench(Namespace(hands=1, seed=0, families="skin,carpet", held_out=False))
