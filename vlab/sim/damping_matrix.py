"""The applied modal damping matrix ``C_m = A diag(c) A^T`` of a plant, and its storage in the model.

:class:`ModalDamping` holds ``A = M Phi`` (the damped modes, mass-normalised)
and the modal coefficients ``c``; its force ``-C_m qvel`` is set as
``qfrc_applied`` before every step. The arrays travel with the model as the
custom numerics :data:`NUMERIC_A` and :data:`NUMERIC_C`
(:func:`store_modal_damping`, :func:`load_modal_damping`), so an exported
MJCF carries them. How ``A`` and ``c`` are designed is described in
:mod:`vlab.sim.damping`.

Source: modal damping as in Sec. 2.1.2 of the dissertation; MuJoCo
``qfrc_applied`` and custom numerics (``doc/XMLreference.rst``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import SimulationError

#: Names of the custom numerics that carry the applied modal damping.
NUMERIC_A = "vlab_modal_A"
NUMERIC_C = "vlab_modal_c"

#: What one numpy call costs, in multiply-adds of a small matrix product (measured on the BCC: a call
#: ~0.5 us, a 22 x 22 product ~0.5 us); it decides :attr:`ModalDamping.dense`.
CALL_COST_FLOPS = 500


@dataclass(frozen=True)
class ModalDamping:
    """The modal damping matrix ``C_m = A diag(c) A^T`` of a plant.

    Attributes
    ----------
    A : ndarray, shape (nv, n_damped)
        ``M Phi`` of the damped modes (mass-normalised ``Phi``).
    c : ndarray, shape (n_damped,)
        Modal damping coefficients [1/s].
    """

    A: np.ndarray
    c: np.ndarray

    @functools.cached_property
    def dense(self) -> np.ndarray | None:
        """``-C_m``, shape (nv, nv), where one product with it costs less than the factored form; else None.

        Per step the force ``-C_m qvel`` is either ``-A (c * (A^T qvel))``
        (three numpy calls, ``2 nv N`` multiply-adds) or ``(-C_m) qvel`` (one
        call, ``nv^2``). A small plant pays mostly for the calls (about
        :data:`CALL_COST_FLOPS` multiply-adds each), a large one for the
        arithmetic: the dense form is used when ``nv^2 <= 2 nv N + 2 x``
        :data:`CALL_COST_FLOPS` (the BCC: nv = 22, N = 7; not the grid: nv = 165,
        N = 15). Every user of the damping (:meth:`apply`,
        :class:`vlab.sim.loopio.LoopIO`, :class:`vlab.sim.batch_plant.MujocoBatchPlant`)
        takes the same form, so their forces agree bit for bit.
        """
        nv, n = self.A.shape
        if nv * nv > 2 * nv * n + 2 * CALL_COST_FLOPS:
            return None
        return np.ascontiguousarray(-((self.A * self.c) @ self.A.T))

    def force(self, qvel: np.ndarray) -> np.ndarray:
        """Generalized damping force ``-C_m qvel``.

        Parameters
        ----------
        qvel : ndarray, shape (nv,)
            Joint velocities.

        Returns
        -------
        ndarray, shape (nv,)
        """
        return -self.A @ (self.c * (self.A.T @ qvel))

    def matrix(self) -> np.ndarray:
        """``C_m``, shape (nv, nv)."""
        return (self.A * self.c) @ self.A.T

    def step(self, model: mujoco.MjModel, data: mujoco.MjData, n: int = 1,
             base: np.ndarray | None = None) -> None:
        """``n`` MuJoCo steps, each with ``qfrc_applied = base - C_m qvel`` set first.

        Parameters
        ----------
        model : mujoco.MjModel
        data : mujoco.MjData
            Advanced in place.
        n : int
            Number of steps.
        base : ndarray, shape (nv,), optional
            Other applied generalized forces (zero by default).
        """
        for _ in range(n):
            self.apply(data, base)
            mujoco.mj_step(model, data)

    def apply(self, data: mujoco.MjData, base: np.ndarray | None = None) -> None:
        """Set ``qfrc_applied = base - C_m qvel`` from the current ``qvel``, as :meth:`step` does before each step.

        For a caller that splits the step (``mj_step1``, then forces, then
        ``mj_step2``): ``qvel`` is unchanged by ``mj_step1``, so the force is
        the one :meth:`step` would set.

        Parameters
        ----------
        data : mujoco.MjData
            Its ``qfrc_applied`` (shape (nv,)) is written in place.
        base : ndarray, shape (nv,), optional
            Other applied generalized forces (zero by default).
        """
        dense = self.dense
        if dense is not None:  # -C_m qvel in one product (the same numbers as LoopIO and the batch plant)
            if base is None:
                np.dot(dense, data.qvel, out=data.qfrc_applied)
            else:
                np.add(base, dense @ data.qvel, out=data.qfrc_applied)
            return
        a = self.A
        f = a @ (self.c * (a.T @ data.qvel))
        if base is None:
            np.negative(f, out=data.qfrc_applied)
        else:
            np.subtract(base, f, out=data.qfrc_applied)

def store_modal_damping(ms: mujoco.MjSpec, md: ModalDamping) -> None:
    """Write ``A`` (row-major, nv x N) and ``c`` into the spec as custom numerics.

    Parameters
    ----------
    ms : mujoco.MjSpec
        The plant's spec (modified).
    md : ModalDamping
    """
    a = ms.add_numeric(name=NUMERIC_A)
    a.data = md.A.ravel().tolist()
    c = ms.add_numeric(name=NUMERIC_C)
    c.data = md.c.tolist()


def load_modal_damping(model: mujoco.MjModel) -> ModalDamping | None:
    """The applied modal damping stored in a model, or None.

    Parameters
    ----------
    model : mujoco.MjModel

    Returns
    -------
    ModalDamping or None

    Raises
    ------
    SimulationError
        If the stored arrays do not fit the model (nv).
    """
    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_NUMERIC, i): i for i in range(model.nnumeric)}
    if NUMERIC_A not in names or NUMERIC_C not in names:
        return None

    def data(name):
        i = names[name]
        adr, size = int(model.numeric_adr[i]), int(model.numeric_size[i])
        return np.array(model.numeric_data[adr: adr + size])

    c = data(NUMERIC_C)
    a = data(NUMERIC_A)
    if a.size != model.nv * c.size:
        raise SimulationError(f"stored modal damping has {a.size} coefficients, expected nv x N = "
                              f"{model.nv} x {c.size}")
    return ModalDamping(a.reshape(model.nv, c.size), c)


