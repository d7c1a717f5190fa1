"""scripts/cross_host_model.py: the model of state messages crossing router links (docs/multi-host.md "What a
cut can save"), on layouts whose answer is known by hand."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("cross_host_model", REPO / "scripts" / "cross_host_model.py")
model = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(model)


def test_subscribed_cells_are_the_cells_meeting_the_disc():
    # a disc of radius 1 around a cell's centre meets that cell and its 8 neighbours (as keys.rs covering_cells)
    assert model.subscribed_cells(np.array([[0.5, 0.5]]), 1.0, 1.0) == {(x, y) for x in (-1, 0, 1) for y in (-1, 0, 1)}
    # radius 0.4 from the centre: only its own cell
    assert model.subscribed_cells(np.array([[0.5, 0.5]]), 0.4, 1.0) == {(0, 0)}


def test_far_apart_hosts_send_nothing():
    pos = np.array([[0.5, 0.5], [50.5, 0.5], [0.5, 50.5]])
    assert model.messages_per_step(pos, np.array([0, 1, 2]), 3, 2.6, 1.0) == 0


def test_a_pair_across_hub_and_worker_crosses_once_each_way():
    pos = np.array([[0.5, 0.5], [1.5, 0.5]])
    assert model.messages_per_step(pos, np.array([0, 1]), 2, 2.6, 1.0) == 2


def test_a_pair_between_two_workers_crosses_two_links_each_way():
    # workers 1 and 2 next to each other, the hub far away: each state goes worker -> hub -> other worker
    pos = np.array([[50.5, 0.5], [0.5, 0.5], [1.5, 0.5]])
    assert model.messages_per_step(pos, np.array([0, 1, 2]), 3, 2.6, 1.0) == 4


def test_a_state_wanted_by_the_hub_and_a_worker_leaves_its_worker_once():
    # agent 1 (worker 1) is near the hub's agent and worker 2's: one message to the hub, one on to worker 2;
    # the hub's agent is heard by both workers (2), worker 2's agent by the hub and worker 1 (2)
    pos = np.array([[0.5, 0.5], [1.5, 0.5], [2.5, 0.5]])
    assert model.messages_per_step(pos, np.array([0, 1, 2]), 3, 2.6, 1.0) == 2 + 2 + 2


def test_straight_cuts_are_balanced_partitions():
    pos = np.random.default_rng(1).uniform(0, 10, (31, 2))
    cuts = model.straight_cuts(pos, 3)
    assert len(cuts) == 18 + 12 * 2 * 12
    for parts in cuts:
        assert sorted(np.concatenate(parts).tolist()) == list(range(31))
        assert max(map(len, parts)) - min(map(len, parts)) <= 1
