"""The design model's state space in SI, built independently of vlab's controller code for tests that check
designs against scipy: ``x = [q'; q]`` (m/s, rad/s, m, rad), velocity outputs at the actuators."""

from __future__ import annotations

import numpy as np

from vlab.design import design_model


def si_state_space(fe):
    """``(dm, A, B, C)`` of the full design model of ``fe``: ``x' = A x + B f`` (f [N] at the actuators), velocity
    outputs ``C x`` [m/s] at the actuators; ``dm`` the design model (its ``m``, ``c``, ``k``, ``labels``)."""
    dm = design_model(fe, "full")
    n = dm.m.shape[0]
    u = np.zeros((n, len(dm.actuator_rows)))
    u[list(dm.actuator_rows), range(len(dm.actuator_rows))] = 1.0
    mi = np.linalg.inv(dm.m)
    a = np.block([[-mi @ dm.c, -mi @ dm.k], [np.eye(n), np.zeros((n, n))]])
    b = np.vstack([mi @ u, np.zeros_like(u)])
    c = np.hstack([u.T, np.zeros_like(u.T)])
    return dm, a, b, c
