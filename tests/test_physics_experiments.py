"""Thesis §4.6 stiffness-only experiments, reproduced and measured."""

import subprocess
import sys

import numpy as np
import pytest

from agent.protocol.errors import UserError
from agent.sph.particle import SXX, P, Y
from agent.sph.reference import VectorisedDriver
from agent.sph.setups import branch_gap, branching, drag
from fluidswarm.scenario import load_scenario

STEPS = 800


def final_of(setup):
    return VectorisedDriver(setup.ids, setup.states, setup.controls, setup.params).run(STEPS)


def test_stiffer_middle_splits_the_flow_into_two_branches():
    split = branching(200, beta_middle=20.0, beta_edge=2.0)
    uniform = branching(200, beta_middle=2.0, beta_edge=2.0)
    reverse = branching(200, beta_middle=2.0, beta_edge=20.0)
    gap_split = branch_gap(split.classes, final_of(split))
    gap_uniform = branch_gap(uniform.classes, final_of(uniform))
    gap_reverse = branch_gap(reverse.classes, final_of(reverse))
    initial = branch_gap(split.classes, split.states)
    print(f"gap initial={initial:.2f} split={gap_split:.2f} uniform={gap_uniform:.2f} reverse={gap_reverse:.2f}")
    # The branches move apart far more with a stiff middle than in a uniform fluid, and more than with
    # the thesis' printed assignment (stiff edges): the stiff middle is what produces the split.
    assert gap_split - initial > 1.5 * (gap_uniform - initial)
    assert gap_split > gap_reverse
    assert gap_split > initial + 5.0


def test_beta_50_spreads_the_flow_in_y_more_than_beta_2():
    stiff = branching(200, beta_middle=50.0, beta_edge=50.0)
    soft = branching(200, beta_middle=2.0, beta_edge=2.0)
    spread = [np.std(final_of(s)[:, Y]) for s in (stiff, soft)]
    print(f"y std beta50={spread[0]:.2f} beta2={spread[1]:.2f}")
    assert spread[0] > 1.3 * spread[1]


def _with_scenario_sph(make, text: str, tmp_path):
    """The experiment's set-up with a scenario's [sph] table applied, as `fluidswarm run` builds it."""
    path = tmp_path / "s.toml"
    path.write_text(text)
    sc = load_scenario(path)
    return make(sc.agents, params=make(sc.agents).params.with_overrides(sc.sph, sc.dt))


def test_scenario_sph_beta_50_changes_the_pressure(tmp_path):
    head = 'experiment = "branching"\nagents = 40\nsteps = 1\n'
    plain = _with_scenario_sph(branching, head, tmp_path)
    stiff = _with_scenario_sph(branching, head + "[sph]\nbeta = 50\n", tmp_path)
    edge = plain.classes != 1  # the middle band keeps its own beta (20)
    p_plain = VectorisedDriver(plain.ids, plain.states, plain.controls, plain.params).run(1)[:, P]
    p_stiff = VectorisedDriver(stiff.ids, stiff.states, stiff.controls, stiff.params).run(1)[:, P]
    assert np.abs(p_plain[edge]).max() > 0
    assert np.allclose(p_stiff[edge], 25.0 * p_plain[edge])  # Tait: p = beta ((rho/rho0)^7 - 1), 50 / 2
    assert np.allclose(p_stiff[~edge], p_plain[~edge])


def test_scenario_sph_mu_changes_the_viscous_stress(tmp_path):
    head = 'experiment = "drag"\nagents = 25\nsteps = 1\n'
    plain = _with_scenario_sph(drag, head, tmp_path)
    thick = _with_scenario_sph(drag, head + "[sph]\nmu = 6\n", tmp_path)
    s_plain = VectorisedDriver(plain.ids, plain.states, plain.controls, plain.params).run(2)[:, SXX]
    s_thick = VectorisedDriver(thick.ids, thick.states, thick.controls, thick.params).run(2)[:, SXX]
    assert np.abs(s_plain).max() > 0 and np.allclose(s_thick, 3.0 * s_plain)  # s = mu eps, mu 6 / 2


def test_scenario_sph_beta_of_an_imitation_is_refused_by_name(tmp_path):
    path = tmp_path / "i.toml"
    path.write_text('input = "x.png"\n[sph]\nbeta = 50\n')
    with pytest.raises(UserError, match=r"i.toml: key 'sph.beta': an imitation's stiffness"):
        load_scenario(path)


@pytest.mark.swarm
def test_simulate_command_writes_png(tmp_path):
    out = tmp_path / "sim.png"
    r = subprocess.run(
        [sys.executable, "-m", "fluidswarm", "simulate", "--out", str(out), "--steps", "200"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = subprocess.run(
        [sys.executable, "-m", "fluidswarm", "simulate", "--out", str(tmp_path / "x.txt")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert bad.returncode == 1 and "Traceback" not in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
