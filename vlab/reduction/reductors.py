"""The projection reductors: :class:`GuyanReduction` and :class:`ExactReduction` (Sec. 3.1).

Both build a basis ``T`` (n, n_R) whose master rows are the identity and
project the full model onto it: ``m_R = T' m T``, ``k_R = T' k T``,
``c_R = T' c T`` (a :class:`vlab.reduction.ReducedModel`); the variants differ
only in the hook ``_basis()``.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
import scipy.linalg as sla

from ..errors import ModelError, ReductionError
from .checks import (check_labels, check_master, damping_ratios, dof_names, frozen, generalized_eigh, mode_names,
                     real_array, symmetric)
from .modal import modal_damping
from .model import ReducedModel, reconstruct_from

#: Largest accepted condition number of the (row/column equilibrated) master
#: rows of the retained modes, ``Phi_R``, in the exact reduction.
PHI_R_MAX_COND = 1e10

#: Largest accepted condition number of the diagonally scaled slave-slave
#: stiffness ``K22`` in the Guyan reduction.
K22_MAX_COND = 1e12


class _Reductor:
    """Common part of the projection reductors: ``m_R = T' m T`` etc.

    Subclasses implement :meth:`_basis` only.
    """

    method = ""

    def __init__(
        self,
        m: Any,
        k: Any,
        master: Sequence[int],
        *,
        c: Any = None,
        labels: Sequence[Any] | None = None,
    ) -> None:
        self.m = symmetric("m", m)
        n = self.m.shape[0]
        self.k = symmetric("k", k, n)
        self.c = None if c is None else symmetric("c", c, n)
        self.labels = check_labels(labels, n)
        self.master = check_master(master, n, self.labels)
        in_master = np.zeros(n, dtype=bool)
        in_master[list(self.master)] = True
        #: Indices of the slave (condensed) DOFs, ascending.
        self.slave = tuple(int(i) for i in np.flatnonzero(~in_master))
        self._t: np.ndarray | None = None

    @property
    def n(self) -> int:
        """Number of DOFs of the full model."""
        return self.m.shape[0]

    @property
    def n_R(self) -> int:  # noqa: N802
        """Number of master DOFs ``n_R``."""
        return len(self.master)

    @property
    def basis(self) -> np.ndarray:
        """Reduction basis ``T``, shape (n, n_R) (computed once, read-only)."""
        if self._t is None:
            t = self._basis()
            # The master rows are the identity by construction; make them exact.
            t[list(self.master), :] = np.eye(self.n_R)
            self._t = frozen(t)
        return self._t

    def _basis(self) -> np.ndarray:  # pragma: no cover - abstract hook
        raise NotImplementedError

    def _reduced_damping(self, t: np.ndarray) -> np.ndarray | None:
        return None if self.c is None else t.T @ self.c @ t

    def reduce(self) -> ReducedModel:
        """Project the full model onto the basis.

        Returns
        -------
        ReducedModel
            ``m_R = T' m T`` (n_R, n_R) [kg], ``k_R = T' k T`` [N/m], and
            ``c_R = T' c T`` [N*s/m] when a damping matrix was given.

        Raises
        ------
        ReductionError
            If the basis cannot be formed for the chosen masters (see the class).
        """
        t = self.basis
        labels = None if self.labels is None else tuple(self.labels[i] for i in self.master)
        return ReducedModel(
            m=t.T @ self.m @ t,
            k=t.T @ self.k @ t,
            T=t,
            master=self.master,
            labels=labels,
            c=self._reduced_damping(t),
            method=self.method,
        )

    def reconstruct(self, q_r: Any) -> np.ndarray:
        """Full-model displacements ``q = T q_R``: :func:`vlab.reduction.model.reconstruct_from` with this reductor's basis.

        Parameters ``q_r`` (reduced coordinates, the master displacements,
        shape (n_R,) or (n_R, n_t)), the result and the errors: as
        :func:`vlab.reduction.model.reconstruct_from`.
        """
        return reconstruct_from(self.basis, q_r)


class GuyanReduction(_Reductor):
    r"""Guyan static condensation onto master DOFs.

    With the DOFs partitioned into masters ``1`` and slaves ``2`` (Eq. 3.9),
    the slaves follow the masters statically, ``q_2 = G_0 q_1`` with
    ``G_0 = -K22^{-1} K21`` (Eq. 3.15), so that, back in the original DOF order,

        T = P [I; -K22^{-1} K21],
        K_R = T' K T = K11 - K12 K22^{-1} K21                (Eq. 3.14),
        M_R = T' M T = M11 + M12 G0 + G0' M21 + G0' M22 G0   (Eq. 3.16),

    with ``P`` the permutation from (masters, slaves) to the original order.
    ``K_R^{-1}`` equals the master block of ``K^{-1}`` (static flexibility is
    exact); the frequencies of the reduced model are upper bounds of the full
    model's (Rayleigh-Ritz).

    Parameters
    ----------
    m, k : array_like, shape (n, n)
        Symmetric mass [kg] and stiffness [N/m] matrices of the full model.
        ``m`` may be singular (massless slave DOFs are the classic case).
    master : sequence of int, length n_R
        Indices of the master DOFs; the reduced coordinates follow this order.
    c : array_like, shape (n, n), optional
        Damping matrix [N*s/m]; reduced as ``T' c T``.
    labels : sequence, length n, optional
        One label per DOF (e.g. ``(point_id, "w")``) for error messages.

    Raises
    ------
    ModelError
        If a matrix is not square, symmetric, finite or of matching size.
    ReductionError
        If ``master`` is empty, has duplicates, non-integers or indices out of
        range; or (from :meth:`reduce`/:attr:`basis`) if ``K22`` is singular:
        the message names the slave DOFs that can move without straining
        (the null space of ``K22``, condition number above
        :data:`K22_MAX_COND` after diagonal scaling).

    Notes
    -----
    Typos in the dissertation, not reproduced here:

    * Eq. 3.12 reads ``q_2 = K22^{-1} F_2 - K11^{-1} K12' q_1``; the second
      term must be ``K22^{-1} K21 q_1`` (``K12' = K21``).
    * Eqs. 3.13-3.14 write ``K11 - K21 K22^{-1} K12'``, which does not conform
      (``K21`` is ``(n - n_R) x n_R``); the standard form is
      ``K11 - K12 K22^{-1} K21``.
    * Eq. 3.16 reads ``M11 + M12 G0 K12 + G0' M12' + G0' G0``: the ``K12``
      factor is spurious and ``M22`` is missing from the last term; the
      standard ``M11 + M12 G0 + G0' M21 + G0' M22 G0 = T' M T`` is used.

    Source: Guyan, "Reduction of stiffness and mass matrices", AIAA J. 3(2),
    1965 (Ref. 1 of the dissertation); Eqs. 3.9-3.16.
    """

    method = "guyan"

    def _basis(self) -> np.ndarray:
        n, n_r = self.n, self.n_R
        master, slave = list(self.master), list(self.slave)
        t = np.zeros((n, n_r))
        t[master, np.arange(n_r)] = 1.0
        if slave:
            k22 = self.k[np.ix_(slave, slave)]
            k21 = self.k[np.ix_(slave, master)]
            t[slave, :] = -self._solve_k22(k22, k21)
        return t

    def _solve_k22(self, k22: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """``K22^{-1} rhs`` with a singularity check that names slave DOFs."""
        slave = np.asarray(self.slave)
        d = np.diag(k22).copy()
        if np.any(d <= 0.0):
            bad = slave[d <= 0.0]
            raise ReductionError(
                "Guyan reduction impossible: slave DOFs with zero or negative diagonal "
                f"stiffness cannot be condensed: {dof_names(bad, self.labels)}. "
                "Make them master DOFs or restrain them."
            )
        s = 1.0 / np.sqrt(d)
        ks = s[:, None] * k22 * s[None, :]
        try:
            cf = sla.cho_factor(ks, check_finite=False)
            anorm = np.max(np.sum(np.abs(ks), axis=0))
            rcond, info = sla.lapack.dpocon(cf[0], anorm, uplo="L" if cf[1] else "U")
            if info != 0 or rcond < 1.0 / K22_MAX_COND:
                self._raise_singular_k22(ks)
            y = sla.cho_solve(cf, s[:, None] * rhs, check_finite=False)
        except np.linalg.LinAlgError:
            # Not positive definite: indefinite K (e.g. compressive geometric
            # stiffness) is allowed as long as K22 is regular.
            self._check_k22_regular(ks)
            y = sla.solve(ks, s[:, None] * rhs, assume_a="sym", check_finite=False)
        return s[:, None] * y

    def _check_k22_regular(self, ks: np.ndarray) -> None:
        w = np.linalg.eigvalsh(ks)
        if np.min(np.abs(w)) < np.max(np.abs(w)) / K22_MAX_COND:
            self._raise_singular_k22(ks)

    def _raise_singular_k22(self, ks: np.ndarray) -> None:
        w, v = np.linalg.eigh(ks)
        wmax = np.max(np.abs(w))
        null = np.abs(w) < wmax / K22_MAX_COND
        if not np.any(null):  # estimate flagged it; take the weakest direction
            null = np.abs(w) == np.min(np.abs(w))
        vn = v[:, null]
        weight = np.sqrt(np.sum(vn**2, axis=1))
        involved = np.asarray(self.slave)[weight > 0.1 * np.max(weight)]
        cond = wmax / max(np.min(np.abs(w)), np.finfo(float).tiny)
        raise ReductionError(
            f"Guyan reduction impossible: the slave-slave stiffness K22 is singular "
            f"(condition number {cond:.3g} > {K22_MAX_COND:.0e} after diagonal scaling, "
            f"{int(np.sum(null))} null direction(s)). These slave DOFs can move without "
            f"straining the structure once the masters are held: {dof_names(involved, self.labels)}. "
            "Make one of them a master DOF or restrain them."
        )


class ExactReduction(_Reductor):
    r"""The dissertation's exact reduction (SEREP with ``n_R`` modes and ``n_R`` masters).

    With ``Phi`` (n, n_R) the first ``n_R`` undamped modes and ``Phi_R``
    (n_R, n_R) its master rows (Eq. 3.5),

        T = Phi Phi_R^{-1},
        m_R = T' m T = Phi_R^{-T} diag(M_i) Phi_R^{-1},
        k_R = T' k T = Phi_R^{-T} diag(M_i w_i^2) Phi_R^{-1},

    which is the dissertation's form (Eqs. 3.6-3.8, see
    :func:`exact_reduction_form`): ``m_R^{-1} k_R = Phi_R diag(w_i^2) Phi_R^{-1}``
    and ``m_R^{-1} = Phi_R diag(1/M_i) Phi_R'``. The reduced model has exactly
    the first ``n_R`` frequencies of the full model and its mode shapes at
    the masters.

    Parameters
    ----------
    m, k : array_like, shape (n, n)
        Symmetric mass [kg] (positive definite unless ``shapes`` are given)
        and stiffness [N/m] matrices of the full model.
    master : sequence of int, length n_R
        Indices of the master DOFs; the reduced coordinates follow this order.
    c : array_like, shape (n, n), optional
        Damping matrix [N*s/m]; reduced as ``T' c T``. Exclusive with ``zeta``.
    zeta : float or array_like, shape (n_R,), optional
        Modal damping ratios of the first ``n_R`` modes [-]; gives
        ``c_R = m_R Phi_R diag(2 zeta_i w_i) Phi_R^{-1}`` (Eq. 3.6).
    freq_hz : array_like, shape (n_modes,), optional
        Natural frequencies [Hz] of the full model, ascending, with
        ``n_modes >= n_R`` (from the FE modal analysis). Given with ``shapes``.
    shapes : array_like, shape (n, n_modes), optional
        The corresponding mode shapes (any normalisation). Without them the
        lowest ``n_R + 1`` modes are computed with ``scipy.linalg.eigh``.
    labels : sequence, length n, optional
        One label per DOF (e.g. ``(point_id, "w")``) for error messages.
    max_cond : float
        Largest accepted condition number of ``Phi_R`` after row and column
        equilibration (default :data:`PHI_R_MAX_COND` = 1e10).

    Raises
    ------
    ModelError
        If a matrix is not square, symmetric, finite or of matching size, ``m``
        is not positive definite, or ``freq_hz``/``shapes`` are inconsistent.
    ReductionError
        For a bad ``master`` list (empty, duplicates, out of range), both
        ``c`` and ``zeta`` given, and (from :meth:`reduce`/:attr:`basis`) if
        ``Phi_R`` is singular or ill-conditioned -- the message names the
        master DOFs and the mode(s) not observable there -- or if frequency
        ``n_R`` equals frequency ``n_R + 1`` (the retained mode set, hence the
        reduced model, would not be unique).

    Notes
    -----
    Reference: Sec. 3.1.1 and Eqs. 3.5-3.8 ("Ref. 8" of the dissertation);
    O'Callahan, Avitabile & Riemer, "System equivalent reduction expansion
    process (SEREP)", 7th IMAC, 1989.
    """

    method = "exact"

    def __init__(
        self,
        m: Any,
        k: Any,
        master: Sequence[int],
        *,
        c: Any = None,
        zeta: Any = None,
        freq_hz: Any = None,
        shapes: Any = None,
        labels: Sequence[Any] | None = None,
        max_cond: float = PHI_R_MAX_COND,
    ) -> None:
        super().__init__(m, k, master, c=c, labels=labels)
        if c is not None and zeta is not None:
            raise ReductionError("give either a damping matrix c or modal damping ratios zeta, not both")
        self.zeta = None if zeta is None else damping_ratios(zeta, self.n_R)
        if (freq_hz is None) != (shapes is None):
            raise ModelError("freq_hz and shapes must be given together (or neither)")
        if not (np.isfinite(max_cond) and max_cond > 1.0):
            raise ModelError(f"max_cond must be a finite number > 1, got {max_cond!r}")
        self.max_cond = float(max_cond)
        self._given = None if freq_hz is None else self._check_given_modes(freq_hz, shapes)
        self._modes: tuple[np.ndarray, np.ndarray] | None = None

    def _check_given_modes(self, freq_hz: Any, shapes: Any) -> tuple[np.ndarray, np.ndarray]:
        f = real_array("freq_hz", freq_hz, 1)
        phi = real_array("shapes", shapes, 2)
        if phi.shape[0] != self.n or phi.shape[1] != f.size:
            raise ModelError(f"shapes has shape {phi.shape}, expected ({self.n}, {f.size}) to match freq_hz")
        if f.size < self.n_R:
            raise ModelError(f"{f.size} modes given but the exact reduction to {self.n_R} masters needs {self.n_R}")
        if np.any(f < 0.0) or np.any(np.diff(f) < 0.0):
            raise ModelError("freq_hz must be non-negative and ascending")
        return f, phi

    @property
    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """The retained modes: ``(freq_hz (n_R,) [Hz], Phi (n, n_R))``.

        Computed shapes are mass-normalised; given shapes are used as given.
        """
        if self._modes is None:
            if self._given is not None:
                f_all, phi_all = self._given
                lam = (2.0 * np.pi * f_all) ** 2
            else:
                n_get = min(self.n_R + 1, self.n)
                lam, phi_all = generalized_eigh(self.k, self.m, subset_by_index=[0, n_get - 1])
                lam = np.clip(lam, 0.0, None)
            self._check_cut(lam)
            lam, phi = lam[: self.n_R], phi_all[:, : self.n_R]
            self._modes = (frozen(np.sqrt(lam) / (2.0 * np.pi)), frozen(phi))
        return self._modes

    def _check_cut(self, lam: np.ndarray) -> None:
        n_r = self.n_R
        if lam.size <= n_r:
            return
        scale = max(abs(lam[n_r]), 1e-9 * np.trace(self.k) / max(np.trace(self.m), np.finfo(float).tiny))
        if abs(lam[n_r] - lam[n_r - 1]) <= 1e-8 * scale:
            f = np.sqrt(np.clip(lam[n_r - 1 : n_r + 1], 0, None)) / (2 * np.pi)
            raise ReductionError(
                f"exact reduction to {n_r} masters is not unique: modes {n_r} and {n_r + 1} "
                f"have the same frequency ({f[0]:.6g} Hz, {f[1]:.6g} Hz), so the retained mode set is "
                "arbitrary within their eigenspace. Use one master DOF more or fewer."
            )

    @property
    def phi_R(self) -> np.ndarray:  # noqa: N802
        """``Phi_R``: master rows of the retained modes, shape (n_R, n_R) (Eq. 3.5)."""
        return frozen(self.modes[1][list(self.master), :])

    @property
    def modal_mass(self) -> np.ndarray:
        """Modal masses ``M_i = phi_i' m phi_i`` of the retained modes, shape (n_R,) [kg]."""
        phi = self.modes[1]
        return np.einsum("ij,ik,kj->j", phi, self.m, phi)

    def _basis(self) -> np.ndarray:
        freq, phi = self.modes
        phi_r = phi[list(self.master), :]
        self._check_phi_r(phi_r, phi, freq)
        # T = Phi Phi_R^{-1}  <=>  Phi_R' T' = Phi'
        return sla.solve(phi_r.T, phi.T).T

    def _check_phi_r(self, phi_r: np.ndarray, phi: np.ndarray, freq: np.ndarray) -> None:
        master = np.asarray(self.master)
        col_full = np.linalg.norm(phi, axis=0)
        col = np.linalg.norm(phi_r, axis=0)
        row = np.linalg.norm(phi_r / np.where(col_full > 0, col_full, 1.0), axis=1)
        eps = np.finfo(float).eps
        # Modes that vanish at every master, masters that no retained mode moves.
        dead_modes = np.flatnonzero(col <= 1e3 * eps * col_full)
        dead_masters = master[row <= 1e3 * eps * max(np.max(row), np.finfo(float).tiny)]
        if dead_modes.size == 0 and dead_masters.size == 0:
            a = phi_r / col[None, :]
            a = a / np.linalg.norm(a, axis=1)[:, None]
            s = np.linalg.svd(a, compute_uv=False)
            cond = s[0] / s[-1] if s[-1] > 0 else np.inf
            if cond <= self.max_cond:
                return
        else:
            cond = np.linalg.cond(phi_r / np.where(col_full > 0, col_full, 1.0)[None, :])
        what = []
        if dead_modes.size:
            verb = "is" if dead_modes.size == 1 else "are"
            what.append(f"{mode_names(dead_modes, freq)} {verb} zero at every master DOF (not observable there)")
        if dead_masters.size:
            verb = "does" if dead_masters.size == 1 else "do"
            what.append(f"{dof_names(dead_masters, self.labels)} {verb} not move in any of the first {self.n_R} modes")
        if not what:
            a = phi_r / col[None, :]
            a = a / np.linalg.norm(a, axis=1)[:, None]
            _, s, vt = np.linalg.svd(a)
            small = s < s[0] / self.max_cond
            v = vt[small, :]
            weight = np.sqrt(np.sum(v**2, axis=0))
            modes = np.flatnonzero(weight > 0.2 * np.max(weight))
            what.append(
                f"a combination of {mode_names(modes, freq)} is (nearly) zero at all master DOFs: "
                "these modes are not independently observable there"
            )
        raise ReductionError(
            f"exact reduction impossible: Phi_R (the first {self.n_R} modes at the master DOFs "
            f"{dof_names(master, self.labels)}) is singular or ill-conditioned "
            f"(condition number {cond:.3g} > {self.max_cond:.0e}): " + "; ".join(what) + ". "
            "Choose master DOFs at which each of the first n_R modes moves distinctly."
        )

    def _reduced_damping(self, t: np.ndarray) -> np.ndarray | None:
        if self.zeta is None:
            return super()._reduced_damping(t)
        m_r = t.T @ self.m @ t
        c_r = m_r @ modal_damping(self.phi_R, self.modes[0], self.zeta)
        return 0.5 * (c_r + c_r.T)
