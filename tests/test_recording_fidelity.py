"""Imitation fidelity on synthetic formations (issue 6) and the Zhang-Suen skeleton it relies on."""

import dataclasses
import time

import cv2
import numpy as np
import pytest

from coordinator.control.fidelity import Fidelity, fidelity, format_fidelity, nn_cv
from coordinator.control.geometry import ImageToDomain
from fluidswarm.recording.synthetic import silhouette, spread_over
from perception.skeleton import thin

MASK = silhouette((100, 100))
TF = ImageToDomain.fit(MASK.shape, (0.0, 2.0, 0.0, 2.0))


def test_uniform_spread_over_target_scores_high():
    f = fidelity(MASK, TF, spread_over(MASK, TF, 300))
    assert f.iou >= 0.8
    assert f.inside == 1.0
    assert f.coverage >= 0.95


def test_all_particles_at_one_point_scores_low():
    centre = TF.to_domain(np.array([[50.0, 30.0]]))
    f = fidelity(MASK, TF, np.repeat(centre, 300, axis=0))
    assert f.iou < 0.1
    assert f.coverage < 0.5


def test_shifted_formation_scores_lower_than_aligned():
    aligned = spread_over(MASK, TF, 300)
    a = fidelity(MASK, TF, aligned)
    s = fidelity(MASK, TF, aligned + np.array([0.4, 0.0]))
    assert s.iou < a.iou - 0.3
    assert s.inside < a.inside
    assert s.coverage < a.coverage


def test_particles_far_outside_the_picture_count_in_the_union():
    pts = spread_over(MASK, TF, 100)
    far = fidelity(MASK, TF, np.vstack([pts, pts + 500.0]))  # half the swarm 500 m away
    near = fidelity(MASK, TF, pts)
    assert far.iou < 0.6 * near.iou
    assert far.inside == pytest.approx(0.5)


def test_score_does_not_depend_on_the_domain_scale():
    pts_px = np.argwhere(MASK)[::37][:, ::-1] + 0.5  # (u, v) pixel centres inside T
    small = ImageToDomain(scale=0.01, x0=0.0, y0=1.0)
    large = ImageToDomain(scale=3.0, x0=-50.0, y0=400.0)
    a = fidelity(MASK, small, small.to_domain(pts_px))
    b = fidelity(MASK, large, large.to_domain(pts_px))
    assert dataclasses.astuple(a) == pytest.approx(dataclasses.astuple(b))


def test_tiny_mask_is_refined():
    tiny = np.zeros((6, 6), bool)
    tiny[1:5, 1:5] = True
    tf = ImageToDomain.fit(tiny.shape, (0.0, 1.0, 0.0, 1.0))
    corners = tf.to_domain(np.array([[2.0, 2.0], [4.0, 4.0], [2.0, 4.0], [4.0, 2.0]]))
    f = fidelity(tiny, tf, corners)
    assert f.iou > 0.6 and f.inside == 1.0 and f.coverage == 1.0


def test_empty_formation_and_bad_masks():
    assert fidelity(MASK, TF, np.empty((0, 2))) == Fidelity(0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="no foreground"):
        fidelity(np.zeros((10, 10), bool), TF, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="2-D"):
        fidelity(np.ones(10, bool), TF, np.zeros((3, 2)))


def test_fast_enough_for_100x100_and_300_particles():
    pts = spread_over(MASK, TF, 300) + np.random.default_rng(1).normal(0, 0.02, (300, 2))
    fidelity(MASK, TF, pts)
    best = min(_timed(lambda: fidelity(MASK, TF, pts)) for _ in range(5))
    assert best < 0.05, f"fidelity took {best * 1e3:.1f} ms"


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def test_format_gives_four_parsable_lines():
    lines = format_fidelity(Fidelity(iou=0.5, inside=0.25, coverage=1.0, nn_cv=0.125)).splitlines()
    assert [ln.split("=")[0] for ln in lines] == ["fidelity_iou", "fidelity_inside", "fidelity_coverage", "nn_cv"]
    assert [float(ln.split("=")[1]) for ln in lines] == [0.5, 0.25, 1.0, 0.125]


def test_nn_cv_is_zero_on_a_lattice_and_high_for_clumps():
    lattice = np.array([[i, j] for i in range(6) for j in range(6)], float)
    assert nn_cv(lattice) == pytest.approx(0.0, abs=1e-12)
    clumps = np.concatenate([lattice * 5, lattice * 5 + 0.1])  # pairs: nn 0.1 inside, 5 between
    assert nn_cv(clumps) == pytest.approx(0.0, abs=1e-12)  # all pairs alike: uniform nn distance
    mixed = np.concatenate([lattice * 5, lattice[:18] * 5 + 0.1])  # half paired, half alone
    assert nn_cv(mixed) > 0.5


def test_skeleton_of_a_bar_is_its_centre_line():
    bar = np.zeros((21, 61), bool)
    bar[5:16, 5:56] = True
    sk = thin(bar)
    rows = np.unique(np.nonzero(sk)[0])
    assert len(rows) <= 2 and 9 <= rows.min() <= rows.max() <= 11
    assert np.count_nonzero(sk) >= 35
    assert not (sk & ~bar).any()


def test_skeleton_is_thin_and_keeps_a_ring_connected():
    ring = np.zeros((80, 80), np.uint8)
    cv2.circle(ring, (40, 40), 30, 1, thickness=8)
    sk = thin(ring.astype(bool)).astype(np.uint8)
    n_labels, _ = cv2.connectedComponents(sk, connectivity=8)
    assert n_labels == 2  # background + one ring
    # thin: no 2x2 block fully set
    blocks = sk[:-1, :-1] & sk[1:, :-1] & sk[:-1, 1:] & sk[1:, 1:]
    assert not blocks.any()
