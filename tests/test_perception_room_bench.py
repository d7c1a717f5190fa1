"""`fluidswarm bench-perception` (perception/bench_room.py): its table and figures from a small run on the
shared data; without the shared data, one line saying which folder is missing."""

from __future__ import annotations

import re
from argparse import Namespace

import numpy as np
import pytest

import perception.dataset
from agent.protocol.errors import UserError
from perception.bench_room import hand_end, run
from perception.commands import _bench


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


def test_missing_shared_data_or_a_bad_family_is_one_line(monkeypatch, tmp_path):
    monkeypatch.setattr(perception.dataset, "SHARED_HANDS", tmp_path / "sign-language-digits")
    with pytest.raises(UserError, match="is missing") as exc:
        run(hands=1)
    assert "\n" not in str(exc.value) and str(tmp_path) in str(exc.value)
    with pytest.raises(UserError, match="unknown carpet"):
        _bench(Namespace(hands=1, seed=0, families="skin,carpet", held_out=False))
