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
    input_gain : array_like, shape (n_act,), optional
        Force per command [1] of each actuator (the coils' gains of a structure file's ``[hardware]``
        table, :meth:`vlab.spec.Hardware.input_gains`): column j of ``U`` is ``input_gain[j]`` at its
        point's DOF. None: ones.

    Raises
    ------
    ModelError
        For inconsistent shapes, an actuator point without a DOF, or ``input_gain`` of another length.
    """

    def __init__(self, m, c, k, *, point_index: dict[int, int], actuator_points, timestep_s: float,
                 input_gain=None):
        m, c, k = (np.asarray(a, dtype=float) for a in (m, c, k))
        n = m.shape[0]
        if m.shape != (n, n) or c.shape != (n, n) or k.shape != (n, n):
            raise ModelError(f"LinearPlant: m, c, k must be ({n}, {n}); got {m.shape}, {c.shape}, {k.shape}")
        self.actuator_points = tuple(actuator_points)
        for p in self.actuator_points:
            if p not in point_index:
                raise ModelError(f"LinearPlant: actuator point {p} has no DOF (points: {sorted(point_index)})")
        self.timestep_s = float(timestep_s)
        if input_gain is not None and np.shape(input_gain) != (len(self.actuator_points),):
            raise ModelError(f"LinearPlant: input_gain must have shape ({len(self.actuator_points)},), "
                             f"got {np.shape(input_gain)}")
        self._pidx = dict(point_index)
        self._index_cache: dict[tuple, np.ndarray] = {}
        u = np.zeros((n, len(self.actuator_points)))
        for j, p in enumerate(self.actuator_points):
            u[point_index[p], j] = 1.0 if input_gain is None else float(input_gain[j])
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
        self._mck, self._u = (m, c, k), u
        self.x = np.zeros(nx)
        self._f = np.zeros(nu)
        self.time_s = 0.0

    def set_periodic_state(self, freq_hz, forces, *, extra_damping=None) -> None:
        """Put the plant in the steady state of periodic forces, at a period's start (warm start).

        For forces ``f(t) = Re sum_k F_k exp(j 2 pi f_k t)`` the steady state is
        ``q(t) = Re sum_k Q_k exp(j w_k t)`` with
        ``(k - w_k^2 m + j w_k c) Q_k = U F_k`` (Eq. 3.1 in the frequency domain);
        the state is set to ``q(0)``, ``q'(0)`` and the time to 0. The discrete
        stepping differs from it by the hold over a physics step, a transient
        that decays within the lab's settling time. ``freq_hz`` and ``forces`` (per input) as in
        :meth:`vlab.sim.runtime.MujocoPlant.set_periodic_state`.

        Parameters
        ----------
        extra_damping : dict of int to float, optional
            Point -> dashpot [N*s/m] added to ``c`` for the steady state only
            (the equivalent damping of a nonlinear force the inputs carry:
            for Coulomb friction of force ``F`` at velocity amplitude ``V``,
            ``4 F / (pi V)``, its describing function).

        Raises
        ------
        ModelError
            Wrong shapes or non-finite values; a damped point without a DOF
            or a negative or non-finite dashpot.
        """
        f = np.asarray(freq_hz, dtype=float)
        F = np.asarray(forces, dtype=complex)
        if F.shape != (f.size, self._u.shape[1]) or not np.all(np.isfinite(F)):
            raise ModelError(f"set_periodic_state: forces must be finite, shape ({f.size}, {self._u.shape[1]}); "
                             f"got {F.shape}")
        m, c, k = self._mck
        if extra_damping:
            c = c.copy()
            for p, cp in extra_damping.items():
                if p not in self._pidx:
                    raise ModelError(f"set_periodic_state: damped point {p} has no DOF "
                                     f"(points: {sorted(self._pidx)})")
                if not (np.isfinite(cp) and cp >= 0.0):
                    raise ModelError(f"set_periodic_state: dashpot at point {p} must be finite and >= 0 N*s/m, "
                                     f"got {cp!r}")
                c[self._pidx[p], self._pidx[p]] += float(cp)
        w = 2 * np.pi * f
        rhs = (self._u @ F.T).T                                           # (n_f, n)
        q = np.linalg.solve(k[None] - (w**2)[:, None, None] * m[None] + 1j * w[:, None, None] * c[None],
                            rhs[:, :, None])[:, :, 0]
        self.x = np.concatenate([np.sum(1j * w[:, None] * q, axis=0).real, np.sum(q, axis=0).real])
        self.time_s = 0.0

    def set_forces(self, forces: np.ndarray) -> None:
        """Hold ``forces`` [N], shape (n_act,), over the following steps."""
        self._f = np.asarray(forces, dtype=float)

    def step(self) -> None:
        """Advance one physics step: ``x+ = Ad x + Bd f``."""
        self.x = self._ad @ self.x + self._bd @ self._f
        self.time_s += self.timestep_s

    def velocities(self, points) -> np.ndarray:
        """Out-of-plane velocities [m/s] at ``points``, shape (len(points),).

        Raises
        ------
        KeyError
            A point without a DOF.
        """
        return self.x[self._index(points)]

    def displacements(self, points) -> np.ndarray:
        """Out-of-plane displacements [m] at ``points``, shape (len(points),).

        Raises
        ------
        KeyError
            A point without a DOF.
        """
        return self.x[self._n + self._index(points)]

    def _index(self, points) -> np.ndarray:
        """Indices in ``q`` of the points' translations (made once per tuple of points: the loop asks every tick)."""
        key = tuple(points)
        idx = self._index_cache.get(key)
        if idx is None:
            idx = self._index_cache[key] = np.array([self._pidx[p] for p in key], dtype=int)
        return idx
