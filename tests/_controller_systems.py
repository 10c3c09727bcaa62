"""Synthetic test plants shared by the controllers tests."""

from __future__ import annotations

import numpy as np
import scipy.linalg


def chain(n=5, zeta=0.01, act=None):
    """Fixed-free chain of masses and springs with modal damping ``zeta`` (synthetic test plant)."""
    m = np.diag(np.linspace(1.0, 1.5, n))
    ks = np.linspace(2.0, 1.0, n)
    k = np.zeros((n, n))
    for i in range(n):
        k[i, i] += ks[i]
        if i + 1 < n:
            k[i, i] += ks[i + 1]
            k[i, i + 1] -= ks[i + 1]
            k[i + 1, i] -= ks[i + 1]
    w2, phi = scipy.linalg.eigh(k, m)
    c = m @ phi @ np.diag(2 * zeta * np.sqrt(w2)) @ phi.T @ m
    act = (0, n // 2, n - 1) if act is None else act
    U = np.zeros((n, len(act)))
    for j, a in enumerate(act):
        U[a, j] = 1.0
    return m, c, k, U
