"""Region shares of a start layout (agent/sph/regions.py): sizes within one agent, compact (disjoint bounding
boxes, few neighbours across a cut), deterministic, and what `--share K/M` starts (fluidswarm/swarm_commands.py)."""

from __future__ import annotations

import numpy as np
import pytest

from agent.protocol.errors import UserError
from agent.sph.regions import central_first, region_sizes, regions, share
from agent.sph.setups import spread_block
from fluidswarm.swarm_commands import parse_share, share_ids


def _boxes_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Do the interiors of the bounding boxes of point sets a and b overlap?"""
    lo = np.maximum(a.min(axis=0), b.min(axis=0))
    hi = np.minimum(a.max(axis=0), b.max(axis=0))
    return bool((hi - lo > 0).all())


def _layouts():
    rng = np.random.default_rng(7)
    yield "block 40", spread_block(40).states[:, :2]
    yield "block 180", spread_block(180).states[:, :2]
    yield "strip", np.stack([np.arange(50.0), np.zeros(50)], axis=1)  # one row: the cuts are all along x
    yield "random 300", rng.uniform(-10, 10, size=(300, 2))
    yield "disc 101", rng.normal(size=(101, 2)) * [3.0, 1.0]
    yield "duplicates", np.repeat(rng.uniform(size=(5, 2)), 4, axis=0)


@pytest.mark.parametrize("m", [1, 2, 3, 4, 5, 7, 8])
def test_regions_partition_the_layout_with_shares_within_one_and_disjoint_boxes(m):
    for name, pos in _layouts():
        parts = regions(pos, m)
        sizes = [len(p) for p in parts]
        assert sizes == region_sizes(len(pos), m), name
        assert max(sizes) - min(sizes) <= 1 and sum(sizes) == len(pos), name
        assert np.array_equal(np.sort(np.concatenate(parts)), np.arange(len(pos))), name  # each position once
        assert all(np.array_equal(p, np.sort(p)) for p in parts)
        for i in range(m):
            for j in range(i + 1, m):
                assert not _boxes_overlap(pos[parts[i]], pos[parts[j]]), f"{name}: regions {i} and {j} overlap"


def test_regions_are_deterministic_and_do_not_depend_on_the_order_of_the_positions():
    rng = np.random.default_rng(3)
    pos = rng.uniform(0, 30, size=(200, 2))  # distinct coordinates: no tie for the index to break
    first = regions(pos, 5)
    assert all(np.array_equal(a, b) for a, b in zip(first, regions(pos.copy(), 5)))
    perm = rng.permutation(len(pos))
    again = regions(pos[perm], 5)
    assert [sorted(perm[p].tolist()) for p in again] == [p.tolist() for p in first]


def _neighbours_across(pos: np.ndarray, parts: list[np.ndarray], reach: float) -> int:
    owner = np.empty(len(pos), dtype=int)
    for k, p in enumerate(parts):
        owner[p] = k
    d = np.hypot(*(pos[:, None, :] - pos[None, :, :]).transpose(2, 0, 1))
    near = (d <= reach) & ~np.eye(len(pos), dtype=bool)
    return int((near & (owner[:, None] != owner[None, :])).sum())


def test_region_shares_keep_neighbours_together_where_id_ranges_scatter_them():
    # a block whose ids are shuffled, as an imitation's placement leaves them: an id range is scattered over
    # the whole block, a region's agents are each other's neighbours
    rng = np.random.default_rng(11)
    pos = spread_block(180).states[:, :2][rng.permutation(180)]
    m, reach = 3, 2.0
    by_region = _neighbours_across(pos, regions(pos, m), reach)
    by_ids = _neighbours_across(pos, np.array_split(np.arange(180), m), reach)
    print(f"neighbour pairs across hosts: regions {by_region}, id ranges {by_ids}")
    assert by_region <= 0.25 * by_ids


def test_bad_input_is_one_line():
    pos = np.zeros((4, 2))
    for call, message in [
        (lambda: regions(pos, 0), "must be 1..4"),
        (lambda: regions(pos, 5), "must be 1..4"),
        (lambda: regions(np.zeros((4, 3)), 2), "expected an \\(n, 2\\) array"),
        (lambda: regions(np.array([[0.0, np.nan]]), 1), "finite"),
        (lambda: share(pos, 3, 2), "K must be 1..2"),
    ]:
        with pytest.raises(ValueError, match=message):
            call()
    for text, message in [("2", "expected K/M"), ("a/b", "expected K/M"), ("0/2", "K must be"), ("3/2", "K must be")]:
        with pytest.raises(UserError, match=message):
            parse_share(text)


def test_share_ids_are_the_regions_of_the_block_and_together_the_whole_swarm():
    setup = spread_block(40)
    got = [share_ids(f"{k}/3", setup) for k in (1, 2, 3)]
    assert sorted(i for g in got for i in g) == list(range(40))
    assert [len(g) for g in got] == [14, 13, 13]
    assert got[0] == list(range(14))  # the block's lowest rows (its longer side is y: 7 rows of 6)
    with pytest.raises(UserError, match="at most one region per agent"):
        share_ids("1/41", setup)


def test_the_part_bordering_the_most_others_goes_first():
    # three bands of a 9 x 3 lattice along x: the middle band borders both others
    xs, ys = np.meshgrid(np.arange(9.0), np.arange(3.0))
    pos = np.stack([xs.ravel(), ys.ravel()], axis=1)
    parts = [
        np.flatnonzero(pos[:, 0] < 3),
        np.flatnonzero((pos[:, 0] >= 3) & (pos[:, 0] < 6)),
        np.flatnonzero(pos[:, 0] >= 6),
    ]
    out = central_first(pos, parts, 1.5)
    assert [p.tolist() for p in out] == [parts[1].tolist(), parts[0].tolist(), parts[2].tolist()]
    # two parts border each other equally: the order stays; no pair that close: the order stays
    assert [p.tolist() for p in central_first(pos, parts[:2], 1.5)] == [parts[0].tolist(), parts[1].tolist()]
    assert [p.tolist() for p in central_first(pos, parts, 0.5)] == [p.tolist() for p in parts]
