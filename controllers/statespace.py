"""First-order (state-space) form of a second-order structural model, and time scaling.

The structure obeys Eq. (3.1), ``m q'' + c q' + k q = U u``. With the state
``x = [q'; q]`` (velocities first, as in the dissertation) it becomes
Eqs. (3.2)-(3.3)::

    x' = A x + B u,   A = [[-m^-1 c, -m^-1 k], [I, 0]],   B = [[m^-1 U], [0]]

and the (velocity) measurement of Eq. (4.2) is ``y = C x`` with
``C = [Cv, 0]``.

Time unit
---------
Sec. 3 of the dissertation designs with a time unit of one centisecond (cs)
so that ``q`` and ``q'`` have the same order of magnitude; its LQ weights
(``Q = 0.01 I``, ``R = 0.84 I``) only mean something in inch, lbf and cs.
:func:`rescale_time` changes the time unit exactly: for a new unit equal to
``T`` old units (``t' = t / T``)::

    x' = S x,   S = diag(T I_n, I_n)        (velocities now in length per new unit)
    A' = T S A S^-1 = [[-T m^-1 c, -T^2 m^-1 k], [I, 0]]
    B' = T S B      = [[T^2 m^-1 U], [0]]    (u stays a force)
    C' = C                                    (same state components, new units)

Gains convert back as ``F = F' S`` for state feedback ``u = -F' x'`` and
``D = T D'`` for velocity feedback ``u = -D' y'``; frequencies as
``omega = omega' / T``; a performance index ``J' = int (...) dt'`` is the
integral over the new time. Everything else in :mod:`controllers` takes the
matrices in whatever time unit they are given and a keyword ``time_unit_s``
(seconds per model time unit) used only to report Hz and to discretise in
seconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .errors import (
    MatrixPropertyError,
    ShapeError,
    check_matrix,
    check_positive_definite,
    check_positive_scalar,
    check_positive_semidefinite,
    check_square,
    readonly,
)

__all__ = [
    "StateSpace",
    "state_space",
    "time_scaling_matrix",
    "rescale_time",
    "structural_modes",
    "modal_initial_states",
]


@dataclass(frozen=True, eq=False)
class StateSpace:
    """A structural model in first-order form (Eqs. 3.2-3.3), immutable.

    Attributes
    ----------
    A : ndarray, shape (2n, 2n)
        System matrix for the state ``x = [q'; q]`` [1/time unit].
    B : ndarray, shape (2n, n_c)
        Input matrix; ``u`` are actuator forces [force unit].
    C : ndarray, shape (n_s, 2n)
        Velocity output matrix ``[Cv, 0]`` [length / time unit per state].
    n_dof : int
        Number of structural DOFs ``n``.
    time_unit_s : float
        Length of the model's time unit in seconds (1.0: seconds, 0.01: cs).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    n_dof: int
    time_unit_s: float = 1.0

    def __post_init__(self) -> None:
        n2 = 2 * self.n_dof
        a = check_matrix("A", self.A, (n2, n2), ("2n", "2n"))
        b = check_matrix("B", self.B, (n2, None), ("2n", "n_c"))
        c = check_matrix("C", self.C, (None, n2), ("n_s", "2n"))
        check_positive_scalar("time_unit_s", self.time_unit_s)
        object.__setattr__(self, "A", readonly(a))
        object.__setattr__(self, "B", readonly(b))
        object.__setattr__(self, "C", readonly(c))

    def rescaled(self, time_unit_s: float) -> "StateSpace":
        """Return the same model with time unit ``time_unit_s`` [s] (see :func:`rescale_time`)."""
        t_new = check_positive_scalar("time_unit_s", time_unit_s)
        factor = t_new / self.time_unit_s
        a, b, c = rescale_time(self.A, self.B, self.C, factor=factor)
        return StateSpace(a, b, c, self.n_dof, t_new)


def state_space(
    m,
    c,
    k,
    U,
    *,
    sensor_dofs=None,
    Cv=None,
    time_unit_s: float = 1.0,
) -> StateSpace:
    """Build ``A, B, C`` from second-order matrices (Eqs. 3.1-3.3).

    Parameters
    ----------
    m, c, k : array_like, shape (n_dof, n_dof)
        Mass [force*s^2/length], damping [force*s/length] and stiffness
        [force/length] matrices in one consistent unit system whose time unit
        is the second (e.g. lbf*s^2/in, lbf*s/in, lbf/in, or SI). ``m`` must be
        symmetric positive definite, ``k`` symmetric positive semi-definite;
        ``c`` need only be square.
    U : array_like, shape (n_dof, n_c)
        Actuator influence matrix (force of actuator j on DOF i).
    sensor_dofs : sequence of int, optional
        Indices of the DOFs whose velocities are measured; ``Cv`` is the
        corresponding rows of the identity. Mutually exclusive with ``Cv``.
    Cv : array_like, shape (n_s, n_dof), optional
        General velocity selection. If neither is given the sensors are
        collocated with the actuators, ``Cv = U^T``.
    time_unit_s : float
        Design time unit in seconds; 0.01 reproduces the dissertation's cs.
        The model is built in seconds and rescaled with :func:`rescale_time`.

    Returns
    -------
    StateSpace
        ``A (2n, 2n)``, ``B (2n, n_c)``, ``C = [Cv, 0] (n_s, 2n)``.

    Raises
    ------
    ShapeError
        Non-square ``m, c, k``, mismatched sizes, ``sensor_dofs`` out of range.
    MatrixPropertyError
        ``m`` not symmetric positive definite, ``k`` not symmetric positive
        semi-definite, non-finite entries, both ``sensor_dofs`` and ``Cv`` given.

    Notes
    -----
    Source: Eqs. (3.1)-(3.3) and Sec. 3 (time unit of 1e-2 s) of the dissertation.
    """
    m = check_square("m", m, "n_dof")
    n = m.shape[0]
    c = check_matrix("c", c, (n, n), ("n_dof", "n_dof"))
    k = check_matrix("k", k, (n, n), ("n_dof", "n_dof"))
    U = check_matrix("U", U, (n, None), ("n_dof", "n_c"))
    m = check_positive_definite("m", m)
    k = check_positive_semidefinite("k", k)
    if sensor_dofs is not None and Cv is not None:
        raise MatrixPropertyError("give either sensor_dofs or Cv, not both")
    if sensor_dofs is not None:
        idx = np.asarray(sensor_dofs, dtype=int).ravel()
        if idx.size == 0 or np.any(idx < 0) or np.any(idx >= n):
            raise ShapeError(
                f"sensor_dofs: expected indices in [0, n_dof) = [0, {n}), found {idx.tolist()}"
            )
        Cv = np.eye(n)[idx]
    elif Cv is not None:
        Cv = check_matrix("Cv", Cv, (None, n), ("n_s", "n_dof"))
    else:
        Cv = U.T.copy()
    minv_c = np.linalg.solve(m, c)
    minv_k = np.linalg.solve(m, k)
    minv_u = np.linalg.solve(m, U)
    A = np.block([[-minv_c, -minv_k], [np.eye(n), np.zeros((n, n))]])
    B = np.vstack([minv_u, np.zeros_like(minv_u)])
    C = np.hstack([Cv, np.zeros_like(Cv)])
    t = check_positive_scalar("time_unit_s", time_unit_s)
    if t != 1.0:
        A, B, C = rescale_time(A, B, C, factor=t)
    return StateSpace(A, B, C, n, t)


def time_scaling_matrix(n_dof: int, factor: float) -> np.ndarray:
    """State transformation ``S = diag(T I_n, I_n)`` of a time-unit change.

    Parameters
    ----------
    n_dof : int
        Number of structural DOFs ``n``.
    factor : float
        ``T``: the new time unit measured in old time units (0.01 for s -> cs).

    Returns
    -------
    ndarray, shape (2n, 2n)
        ``x_new = S x_old`` for the structural state ``x = [q'; q]``.

    Raises
    ------
    MatrixPropertyError
        If ``factor`` is not a finite positive number.
    """
    t = check_positive_scalar("factor", factor)
    return np.diag(np.concatenate([np.full(n_dof, t), np.ones(n_dof)]))


def rescale_time(A, B, C, *, factor: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Change the time unit of a structural state-space model exactly.

    With ``t' = t / T`` (``T = factor``, the new unit in old units) and
    ``x' = S x``, ``S = diag(T I_n, I_n)``::

        A' = T S A S^-1,   B' = T S B,   C' = C

    so the velocity states (and velocity outputs) are in length per new time
    unit, positions and forces are unchanged. Gains designed in the new unit
    convert back as ``F = F' S`` (state feedback) and ``D = T D'`` (velocity
    feedback); eigenvalues scale as ``lambda' = T lambda``, damping ratios are
    unchanged.

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
        System matrix for ``x = [q'; q]`` [1/old unit].
    B : array_like, shape (2n, n_c)
        Input matrix.
    C : array_like, shape (n_s, 2n)
        Output matrix (velocity and/or position selection).
    factor : float
        ``T`` > 0.

    Returns
    -------
    A', B', C' : ndarrays of the same shapes.

    Raises
    ------
    ShapeError
        Odd state dimension or mismatched shapes.
    MatrixPropertyError
        Non-positive ``factor``, non-finite entries.

    Notes
    -----
    Source: Sec. 3 of the dissertation ("the time unit employed was 1e-2 s").
    """
    A = check_matrix("A", A, (None, None), ("2n", "2n"))
    n2 = A.shape[0]
    if A.shape[1] != n2 or n2 % 2:
        raise ShapeError(f"A: expected shape (2n, 2n) with even 2n, found {A.shape}")
    B = check_matrix("B", B, (n2, None), ("2n", "n_c"))
    C = check_matrix("C", C, (None, n2), ("n_s", "2n"))
    t = check_positive_scalar("factor", factor)
    s = np.concatenate([np.full(n2 // 2, t), np.ones(n2 // 2)])
    A2 = t * (s[:, None] * A / s[None, :])
    B2 = t * (s[:, None] * B)
    return A2, B2, C.copy()


def structural_modes(m, k) -> tuple[np.ndarray, np.ndarray]:
    """Undamped natural frequencies and mass-normalised mode shapes (Eq. 3.4).

    Parameters
    ----------
    m : array_like, shape (n_dof, n_dof)
        Symmetric positive definite mass matrix.
    k : array_like, shape (n_dof, n_dof)
        Symmetric positive semi-definite stiffness matrix.

    Returns
    -------
    omega : ndarray, shape (n_dof,)
        Natural frequencies [rad per time unit of ``m, k``], ascending.
    phi : ndarray, shape (n_dof, n_dof)
        Mode shapes as columns, ``phi^T m phi = I``.

    Raises
    ------
    ShapeError, MatrixPropertyError
        Non-square, mismatched, non-symmetric or indefinite matrices.
    """
    m = check_square("m", m, "n_dof")
    n = m.shape[0]
    k = check_matrix("k", k, (n, n), ("n_dof", "n_dof"))
    m = check_positive_definite("m", m)
    k = check_positive_semidefinite("k", k)
    w2, phi = scipy.linalg.eigh(k, m)
    return np.sqrt(np.clip(w2, 0.0, None)), phi


def modal_initial_states(m, k, n_modes: int, *, length_dofs=None) -> np.ndarray:
    """Initial states ``x0 = [0; phi_i]`` in the shape of the first modes (Sec. 4.1.1).

    Each mode shape is scaled so that its largest deflection over
    ``length_dofs`` is exactly 1 (one inch in the thesis' unit system) and
    that entry is positive (a deterministic sign).

    Parameters
    ----------
    m, k : array_like, shape (n_dof, n_dof)
        Mass and stiffness matrices.
    n_modes : int
        ``n_f``, number of modes (1 <= n_f <= n_dof).
    length_dofs : sequence of int, optional
        Indices of the translational DOFs over which the maximum deflection is
        taken (rotations excluded); default all DOFs.

    Returns
    -------
    ndarray, shape (2n, n_f)
        Columns ``[0; phi_i]`` (zero velocity, position in the model's length unit).

    Raises
    ------
    ShapeError
        ``n_modes`` out of range or ``length_dofs`` out of range.
    MatrixPropertyError
        A mode with zero deflection on every ``length_dofs`` entry.

    Notes
    -----
    Source: Sec. 4.1.1 ("the first n_f open-loop mode shapes, each normalized
    with a maximum deflection of one inch") and Eq. (4.37).
    """
    _, phi = structural_modes(m, k)
    n = phi.shape[0]
    if not 1 <= int(n_modes) <= n:
        raise ShapeError(f"n_modes: expected 1 <= n_f <= n_dof = {n}, found {n_modes}")
    idx = np.arange(n) if length_dofs is None else np.asarray(length_dofs, dtype=int).ravel()
    if idx.size == 0 or np.any(idx < 0) or np.any(idx >= n):
        raise ShapeError(f"length_dofs: expected indices in [0, {n}), found {idx.tolist()}")
    x0 = np.zeros((2 * n, int(n_modes)))
    for i in range(int(n_modes)):
        sub = phi[idx, i]
        j = int(np.argmax(np.abs(sub)))
        if abs(sub[j]) <= 1e-14 * np.max(np.abs(phi[:, i])):
            raise MatrixPropertyError(
                f"mode {i + 1} has no deflection on length_dofs; cannot normalise to max 1"
            )
        x0[n:, i] = phi[:, i] / sub[j]
    return x0
