"""The imperfect radio and localisation (issue 33 item 2, agent/sph/radio.py): the draws, the settings' checks
in the model, the spec, a scenario and the command line, what the reference driver makes of them, and a swarm
of agent processes reproducing it (the draws are functions of seed, ids and step, not of arrival order)."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest

from agent.protocol.errors import UserError
from agent.protocol.spec import AgentSpec
from agent.sph.particle import X, Y
from agent.sph.radio import LOSS, MAX_LATENCY, PERFECT, RadioModel, radio_from, uniform
from agent.sph.reference import PerParticleDriver, VectorisedDriver
from agent.sph.robot import RobotModel
from agent.sph.setups import spread_block
from fluidswarm.scenario import load_scenario

UNICYCLE = RobotModel(kind="unicycle")
LOSSY = RadioModel(loss=0.1, latency=2, noise=0.05)


def test_the_draws_are_uniform_and_functions_of_their_counters():
    u = np.array([uniform(3, LOSS, 1, 2, s) for s in range(20_000)])
    assert 0.0 <= u.min() and u.max() < 1.0 and abs(u.mean() - 0.5) < 0.01
    assert uniform(3, LOSS, 1, 2, 7) == uniform(3, LOSS, 1, 2, 7) != uniform(3, LOSS, 2, 1, 7)
    r = RadioModel(loss=0.1, noise=0.05, seed=9)
    lost = np.mean([r.lost(4, 5, s) for s in range(20_000)])
    assert 0.09 < lost < 0.11
    errors = np.array([r.position_error(5, s) for s in range(20_000)])
    assert np.allclose(errors.std(axis=0), 0.05, rtol=0.03) and np.allclose(errors.mean(axis=0), 0.0, atol=2e-3)
    assert r.position_error(5, 3) == r.position_error(5, 3) != RadioModel(noise=0.05, seed=10).position_error(5, 3)
    assert PERFECT.is_perfect and not PERFECT.lost(0, 1, 0) and PERFECT.position_error(1, 0) == (0.0, 0.0)


@pytest.mark.parametrize(
    "fields, key",
    [
        ({"loss": 1.0}, "radio.loss"),
        ({"loss": -0.01}, "radio.loss"),
        ({"loss": math.nan}, "radio.loss"),
        ({"latency": MAX_LATENCY + 1}, "radio.latency"),
        ({"latency": -1}, "radio.latency"),
        ({"latency": 1.0}, "radio.latency"),
        ({"noise": -0.1}, "radio.noise"),
        ({"noise": math.inf}, "radio.noise"),
        ({"jitter": 1}, "radio.jitter"),
    ],
)
def test_bad_radio_settings_name_the_key(fields, key):
    with pytest.raises(ValueError, match=f"^{key}: "):
        radio_from(fields)


def test_the_reference_applies_the_radio_and_the_perfect_radio_changes_nothing():
    setup = spread_block(16).with_robot(UNICYCLE)
    args = (setup.ids, setup.states, setup.controls, setup.params, setup.robot)
    perfect = PerParticleDriver(*args).run(40)
    assert np.array_equal(PerParticleDriver(*args, PERFECT.with_seed(0)).run(40), perfect)
    for radio in (RadioModel(loss=0.1), RadioModel(latency=2), RadioModel(noise=0.05), LOSSY):
        moved = np.abs(PerParticleDriver(*args, radio).run(40)[:, [X, Y]] - perfect[:, [X, Y]]).max()
        assert moved > 1e-3, radio
    other_seed = PerParticleDriver(*args, LOSSY.with_seed(1)).run(40)
    assert not np.array_equal(other_seed, PerParticleDriver(*args, LOSSY).run(40))
    with pytest.raises(NotImplementedError):
        VectorisedDriver(*args, LOSSY).step()


def test_the_spec_carries_the_radio_and_refuses_it_in_async_mode():
    base = {"run": "r1", "id": 0, "connect": ["tcp/127.0.0.1:7447"], "steps": 1, "initial": [0, 0, 0, 0]}
    spec = AgentSpec.from_json(json.dumps({**base, "radio": LOSSY.as_dict()}))
    assert spec.radio_model() == LOSSY
    for bad, key in (({"loss": 2}, "radio.loss"), ({"latency": 7}, "radio.latency"), ({"x": 1}, "radio")):
        with pytest.raises(ValueError, match=key):
            AgentSpec.from_json(json.dumps({**base, "radio": bad}))
    with pytest.raises(ValueError, match="lockstep only"):
        AgentSpec.from_json(json.dumps({**base, "mode": "async", "radio": LOSSY.as_dict()}))


def test_a_scenarios_radio_table_is_checked_and_seeded_from_the_scenario(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('experiment = "drag"\nseed = 7\n[radio]\nloss = 0.1\nlatency = 2\nnoise = 0.05\n')
    assert load_scenario(path).radio == RadioModel(0.1, 2, 0.05, seed=7)
    for table, message in (
        ("loss = 1", "key 'radio.loss': must be a probability in [0, 1)"),
        ("latency = 2.5", "key 'radio.latency': must be an integer"),
        ("noise = -1.0", "key 'radio.noise': must be a finite number"),
        ("fade = 1", "key 'radio.fade': unknown key"),
    ):
        path.write_text(f'experiment = "drag"\n[radio]\n{table}\n')
        with pytest.raises(UserError, match=re.escape(message)):
            load_scenario(path)
    path.write_text('experiment = "drag"\nsync = "async"\n[radio]\nloss = 0.1\n')
    with pytest.raises(UserError, match="key 'radio': the imperfect radio is modelled in lockstep only"):
        load_scenario(path)
    assert load_scenario("hand_lossy_radio").radio == RadioModel(0.1, 2, 0.05, seed=1)


def test_bad_radio_options_are_one_line_before_anything_starts(capsys):
    # in this process: tests/conftest.py fails a unit test that starts an agent, a router or a session
    from fluidswarm.cli import main

    for args, message in (
        (["verify", "--radio-loss", "1.5"], "--radio-loss: must be a probability in [0, 1), got 1.5"),
        (["launch", "--radio-latency", "5"], "--radio-latency: must be an integer number of steps in [0, 4]"),
        (["launch", "--mode", "async", "--radio-noise", "0.1"], "lockstep only"),
        (["run", "hand_lossy_radio", "--sync", "async"], "lockstep only"),
    ):
        assert main(args) == 1, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], err


@pytest.mark.swarm
def test_verify_with_an_imperfect_radio_stays_exact():
    # 16 unicycles for 60 steps: every kind of draw (losses, latency, noise) is taken thousands of times
    cmd = [
        "verify",
        "--agents",
        "16",
        "--steps",
        "60",
        "--robot",
        "unicycle",
        "--radio-loss",
        "0.1",
        "--radio-latency",
        "2",
        "--radio-noise",
        "0.05",
        "--json",
    ]
    r = subprocess.run([sys.executable, "-m", "fluidswarm", *cmd], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    record = json.loads(r.stdout)
    assert record["passed"] and record["finished"] == 16
    assert record["figures"]["max_position_error"] <= 1e-9
    assert record["radio"] == {"loss": 0.1, "latency": 2, "noise": 0.05, "seed": 0}
