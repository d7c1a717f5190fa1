"""The SPH physics core (thesis ch. 3, eq. 3.3-3.13, 6.2) against numbers it must reproduce."""

import math

import numpy as np
import pytest

from agent.sph import Control, SPHParams, body_force, gaussian_kernel, initial_state, kernel_gradient, tait_pressure
from agent.sph.particle import VX, VY, X, Y
from agent.sph.reference import PerParticleDriver, VectorisedDriver
from agent.sph.setups import lattice, spread_block


def test_kernel_zeroth_moment_is_one_minus_exp_minus_four():
    h = 0.7
    r = np.linspace(0, 2.5 * h, 20001)
    integral = np.trapezoid(2 * math.pi * r * gaussian_kernel(r, h), r)
    assert integral == pytest.approx(1 - math.exp(-4), abs=1e-3)


def test_kernel_first_moment_zero_and_gradient_antisymmetric():
    h = 1.3
    g = np.linspace(-3 * h, 3 * h, 401)
    xx, yy = np.meshgrid(g, g)
    w = gaussian_kernel(np.hypot(xx, yy), h)
    cell = (g[1] - g[0]) ** 2
    assert abs(np.sum(xx * w) * cell) < 1e-9 and abs(np.sum(yy * w) * cell) < 1e-9
    assert np.sum(w) * cell == pytest.approx(1 - math.exp(-4), abs=1e-3)
    rng = np.random.default_rng(1)
    d = rng.uniform(-2 * h, 2 * h, size=(100, 2))
    gx, gy = kernel_gradient(d[:, 0], d[:, 1], h)
    mx, my = kernel_gradient(-d[:, 0], -d[:, 1], h)
    assert np.all(gx == -mx) and np.all(gy == -my)
    assert np.any(gx != 0)
    # Outside the support the kernel and its gradient vanish.
    assert gaussian_kernel(2.0001 * h, h) == 0.0
    assert kernel_gradient(2.01 * h, 0.0, h)[0] == 0.0


def test_tait_pressure():
    assert tait_pressure(1.0, 20.0, 1.0) == 0.0
    assert tait_pressure(2.0, 2.0, 1.0, 7.0) == pytest.approx(2.0 * (2**7 - 1))


@pytest.mark.parametrize("d,expected", [(0.5, 0.0), (1.0, 0.0), (2.0, 3.0 * 1.0), (3.0, 3.0 * 2.0), (10.0, 3.0 * 2.0)])
def test_body_force_three_pieces(d, expected):
    """eq. 6.2 with r = 1, s = 2, alpha = 3: zero inside r, alpha (d - r) on the ramp, alpha s beyond."""
    theta = 0.6
    x, y = -d * math.cos(theta), -d * math.sin(theta)  # the waypoint is at the origin
    fx, fy = body_force(np.array(x), np.array(y), 0.0, 0.0, 1.0, 2.0, 3.0)
    assert math.hypot(fx, fy) == pytest.approx(expected, abs=1e-12)
    if expected:
        # Both components carry the same magnitude (the thesis' slip: F_y = alpha s sin(theta)).
        assert fx == pytest.approx(expected * math.cos(theta)) and fy == pytest.approx(expected * math.sin(theta))


def test_momentum_conserved_without_body_force_borders_or_viscosity():
    # v_max is a robot speed limit, not part of the fluid: lifted here so it cannot act.
    params = SPHParams(mu=0.0, drag=0.0, beta=20.0, v_max=1e6, domain=(-1e3, 1e3, -1e3, 1e3))
    pos = lattice(49, 7, 0.9)
    rng = np.random.default_rng(3)
    vel = rng.normal(0.0, 0.5, size=pos.shape)
    states = np.array([initial_state(x, y, vx, vy, params) for (x, y), (vx, vy) in zip(pos, vel)])
    controls = [Control(beta=20.0 if k % 2 else 2.0) for k in range(49)]
    driver = PerParticleDriver(range(49), states, controls, params)
    p0 = params.mass * driver.states[:, [VX, VY]].sum(axis=0)
    scale = params.mass * np.abs(driver.states[:, [VX, VY]]).sum()
    final = driver.run(200)
    p1 = params.mass * final[:, [VX, VY]].sum(axis=0)
    assert np.abs(final[:, [VX, VY]] - vel).max() > 1e-2  # the particles did interact
    assert np.abs(p1 - p0).max() / scale <= 1e-10


def test_viscosity_drags_neighbours_along_the_push():
    """Thesis §4.7 (Fig. 4.14-4.15): one particle pushed along +x; the particles around it follow more with a
    larger mu. Measured on the ring the claim is about: the particles 1.5-3 m from the pushed one's *current*
    position (it moves ~2 m), as a time mean over the run. The nearest ring (<= 1.5 m) is slowed by mu
    instead: the stress form's two-hop stencil is negative at one spacing (docs/thesis-reproduction.md)."""

    def ring_means(mu, steps=300):
        params = SPHParams(mu=mu, domain=(-100, 100, -100, 100), border="reflect")
        pos = lattice(99, 11)  # x 0..10, y 0..8: the thesis' block, pushed particle at (5, 4)
        pushed = int(np.flatnonzero((pos[:, 0] == 5) & (pos[:, 1] == 4))[0])
        states = np.array([initial_state(x, y, 0.0, 0.0, params) for x, y in pos])
        controls = [Control(mu=mu, beta=2.0, push_x=1.0 if k == pushed else 0.0) for k in range(99)]
        driver = VectorisedDriver(range(99), states, controls, params)
        near, second = [], []
        for _ in range(steps):
            driver.step()
            s = driver.states
            d = np.hypot(s[:, X] - s[pushed, X], s[:, Y] - s[pushed, Y])
            near.append(s[(d > 0) & (d <= 1.5), VX].mean())
            second.append(s[(d > 1.5) & (d <= 3.0), VX].mean())
        return np.mean(near), np.mean(second)

    near, second = zip(*(ring_means(mu) for mu in (0.0, 0.5, 2.0)))
    print(f"ring 1 {np.round(near, 3)}, ring 2 {np.round(second, 3)}")
    assert 0 < second[0] and 1.1 * second[0] < second[1] and 1.1 * second[1] < second[2], second
    assert near[0] > near[1] > near[2], near


def test_per_particle_and_vectorised_drivers_agree_at_200_particles():
    setup = spread_block(200)
    a = PerParticleDriver(setup.ids, setup.states, setup.controls, setup.params).run(300)
    b = VectorisedDriver(setup.ids, setup.states, setup.controls, setup.params).run(300)
    moved = np.abs(a[:, [X, Y]] - setup.states[:, [X, Y]]).max()
    assert moved > 0.5
    assert np.abs(a[:, [X, Y]] - b[:, [X, Y]]).max() <= 1e-9


@pytest.mark.parametrize(
    "field,value",
    [
        ("h", 0.0),
        ("dt", -0.1),
        ("mass", -1.0),
        ("rho0", float("nan")),
        ("mu", -1.0),
        ("border", "wrap"),
        ("domain", (1, 0, 0, 1)),
    ],
)
def test_invalid_parameters_name_the_field(field, value):
    with pytest.raises(ValueError, match=f"SPHParams.{field}"):
        SPHParams(**{field: value})
