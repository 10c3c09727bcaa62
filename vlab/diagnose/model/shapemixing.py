"""The uncertainty of the mode shapes that a model's frequency uncertainty implies.

A model whose natural frequencies are uncertain by ``sigma_i`` (relative, one standard uncertainty) is
uncertain in its stiffness and mass; the same perturbation that moves the frequencies mixes the modes. To
first order (R. L. Fox and M. P. Kapoor, "Rates of change of eigenvalues and eigenvectors", *AIAA J.* 6
(1968) 2426-2429) a perturbation whose matrix in the mass-normalised modal coordinates is ``E`` moves

    omega_i^2  by  E_ii,                 phi_i  by  sum_{j != i} E_ji / (omega_i^2 - omega_j^2) phi_j.

The frequency uncertainty fixes the diagonal's standard deviation, ``std(E_ii) = 2 omega_i^2 sigma_i``
(``d omega^2 / omega^2 = 2 d omega / omega``). The off-diagonal entries are not measured; vlab takes the
largest that a perturbation of one sign (a stiffness or a mass change, positive semi-definite; also a sum of
independent such changes of the elements) allows, ``|E_ij| <= sqrt(E_ii E_jj)``, i.e. ``std(E_ij) = 2
omega_i omega_j sqrt(sigma_i sigma_j)``: an upper bound under that assumption (a perturbation of mixed sign
can exceed it), so the shapes are not claimed more certain than the frequencies allow. The mixing
coefficient of mode ``j`` into mode ``i`` is then uncertain by

    c_ij = 2 omega_i omega_j sqrt(sigma_i sigma_j) / abs(omega_i^2 - omega_j^2),

large for close modes (the BCC's 8.8/9.5 Hz pair: 0.66 % for a frequency uncertainty of 0.05 %; with the
other modes, 0.49 % and 0.94 % of modes 3 and 4 at the points) and small for well-separated ones. Measured at the points, mode ``i``'s shape changes by ``c_ij`` times mode
``j``'s root-mean-square shape there; relative to its own, the modes' contributions add in quadrature:

    s_i = sqrt( sum_{j != i} (c_ij rms_j / rms_i)^2 ).

At one point ``p`` the mixing moves mode ``i``'s shape by ``sum_j c_ij phi_j(p)`` times a standard normal,
whose standard deviation relative to the mode's RMS is

    s_i(p) = sqrt( sum_{j != i} (c_ij phi_j(p) / rms_i)^2 )

(``per_point``): ``s_i`` is its root-mean-square over the points, and at a point where the partners' shapes
are large -- the BCC's beam end, point 9, where the 8.8 Hz mode moves the 9.5 Hz one by 1.85 times ``s_i`` --
the average understates it. :func:`vlab.diagnose.model.modelform.frf_model_form` takes ``s_i(p)`` as the
relative standard uncertainty of each point's shape entry (a parameter of standard uncertainty
``s_i(p) rms_i``). Those parameters are independent from point to point, whereas a mixing moves every point
along mode ``j``'s shape at once: the variance at each point is the mixing's, the correlation between points
is not carried (a broader covariance than the mixing's).
"""

from __future__ import annotations

import numpy as np

from .labmodel import PointModes

__all__ = ["MAX_MIXING", "mixing_shape_uncertainty", "shape_sigma_at"]

#: Largest relative shape uncertainty [1], of one pair's mixing and of a mode's total: first-order perturbation
#: theory holds while the mixing is small; at 1 the model no longer tells the mode's shape at the points (it
#: may be anything of its own size there), and a larger number would not describe a larger uncertainty.
MAX_MIXING = 1.0


def mixing_shape_uncertainty(modes: PointModes, frequency_rel: np.ndarray, *, per_point: bool = False) -> np.ndarray:
    """Relative uncertainty of each mode's shape at the points implied by the frequency uncertainty (module notes).

    Parameters
    ----------
    modes : PointModes
        The modes (angular frequencies ``omega`` [rad/s], shape (n,); shapes at the points, shape (n_p, n)).
    frequency_rel : ndarray, shape (n,)
        One standard uncertainty of each mode's frequency, relative [1]; 0 or NaN: that mode's frequency is
        taken as exact (it neither mixes nor is mixed).

    per_point : bool
        Return ``s_i(p)`` at each point instead of ``s_i`` (module notes).

    Returns
    -------
    ndarray, shape (n,), or (n_p, n) with ``per_point``
        ``s_i`` [1]: the shape's change at the points relative to its root-mean-square there (or ``s_i(p)``,
        its change at each point relative to that root-mean-square), at most :data:`MAX_MIXING`; 0 for a mode
        without shape at the points.

    Raises
    ------
    ValueError
        ``frequency_rel`` of another length than the modes, or negative.

    Source: first-order eigenvector perturbation, Fox & Kapoor (1968); the bound on the off-diagonal modal
    perturbation is the Cauchy-Schwarz inequality of a semi-definite matrix.
    """
    w = np.asarray(modes.omega, dtype=float)
    s = np.asarray(frequency_rel, dtype=float)
    if s.shape != w.shape:
        raise ValueError(f"frequency_rel: {s.shape[0] if s.ndim else 0} values for {w.size} modes")
    s = np.where(np.isfinite(s), s, 0.0)
    if np.any(s < 0):
        raise ValueError(f"frequency_rel: negative value {float(s.min())}")
    shapes = np.asarray(modes.shapes, dtype=float)
    rms = np.sqrt(np.mean(shapes**2, axis=0))
    gap = np.abs(w[:, None] ** 2 - w[None, :] ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = 2.0 * np.outer(w, w) * np.sqrt(np.outer(s, s)) / gap
        c = np.where(np.isfinite(c), np.minimum(c, MAX_MIXING), MAX_MIXING)
        np.fill_diagonal(c, 0.0)
        c = np.where(np.outer(s, s) > 0, c, 0.0)
        # at each point p: sum_j (c_ij phi_j(p))^2 / rms_i^2, shape (n_p, n)
        at = np.einsum("ij,pj->pi", c**2, shapes**2) / rms[None, :] ** 2
    at = np.where(np.isfinite(at), at, 0.0)
    if per_point:
        return np.where(rms[None, :] > 0, np.minimum(np.sqrt(at), MAX_MIXING), 0.0)
    return np.where(rms > 0, np.minimum(np.sqrt(np.mean(at, axis=0)), MAX_MIXING), 0.0)


def shape_sigma_at(shape_rel, r: int, points: tuple) -> np.ndarray:
    """Mode ``r``'s relative shape uncertainty [1] at each of ``points``, shape (len(points),).

    Parameters
    ----------
    shape_rel : ndarray or None
        Shape (n,): each mode's value, the same at every point (:func:`mixing_shape_uncertainty`); or
        (len(points), n): one row per point (``per_point``); None: shapes exact.
    r : int
        Mode index (0-based); a mode ``shape_rel`` does not cover has 0.
    points : tuple of int
        The points, in the rows' order.

    Returns
    -------
    ndarray, shape (len(points),)

    Raises
    ------
    ValueError
        A two-dimensional ``shape_rel`` whose rows are not one per point.
    """
    n_pts = len(points)
    if shape_rel is None:
        return np.zeros(n_pts)
    a = np.atleast_2d(np.asarray(shape_rel, dtype=float))
    if np.ndim(shape_rel) == 2 and a.shape[0] != n_pts:
        raise ValueError(f"shape_rel has {a.shape[0]} rows for the {n_pts} points {tuple(points)}")
    return a[np.arange(n_pts) % a.shape[0], r] if r < a.shape[1] else np.zeros(n_pts)
