"""Small analytic structures with known modes for the measurement tests."""

from __future__ import annotations

import numpy as np
from scipy import linalg


def spring_mass_chain(masses, springs):
    """Spring-mass chain, spring 0 to ground, spring i between masses i-1 and i: (m, k)."""
    n = len(masses)
    k = np.zeros((n, n))
    for i, ki in enumerate(springs):
        if i == 0:
            k[0, 0] += ki
        else:
            k[np.ix_([i - 1, i], [i - 1, i])] += ki * np.array([[1.0, -1.0], [-1.0, 1.0]])
    return np.diag(np.asarray(masses, dtype=float)), k


def two_dof(zetas=(0.02, 0.03), stiff_scale=4.0):
    """2-DOF chain with modal damping: (M, C, K, f_n [Hz], zeta). Modes near 4.5 and 9.0 Hz."""
    M = np.diag([1.0, 0.5])
    K = np.array([[600.0, -200.0], [-200.0, 200.0]]) * stiff_scale
    lam, V = linalg.eigh(K, M)                    # mass-normalised V
    wn = np.sqrt(lam)
    z = np.asarray(zetas, dtype=float)
    C = M @ V @ np.diag(2 * z * wn) @ V.T @ M
    return M, C, K, wn / (2 * np.pi), z


def receptance(freq_hz, M, C, K, out_dof, in_dof):
    """Displacement FRF [m/N] H(w) = [K - w^2 M + i w C]^-1, entry (out, in)."""
    e = np.zeros(M.shape[0])
    e[in_dof] = 1.0
    return np.array([np.linalg.solve(K - w**2 * M + 1j * w * C, e)[out_dof]
                     for w in 2 * np.pi * np.asarray(freq_hz)])


def state_space(M, C, K, in_dof, out_dof):
    """(A, B, C, D) of force at in_dof -> velocity at out_dof."""
    n = M.shape[0]
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ C]])
    B = np.concatenate([np.zeros(n), Mi[:, in_dof]])[:, None]
    Cv = np.zeros((1, 2 * n))
    Cv[0, n + out_dof] = 1.0
    return A, B, Cv, np.zeros((1, 1))
