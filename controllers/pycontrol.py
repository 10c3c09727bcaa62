"""python-control objects of a design: the plant, the controller and the closed loop as ``control.StateSpace``.

The design module solves its Riccati and Lyapunov equations with scipy (:func:`scipy.linalg.solve_continuous_are`,
:func:`scipy.linalg.solve_continuous_lyapunov`) -- the solvers python-control itself calls when slycot is
absent -- and discretises with :func:`scipy.linalg.expm`. What python-control adds is the toolbox of the field
on the result: frequency responses, margins, feedback interconnection, simulation. This module hands the
designs over in seconds (SI):

* :func:`plant` -- the design model ``x' = A x + B u``, ``y = C x`` converted from its time unit to seconds
  (:func:`controllers.statespace.rescale_time`): velocities in length per second;
* :func:`lqg_controller` -- the continuous LQG controller ``x' = (A~/T) x + K y``, ``u = -F x``
  (Eq. 5.5 in seconds, as :func:`controllers.realization.estimator_realization` discretises it);
* :func:`output_feedback` -- a direct rate feedback ``u = -D y`` (MFDRF, LQDRF: Eq. 4.30) in seconds;
* :func:`discrete_controller` -- the engine of Eq. (5.1) ``u_k = F11 y_k + F12 x_k``,
  ``x_{k+1} = F21 y_k + F22 x_k`` as a discrete-time system with ``dt`` the sampling period;
* :func:`closed_loop` -- plant and controller joined, ``u = r + K y`` (the controller's output carries its
  own sign), from the added input ``r`` to the sensors.

Every controller here maps sensor velocities [m/s] to actuator forces [N] when the design model is in SI
lengths and forces; the signs are those of the lab (the command applied is the controller's output).

Source: Eqs. (4.4)-(4.22), (4.30), (5.1)-(5.5) of the dissertation; python-control 0.10 (Fuller et al.,
"The Python Control Systems Library (python-control)", IEEE CDC 2021).
"""

from __future__ import annotations

import control
import numpy as np

from .errors import check_matrix, check_positive_scalar
from .lqg import LqgDesign
from .statespace import rescale_time

__all__ = ["plant", "lqg_controller", "output_feedback", "discrete_controller", "closed_loop"]


def plant(A, B, C, *, time_unit_s: float = 1.0) -> control.StateSpace:
    """The design model ``x' = A x + B u``, ``y = C x`` in seconds.

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
        System matrix for ``x = [q'; q]`` [1/time unit].
    B : array_like, shape (2n, n_c)
        Input matrix.
    C : array_like, shape (n_s, 2n)
        Output matrix (sensor velocities).
    time_unit_s : float
        Seconds per time unit of ``A`` (0.01 for the dissertation's centiseconds).

    Returns
    -------
    control.StateSpace
        Continuous, ``(n_s, n_c)``, with the velocity states and outputs per second.

    Raises
    ------
    ShapeError, MatrixPropertyError
        As :func:`controllers.statespace.rescale_time`.

    Source: Eqs. (3.2)-(3.3); the time scaling of Sec. 3.
    """
    t = check_positive_scalar("time_unit_s", time_unit_s)
    a, b, c = rescale_time(A, B, C, factor=1.0 / t)
    return control.ss(a, b, c, np.zeros((c.shape[0], b.shape[1])))


def lqg_controller(design: LqgDesign) -> control.StateSpace:
    """The continuous LQG controller of ``design`` in seconds: ``x' = (A~/T) x + K y``, ``u = -F x``.

    Parameters
    ----------
    design : LqgDesign
        From :func:`controllers.lq.lqg` (``A~ = A - B F - K C``, Eq. 5.5).

    Returns
    -------
    control.StateSpace
        Continuous, ``(n_c, n_s)``: sensor velocities per second in, actuator commands out (the sign of
        ``u = -F x`` included).

    Raises
    ------
    nothing beyond python-control's own checks.

    Source: Eqs. (4.11)-(4.15), (5.5).
    """
    F, K = design.regulator.gain, design.estimator.gain
    a_tilde = design.A - design.B @ F - K @ design.C
    t = design.time_unit_s
    return control.ss(a_tilde / t, K, -F, np.zeros((F.shape[0], K.shape[1])))


def output_feedback(D, *, time_unit_s: float = 1.0) -> control.StateSpace:
    """A direct rate feedback ``u = -D y`` (a static gain) in seconds.

    Parameters
    ----------
    D : array_like, shape (n_c, n_s)
        Gain designed with velocities per time unit (:mod:`controllers.drf`).
    time_unit_s : float
        Seconds per time unit: the gain per second is ``T D`` (:func:`controllers.statespace.rescale_time`).

    Returns
    -------
    control.StateSpace
        Static, ``(n_c, n_s)``, ``D`` matrix ``-T D``.

    Raises
    ------
    ShapeError, MatrixPropertyError
        Not a finite matrix; non-positive ``time_unit_s``.

    Source: Eq. (4.30).
    """
    d = check_matrix("D", D, (None, None), ("n_c", "n_s"))
    t = check_positive_scalar("time_unit_s", time_unit_s)
    return control.ss([], [], [], -t * d)


def discrete_controller(f11, f12, f21, f22, dt_s: float) -> control.StateSpace:
    """The controller engine of Eq. (5.1), ``u_k = F11 y_k + F12 x_k``, ``x_{k+1} = F21 y_k + F22 x_k``, as a
    discrete-time ``control.StateSpace`` (the coefficients of a
    :class:`~controllers.realization.DiscreteRealization`, or ``f11``-``f22`` of a vlab design).

    Parameters
    ----------
    f11, f12, f21, f22 : array_like
        Shapes (n_u, n_y), (n_u, n_x), (n_x, n_y), (n_x, n_x); ``n_x`` may be 0 (a static law).
    dt_s : float
        Sampling period [s].

    Returns
    -------
    control.StateSpace
        ``A = F22``, ``B = F21``, ``C = F12``, ``D = F11``, ``dt = dt_s``: sensor velocities [m/s] in,
        commands [N] out. Without the lab's computation delay, hold and RC filter.

    Raises
    ------
    ShapeError, MatrixPropertyError
        Inconsistent shapes, non-finite entries, non-positive ``dt_s``.

    Source: Eq. (5.1).
    """
    d11 = check_matrix("F11", f11, (None, None), ("n_u", "n_y"))
    nu, ny = d11.shape
    d22 = np.atleast_2d(np.asarray(f22, dtype=float)) if np.size(f22) else np.zeros((0, 0))
    nx = d22.shape[0]
    d22 = check_matrix("F22", d22, (nx, nx), ("n_x", "n_x")) if nx else d22
    d12 = check_matrix("F12", np.reshape(f12, (nu, nx)), (nu, nx), ("n_u", "n_x")) if nx else None
    d21 = check_matrix("F21", np.reshape(f21, (nx, ny)), (nx, ny), ("n_x", "n_y")) if nx else None
    h = check_positive_scalar("dt_s", dt_s)
    if nx == 0:
        return control.ss([], [], [], d11, h)
    return control.ss(d22, d21, d12, d11, h)


def closed_loop(plant_ss: control.StateSpace, controller_ss: control.StateSpace) -> control.StateSpace:
    """Plant and controller in one loop, ``u = r + K y``: from the added input ``r`` to the sensors ``y``.

    Parameters
    ----------
    plant_ss : control.StateSpace
        ``(n_s, n_c)``, e.g. :func:`plant`.
    controller_ss : control.StateSpace
        ``(n_c, n_s)``, its output the command itself (:func:`lqg_controller`, :func:`output_feedback`);
        of the same time base as the plant.

    Returns
    -------
    control.StateSpace
        ``(n_s, n_c)``; its poles are the closed loop's.

    Raises
    ------
    ValueError
        Mismatched sizes or time bases (python-control's).

    Source: Eq. (4.16) (the LQG loop), Eq. (4.30) (rate feedback).
    """
    return control.feedback(plant_ss, controller_ss, sign=+1)
