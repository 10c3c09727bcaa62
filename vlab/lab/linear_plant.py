"""A linear plant for the control loop: ``m q'' + c q' + k q = U f`` stepped exactly.

The fast stand-in for the MuJoCo plant (Sec. 3, Eq. 3.1): the force is held
over each physics step and the state advanced with the exact zero-order-hold
discretisation (``scipy.linalg.expm`` of the augmented matrix). Used to test
the loop, to predict experiments quickly and, in diagnosis, to fit
hypotheses on the linear model.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..errors import ModelError


class LinearPlant:
    """Exactly discretised second-order model with point-wise inputs and outputs.

    Parameters
    ----------
    m, c, k : ndarray, shape (n, n)
        Mass [kg], damping [N*s/m], stiffness [N/m].
    point_index : dict[int, int]
        Point id -> index of its out-of-plane translation in ``q``.
    actuator_points : tuple of int
        Points where ``set_forces`` applies forces [N], in order.
    timestep_s : float
        Physics step h [s].

    Raises
    ------
    ModelError
        For inconsistent shapes or an actuator point without a DOF.
    """

    def __init__(self, m, c, k, *, point_index: dict[int, int], actuator_points, timestep_s: float):
        m, c, k = (np.asarray(a, dtype=float) for a in (m, c, k))
        n = m.shape[0]
        if m.shape != (n, n) or c.shape != (n, n) or k.shape != (n, n):
            raise ModelError(f"LinearPlant: m, c, k must be ({n}, {n}); got {m.shape}, {c.shape}, {k.shape}")
        self.actuator_points = tuple(actuator_points)
        for p in self.actuator_points:
            if p not in point_index:
                raise ModelError(f"LinearPlant: actuator point {p} has no DOF (points: {sorted(point_index)})")
        self.timestep_s = float(timestep_s)
        self._pidx = dict(point_index)
        u = np.zeros((n, len(self.actuator_points)))
        for j, p in enumerate(self.actuator_points):
            u[point_index[p], j] = 1.0
        minv = np.linalg.inv(m)
        a = np.block([[-minv @ c, -minv @ k], [np.eye(n), np.zeros((n, n))]])
        b = np.vstack([minv @ u, np.zeros((n, u.shape[1]))])
        nx, nu = a.shape[0], b.shape[1]
        big = np.zeros((nx + nu, nx + nu))
        big[:nx, :nx] = a * self.timestep_s
        big[:nx, nx:] = b * self.timestep_s
        e = scipy.linalg.expm(big)
        self._ad, self._bd = e[:nx, :nx], e[:nx, nx:]
        self._n = n
        self.x = np.zeros(nx)
        self._f = np.zeros(nu)
        self.time_s = 0.0

    def set_forces(self, forces: np.ndarray) -> None:
        """Hold ``forces`` [N], shape (n_act,), over the following steps."""
        self._f = np.asarray(forces, dtype=float)

    def step(self) -> None:
        """Advance one physics step: ``x+ = Ad x + Bd f``."""
        self.x = self._ad @ self.x + self._bd @ self._f
        self.time_s += self.timestep_s

    def velocities(self, points) -> np.ndarray:
        """Out-of-plane velocities [m/s] at ``points``, shape (len(points),)."""
        return np.array([self.x[self._pidx[p]] for p in points])

    def displacements(self, points) -> np.ndarray:
        """Out-of-plane displacements [m] at ``points``, shape (len(points),)."""
        return np.array([self.x[self._n + self._pidx[p]] for p in points])
