"""An independent all-pairs implementation of the thesis' equations (eq. 3.3-3.13, 6.2), dense N x N.

Written again from the thesis, not from agent/sph's equation functions, so that the project's per-particle
step can be checked against it. Only the integration bookkeeping (speed cap, border policy) is shared.
Options measure the readings the project had to choose between:

lag        "protocol": forces at step n use ρ, p and the stress of configuration n-1, and the stress of
           configuration n is built with the neighbours' ρ of configuration n-1 (the project's one
           exchange per step, docs/protocol.md); "none": the thesis' flow chart (Fig. 3.5, two
           exchanges): ρ, p and stress of configuration n, the stress with ρ of configuration n.
eq38       "corrected": the y-equation's viscous terms use ε^xy and ε^yy (Liu & Liu; agent/sph);
           "printed": as eq. 3.8 is printed, μ_i ε_i^xy + μ_j ε_j^xx with dW/dx and μ_i ε_i^yy + μ_j ε_j^yy
           with dW/dy.
stress_rho "previous" (protocol): the stress of configuration n uses the neighbours' ρ of configuration
           n-1, the ρ their states carry; "same": their ρ of configuration n (needs a second exchange).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agent.sph.params import SPHParams
from agent.sph.particle import FROZEN, RHO, SXX, SXY, SYY, VX, VY, P, X, Y, apply_border, cap_speed
from agent.sph.reference import Driver

LAGS = ("protocol", "none")
EQ38 = ("corrected", "printed")
STRESS_RHO = ("previous", "same")


@dataclass(frozen=True)
class Controls:
    """Per-particle control arrays (N,): waypoint wx, wy [m], r, s [m], alpha [1/s^2], beta [N/m], mu [kg/s],
    push_x, push_y [m/s^2]."""

    wx: np.ndarray
    wy: np.ndarray
    r: np.ndarray
    s: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    mu: np.ndarray
    push_x: np.ndarray
    push_y: np.ndarray

    @classmethod
    def of(cls, controls, states: np.ndarray, step: int) -> Controls:
        cs = [c.control(states[k], step) for k, c in enumerate(controls)]
        return cls(
            *(
                np.array([getattr(c, f) for c in cs], dtype=float)
                for f in ("wx", "wy", "r", "s", "alpha", "beta", "mu", "push_x", "push_y")
            )
        )


def pair_geometry(x, y, params: SPHParams):
    """x_ij, y_ij, W_ij, dW/dx_i, dW/dy_i for all pairs (N, N), zero outside the support and on the diagonal."""
    dx = x[:, None] - x[None, :]
    dy = y[:, None] - y[None, :]
    h = params.h
    R2 = (dx * dx + dy * dy) / (h * h)
    inside = R2 <= params.kappa**2
    w = np.where(inside, np.exp(-R2) / (math.pi * h * h), 0.0)  # eq. 3.3, alpha_d = 1/(pi h^2)
    g = np.where(inside, -2.0 * np.exp(-R2) / (math.pi * h**4), 0.0)  # dW/dR * dR/dx_i / x_ij
    np.fill_diagonal(g, 0.0)
    return dx, dy, w, g * dx, g * dy


def fluid_quantities(x, y, vx, vy, rho_nb, active, beta, mu, params: SPHParams):
    """ρ (eq. 3.5, self included), p (eq. 3.13) and the stress μ ε (eq. 3.11, neighbours' density rho_nb)."""
    _dx, _dy, w, wx, wy = pair_geometry(x, y, params)
    pair = active[:, None] & active[None, :]
    w, wx, wy = w * pair, wx * pair, wy * pair
    rho = params.mass * w.sum(axis=1)  # the diagonal is the self term W(0)
    p = beta * ((rho / params.rho0) ** params.gamma - 1.0)
    u_ji = vx[None, :] - vx[:, None]
    v_ji = vy[None, :] - vy[:, None]
    c = params.mass / rho_nb[None, :]
    exx = (2.0 / 3.0) * (c * (2.0 * u_ji * wx - v_ji * wy)).sum(axis=1)
    exy = (c * (v_ji * wx + u_ji * wy)).sum(axis=1)
    eyy = (2.0 / 3.0) * (c * (2.0 * v_ji * wy - u_ji * wx)).sum(axis=1)
    return rho, p, mu * exx, mu * exy, mu * eyy


def acceleration(x, y, vx, vy, rho, p, sxx, sxy, syy, active, params: SPHParams, eq38: str = "corrected"):
    """The neighbour sums of eq. 3.7-3.8 (pressure, artificial viscosity eq. 3.9-3.10, viscous stress)."""
    dx, dy, _w, wx, wy = pair_geometry(x, y, params)
    pair = active[:, None] & active[None, :]
    wx, wy = wx * pair, wy * pair
    h = params.h
    dvx = vx[:, None] - vx[None, :]
    dvy = vy[:, None] - vy[None, :]
    vdotx = dvx * dx + dvy * dy
    phi = h * vdotx / (dx * dx + dy * dy + (0.1 * h) ** 2)
    pi_ij = np.where(vdotx < 0.0, params.beta_pi * phi * phi / (0.5 * (rho[:, None] + rho[None, :])), 0.0)
    rr = rho[:, None] * rho[None, :]
    press = (p[:, None] + p[None, :]) / rr + pi_ij
    m = params.mass
    ax = (m * (-press * wx + ((sxx[:, None] + sxx[None, :]) * wx + (sxy[:, None] + sxy[None, :]) * wy) / rr)).sum(
        axis=1
    )
    if eq38 == "printed":
        first = sxy[:, None] + sxx[None, :]
    else:
        first = sxy[:, None] + sxy[None, :]
    ay = (m * (-press * wy + (first * wx + (syy[:, None] + syy[None, :]) * wy) / rr)).sum(axis=1)
    return ax, ay


def body_force(x, y, c: Controls):
    """eq. 6.2 (both components carry s beyond r + s)."""
    ex, ey = c.wx - x, c.wy - y
    d = np.hypot(ex, ey)
    mag = np.where(d < c.r, 0.0, np.where(d <= c.r + c.s, c.alpha * (d - c.r), c.alpha * c.s))
    safe = np.where(d > 0.0, d, 1.0)
    return mag * ex / safe, mag * ey / safe


class AllPairsDriver(Driver):
    """All particles, all pairs, one step at a time; states laid out as agent/sph's (N, NFIELDS) rows.
    Its own equations (the point of it); only the stepping loop, `run`, is the reference drivers'."""

    def __init__(
        self,
        states: np.ndarray,
        controls,
        params: SPHParams,
        lag: str = "protocol",
        eq38: str = "corrected",
        stress_rho: str = "previous",
    ):
        if lag not in LAGS or eq38 not in EQ38 or stress_rho not in STRESS_RHO:
            raise ValueError(
                f"lag must be one of {LAGS}, eq38 one of {EQ38}, stress_rho one of {STRESS_RHO}; "
                f"got {lag!r}, {eq38!r}, {stress_rho!r}"
            )
        self.stress_rho = stress_rho
        self.states = np.array(states, dtype=float)
        self.controls, self.params, self.lag, self.eq38 = controls, params, lag, eq38
        self.step_index = 0

    def step(self) -> None:
        s, params = self.states, self.params
        c = Controls.of(self.controls, s, self.step_index)
        active = s[:, FROZEN] == 0.0
        x, y, vx, vy = s[:, X], s[:, Y], s[:, VX], s[:, VY]
        rho_now, p_now, sxx, sxy, syy = fluid_quantities(x, y, vx, vy, s[:, RHO], active, c.beta, c.mu, params)
        if self.lag == "none" or self.stress_rho == "same":
            rho_now, p_now, sxx, sxy, syy = fluid_quantities(x, y, vx, vy, rho_now, active, c.beta, c.mu, params)
        if self.lag == "none":
            ax, ay = acceleration(x, y, vx, vy, rho_now, p_now, sxx, sxy, syy, active, params, self.eq38)
        else:
            ax, ay = acceleration(
                x, y, vx, vy, s[:, RHO], s[:, P], s[:, SXX], s[:, SXY], s[:, SYY], active, params, self.eq38
            )
        fx, fy = body_force(x, y, c)
        new = s.copy()
        new[:, VX] = vx + params.dt * (ax + fx + c.push_x - params.drag * vx)
        new[:, VY] = vy + params.dt * (ay + fy + c.push_y - params.drag * vy)
        cap_speed(new, params)
        new[:, X] = x + params.dt * new[:, VX]
        new[:, Y] = y + params.dt * new[:, VY]
        apply_border(new, params)
        new[:, RHO], new[:, P], new[:, SXX], new[:, SXY], new[:, SYY] = rho_now, p_now, sxx, sxy, syy
        frozen_now = new[:, FROZEN] != 0.0
        new[np.ix_(frozen_now, [VX, VY, P, SXX, SXY, SYY])] = 0.0
        new[~active] = s[~active]
        self.states = new
        self.step_index += 1
