"""Results of the DRF designs (MFDRF, LQDRF; Eqs. 4.30-4.38): the design and each optimiser start."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .realization import DiscreteRealization, output_feedback_realization

__all__ = ["DrfStart", "DrfDesign"]


@dataclass(frozen=True, eq=False)
class DrfStart:
    """One optimiser start of a DRF design.

    Attributes
    ----------
    start : int
        0-based start number (0: the ``c I`` start).
    objective : float
        ``gamma`` or ``beta`` reached (design units).
    success : bool
        SLSQP's own success flag.
    feasible : bool
        All constraints hold at the end (independent check).
    iterations : int
    evaluations : int
        Function + gradient evaluations.
    message : str
    """

    start: int
    objective: float
    success: bool
    feasible: bool
    iterations: int
    evaluations: int
    message: str


@dataclass(frozen=True, eq=False)
class DrfDesign:
    """Result of an MFDRF or LQDRF design (Eqs. 4.30-4.38).

    Attributes
    ----------
    kind : str
        ``"MFDRF"``, ``"LQDRF"``, ``"LQDRF-diagonal"``, ``"LQDRF-LQR-normalised"``
        or ``"LQDRF-diagonal-LQR-normalised"``.
    gain : ndarray, shape (n_c, n_c)
        ``D`` of ``u = -D y`` [force / (length per time unit)], symmetric.
    objective : float
        The minimised ``gamma`` (MFDRF) or ``beta`` (LQDRF), recomputed from ``gain``.
    gamma : float
        ``max_i sum_j |d_ij|`` (Eq. 4.31) [force / (length per time unit)].
    row_sums : ndarray, shape (n_c,)
        ``f_i = sum_j |d_ij|``.
    beta : float or None
        ``max_i J_i`` (or ``max_i J_i / J_i^LQR``) for LQDRF; None for MFDRF.
    constrained_damping : ndarray, shape (n_m',)
        Damping ratios of the constrained (first ``n_m``) modes.
    eigenvalues, damping_ratios, frequencies_hz : ndarray, shape (n_modes,)
        All modes of ``A - B D C`` sorted by frequency.
    zeta_min : float
    n_modes : int
    min_eig : float
        Lower bound imposed on the eigenvalues of ``D``.
    performance_index : ndarray, shape (n_f,) or None
        ``J_i`` (Eqs. 4.33-4.36) for the given initial states.
    performance_ratio : ndarray, shape (n_f,) or None
        ``J_i / J_i^LQR`` when LQR-normalised.
    converged : bool
        Optimiser success *and* every constraint verified.
    message : str
        Reason, start used, or what failed.
    iterations : int
        SLSQP iterations of the returned start.
    evaluations : int
        Distinct gains analysed (eigen-decompositions), all starts, the start
        scan and phase one included.
    active_constraints : tuple of str
        Constraints within ``1e-5`` (scaled) of their bound.
    starts : tuple of DrfStart
    wall_time_s : float
    time_unit_s : float
        Seconds per design time unit.
    """

    kind: str
    gain: np.ndarray
    objective: float
    gamma: float
    row_sums: np.ndarray
    beta: float | None
    constrained_damping: np.ndarray
    eigenvalues: np.ndarray
    damping_ratios: np.ndarray
    frequencies_hz: np.ndarray
    zeta_min: float
    n_modes: int
    min_eig: float
    performance_index: np.ndarray | None
    performance_ratio: np.ndarray | None
    converged: bool
    message: str
    iterations: int
    evaluations: int
    active_constraints: tuple[str, ...]
    starts: tuple[DrfStart, ...]
    wall_time_s: float
    time_unit_s: float

    @property
    def gain_per_s(self) -> np.ndarray:
        """``D`` for velocities per second, ``T D`` (Table 7 units: lbf*s/in), shape (n_c, n_c)."""
        return self.time_unit_s * self.gain

    def realize(self, dt_s: float) -> DiscreteRealization:
        """Engine coefficients of Eq. (5.1): ``F11 = -T D``, no state (Sec. 5.3).

        ``y_k`` in length per second, ``u_k`` actuator force; see
        :func:`controllers.realization.output_feedback_realization`, which
        documents ``dt_s`` [s] and the errors (a non-positive ``dt_s``).

        Returns
        -------
        DiscreteRealization
            ``F11 (n_c, n_c)``, no internal state.
        """
        return output_feedback_realization(self.gain, dt_s, time_unit_s=self.time_unit_s)
