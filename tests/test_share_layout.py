"""Where an imitation's swarm is going, for cutting it between hosts (fluidswarm/orchestration/share_layout.py): the
numpy oracle run ahead from the coordinator's own set-up, following the command as the agents do."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from agent.sph.obstacles import Circle
from agent.sph.reference import VectorisedDriver
from agent.sph.regions import regions
from coordinator.control.imitation_setup import prepare
from coordinator.control.route import followers_for
from fluidswarm.orchestration.share_layout import formation_ahead
from perception.io import load_image

PHOTO = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"


def test_the_formation_ahead_is_the_oracles_in_the_setups_order():
    im = prepare(load_image(str(PHOTO)), 40)
    setup = im.setup
    shuffled = np.random.default_rng(3).permutation(len(setup.ids))  # a set-up not in id order
    setup.ids, setup.states = np.asarray(setup.ids)[shuffled], setup.states[shuffled]
    setup.controls = [setup.controls[k] for k in shuffled]
    ahead = formation_ahead(setup, im.command, steps=120)
    d = VectorisedDriver(setup.ids, setup.states, followers_for(im.command, setup.ids), setup.params)
    by_id = d.run(120)[:, :2]  # sorted by id
    for k, agent in enumerate(setup.ids):
        assert np.array_equal(ahead[k], by_id[int(np.searchsorted(d.ids, agent))])
    # the swarm moved: its formation's regions are not the start layout's
    start = [set(np.asarray(setup.ids)[p]) for p in regions(setup.states[:, :2], 3)]
    later = [set(np.asarray(setup.ids)[p]) for p in regions(ahead, 3)]
    assert start != later


def test_a_set_up_the_oracle_does_not_model_or_a_spent_budget():
    im = prepare(load_image(str(PHOTO)), 20)
    far = Circle(100.0, 100.0, 1.0)  # away from every agent: the set-up is valid, the oracle has no obstacles
    assert formation_ahead(im.setup.with_obstacles((far,)), im.command) is None
    once = formation_ahead(im.setup, im.command, steps=500, budget=0.0)  # stops after its first step
    d = VectorisedDriver(im.setup.ids, im.setup.states, followers_for(im.command, im.setup.ids), im.setup.params)
    d.step()
    assert np.allclose(np.sort(once[:, 0]), np.sort(d.states[:, 0]))
