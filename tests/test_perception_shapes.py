"""Synthetic shapes with known answers: ellipses, skeleton feature vectors, the gesture ANN, hand regions."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from perception.ann import GestureANN, load_training
from perception.ellipses import fit_ellipse, hand_regions
from perception.skeleton import feature_vector

N = 160


def drawn_ellipse(l_major, l_minor, orientation, x_c, y_c, size=200):
    im = np.zeros((size, size), np.uint8)
    cv2.ellipse(im, (x_c, y_c), (l_major // 2, l_minor // 2), -orientation, 0, 360, 1, -1)
    return im.astype(bool)


@pytest.mark.parametrize(
    "params",
    [
        (60, 20, 30, 80, 70),
        (40, 12, 100, 50, 60),
        (90, 50, 0, 100, 100),
        (30, 8, 165, 40, 40),
        (120, 30, 90, 100, 100),
        (70, 40, 135, 120, 90),
    ],
)
def test_drawn_ellipse_is_recovered_within_2px_and_2deg(params):
    l_major, l_minor, orientation, x_c, y_c = params
    e = fit_ellipse(drawn_ellipse(*params))
    assert abs(e.l_major - l_major) <= 2 and abs(e.l_minor - l_minor) <= 2
    assert abs(e.x_c - x_c) <= 2 and abs(e.y_c - y_c) <= 2
    d = abs(e.orientation_deg - orientation) % 180
    assert min(d, 180 - d) <= 2


def line(angle, t=12):
    im = np.zeros((N, N), np.uint8)
    d = np.array([np.cos(np.radians(angle)), -np.sin(np.radians(angle))]) * N * 0.38
    cv2.line(im, tuple((N // 2 - d).astype(int)), tuple((N // 2 + d).astype(int)), 1, t)
    return im.astype(bool)


def vee(opening, t=10):
    im = np.zeros((N, N), np.uint8)
    apex = (N // 2, int(N * 0.85))
    for s in (-1, 1):
        a = np.radians(90 + s * opening / 2)
        cv2.line(im, apex, (int(apex[0] + 0.7 * N * np.cos(a)), int(apex[1] - 0.7 * N * np.sin(a))), 1, t)
    return im.astype(bool)


def you(gap, t=10):
    im = np.zeros((N, N), np.uint8)
    x0, x1, top, bot = N // 2 - gap // 2, N // 2 + gap // 2, int(N * 0.12), int(N * 0.7)
    cv2.line(im, (x0, top), (x0, bot), 1, t)
    cv2.line(im, (x1, top), (x1, bot), 1, t)
    cv2.ellipse(im, (N // 2, bot), (gap // 2, gap // 2), 0, 0, 180, 1, t)
    return im.astype(bool)


@pytest.mark.parametrize("angle", [0, 30, 90, 135])
def test_line_matches_the_line_edge_template(angle):
    assert feature_vector(line(angle)).tolist() == [1, 0, 0, 0, 0, 0]


@pytest.mark.parametrize("opening", [30, 50, 80])
def test_v_matches_the_v_template_and_aperture_grows(opening):
    fv = feature_vector(vee(opening))
    assert fv[:5].tolist() == [0, 0, 1, 0, 0] and fv[5] > 0.3


def test_v_aperture_grows_with_opening():
    assert feature_vector(vee(30))[5] < feature_vector(vee(50))[5] < feature_vector(vee(80))[5]


@pytest.mark.parametrize("gap", [24, 40, 60])
def test_u_matches_the_u_template_with_its_gap(gap):
    fv = feature_vector(you(gap))
    assert fv[:5].tolist() == [0, 1, 0, 0, 0]
    # aperture = distance between the branch ends / longer side of the silhouette
    assert abs(fv[5] * (N * 0.7 - N * 0.12 + gap / 2 + 10) - gap) < 0.35 * gap


def test_gesture_ann_is_6_5_k_and_reproduces_its_training_set():
    net = GestureANN.load()
    assert net.w1.shape == (6, 5) and net.w2.shape[0] == 5
    x, y, pairs = load_training()
    assert all(p["source"] for p in pairs)
    assert np.abs(net(x) - y).max() < 0.1
    # a line asks for thrust along the finger and no split; a wide V for a split
    f_line, f_v = net(np.array([[1, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0.8]], float))
    assert f_line[0] > 1.8 and abs(f_line[1]) < 0.1 and f_v[1] > 0.9


def test_hand_regions_finds_fingers_tips_and_joints_of_a_drawn_hand():
    im = np.zeros((120, 120), np.uint8)
    cv2.circle(im, (60, 80), 22, 1, -1)  # palm
    cv2.rectangle(im, (52, 95), (68, 119), 1, -1)  # wrist leaving the picture at the bottom
    cv2.line(im, (50, 65), (35, 10), 1, 9)  # two fingers
    cv2.line(im, (70, 65), (85, 10), 1, 9)
    r = hand_regions(im.astype(bool))
    assert r["wrist_side"] == "bottom"
    assert len(r["fingers"]) == 2
    tips = sorted(r["critical_points"]["finger_tips"])
    assert np.hypot(tips[0][0] - 35, tips[0][1] - 10) < 6 and np.hypot(tips[1][0] - 85, tips[1][1] - 10) < 6
    joints = sorted(r["critical_points"]["first_joints"])
    assert all(40 < y < 75 for _x, y in joints) and joints[0][0] < 60 < joints[1][0]
    left, right = r["fingers"]  # sorted by tip column
    assert 95 < left.orientation_deg < 120 and 60 < right.orientation_deg < 85
    palm = r["palm"]
    assert abs(palm.x_c - 60) < 4 and abs(palm.y_c - 82) < 5
