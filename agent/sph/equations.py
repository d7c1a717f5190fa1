"""SPH equations of the thesis (ch. 3, eq. 3.5-3.13; ch. 6, eq. 6.2) as pure functions on numpy arrays.

Pair functions take arrays over interacting pairs (i, j) and return one term per pair; a caller sums
them per particle. The per-particle step (one particle, its neighbours) and the vectorised solver (all
pairs at once) both call these same functions, so they cannot drift apart.
"""

from __future__ import annotations

import numpy as np

from agent.sph.kernel import gaussian_kernel


def density(r_ij: np.ndarray, m_j: np.ndarray | float, h: float, kappa: float = 2.0) -> float:
    """rho_i = sum_j m_j W_ij over the support, self included (eq. 3.5); pass r = 0 for the self term."""
    return float(np.sum(m_j * gaussian_kernel(r_ij, h, kappa)))


def density_terms(r_ij: np.ndarray, m_j: np.ndarray | float, h: float, kappa: float = 2.0) -> np.ndarray:
    """The terms m_j W_ij of eq. 3.5, one per pair."""
    return m_j * gaussian_kernel(r_ij, h, kappa)


def tait_pressure(rho: np.ndarray | float, beta: np.ndarray | float, rho0: float, gamma: float = 7.0):
    """p_i = beta_i ((rho_i / rho0)^gamma - 1): Tait equation of state for liquid-like flow (eq. 3.13)."""
    return beta * ((np.asarray(rho, dtype=float) / rho0) ** gamma - 1.0)


def artificial_viscosity(dx, dy, dvx, dvy, rho_i, rho_j, h: float, beta_pi: float) -> np.ndarray:
    """Pi_ij = beta_pi phi_ij^2 / rho_bar_ij when v_ij . x_ij < 0, else 0 (eq. 3.9-3.10).

    phi_ij = h_ij v_ij.x_ij / (|x_ij|^2 + (0.1 h_ij)^2), rho_bar_ij and h_ij the pair means; with one
    smoothing length for all particles h_ij = h. x_ij = x_i - x_j, v_ij = v_i - v_j.
    """
    vdotx = dvx * dx + dvy * dy
    phi = h * vdotx / (dx * dx + dy * dy + (0.1 * h) ** 2)
    rho_bar = 0.5 * (rho_i + rho_j)
    return np.where(vdotx < 0.0, beta_pi * phi * phi / rho_bar, 0.0)


def stress_rate_terms(dWdx, dWdy, du_ji, dv_ji, m_j, rho_j):
    """Viscous stress rates (eq. 3.11), one term per pair; sum over j for eps_i^xx, eps_i^xy, eps_i^yy.

    eps^xx = 2/3 sum m_j/rho_j (2 u_ji dW/dx_i - v_ji dW/dy_i)
    eps^xy =     sum m_j/rho_j (  v_ji dW/dx_i + u_ji dW/dy_i)
    eps^yy = 2/3 sum m_j/rho_j (2 v_ji dW/dy_i - u_ji dW/dx_i)
    with u_ji = u_j - u_i, v_ji = v_j - v_i the velocity differences along x and y.
    """
    w = m_j / rho_j
    exx = (2.0 / 3.0) * w * (2.0 * du_ji * dWdx - dv_ji * dWdy)
    exy = w * (dv_ji * dWdx + du_ji * dWdy)
    eyy = (2.0 / 3.0) * w * (2.0 * dv_ji * dWdy - du_ji * dWdx)
    return exx, exy, eyy


def momentum_terms(dWdx, dWdy, m_j, rho_i, rho_j, p_i, p_j, pi_ij, sxx_i, sxy_i, syy_i, sxx_j, sxy_j, syy_j):
    """Per-pair acceleration terms of the momentum equation (eq. 3.7-3.8), body force excluded.

    Du_i/Dt = -sum m_j ((p_i + p_j)/(rho_i rho_j) + Pi_ij) dW/dx_i
              + sum m_j ((s_i^xx + s_j^xx) dW/dx_i + (s_i^xy + s_j^xy) dW/dy_i) / (rho_i rho_j)
    Dv_i/Dt = -sum m_j ((p_i + p_j)/(rho_i rho_j) + Pi_ij) dW/dy_i
              + sum m_j ((s_i^xy + s_j^xy) dW/dx_i + (s_i^yy + s_j^yy) dW/dy_i) / (rho_i rho_j)
    where s = mu * eps is the viscous stress of each particle (per-particle viscosity mu). The thesis'
    eq. 3.8 prints eps^xx and eps^vy in the y-equation: a typesetting slip; we use eps^xy and eps^yy as in
    the standard Liu & Liu form. Every coefficient is symmetric in (i, j) and dW is odd, so the pair terms
    are antisymmetric and total momentum is conserved.
    """
    rr = rho_i * rho_j
    pres = (p_i + p_j) / rr + pi_ij
    ax = m_j * (-pres * dWdx + ((sxx_i + sxx_j) * dWdx + (sxy_i + sxy_j) * dWdy) / rr)
    ay = m_j * (-pres * dWdy + ((sxy_i + sxy_j) * dWdx + (syy_i + syy_j) * dWdy) / rr)
    return ax, ay


def body_force(x: np.ndarray, y: np.ndarray, wx, wy, r, s, alpha):
    """Potential-field body force per unit mass towards a waypoint (eq. 3.14 / 6.2).

    With d the distance to the waypoint and theta its direction:
      0                          for d < r,
      alpha (d - r) (cos, sin)   for r <= d <= r + s,
      alpha s (cos, sin)         for d > r + s.
    Two typesetting slips of the thesis are corrected: in the last case both components carry s
    (F_y = alpha s sin(theta)), and f_i is a per-particle, per-unit-mass term added once to the
    acceleration, not inside the neighbour sum of eq. 3.7-3.8.
    Works on scalars or arrays (one waypoint per particle).
    """
    ex = np.asarray(wx, dtype=float) - x
    ey = np.asarray(wy, dtype=float) - y
    d = np.hypot(ex, ey)
    magnitude = np.where(d < r, 0.0, np.where(d <= r + s, alpha * (d - r), alpha * s))
    safe = np.where(d > 0.0, d, 1.0)
    return magnitude * ex / safe, magnitude * ey / safe
