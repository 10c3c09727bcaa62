"""The two forms of an FRF line's residual: the log ratio the fits descend, the relative error the tests judge.

For a line with measured FRF ``h`` (noise of relative complex variance ``s^2``, circular) and a model's
``H``, two residuals are in use, each split into its real and imaginary part and divided by the part's
standard deviation ``sigma_p = sqrt((s^2 + floor^2) / 2)``:

* the **log ratio** ``ln(H / h) = ln|H / h| + j arg(H / h)`` (``form="log"`` of :func:`line_residual`):
  log magnitude and phase, smooth in a stiffness or a mass over decades of ``|H|``, the objective of every
  fit and the footing on which fitted labs are compared;
* the **relative error** ``H / h - 1 = (H - h) / h`` (``form="relative"``): with ``H`` the true
  FRF it is the measured noise over the measured value, ``-n / h``, whose parts over ``sigma_p`` are
  exactly normal for normal noise, so that the sum of squares is chi-square and the largest line's
  square follows ``dof F(dof, nu)`` with an estimated variance: the cost of the frequency-domain
  maximum-likelihood estimator for additive circular complex noise (Pintelon & Schoukens, *System
  Identification: A Frequency Domain Approach*, Wiley).

The two agree to first order in the error (``ln(1 + e) = e - e^2/2 + ...``). Where the noise is not small
the log ratio's tail is heavier: ``|ln(1 + e)|`` grows without bound as ``e`` nears -1 (a model FRF far
below a noisy measured line). A test of the log ratio against the laws of the relative error then fires
far above its rate (noise-only lines at a median relative noise of 0.15, two periods, a test rate of
1.7 %: the log ratio's largest line beyond its limit in 13.8 % of the draws, the relative error's in
0.8 %; tests/test_diagnose_noise_limits.py). So every statistic judged against a limit is of the
relative error.
"""

from __future__ import annotations

import numpy as np

#: Residual returned for a state the model cannot be built for (unstable, singular).
PENALTY = 1e3


def _parts(e: np.ndarray, part_sigma: np.ndarray, use_phase: bool) -> np.ndarray:
    """``[Re e / sigma_p, Im e / sigma_p]`` (or the real part alone), non-finite values as :data:`PENALTY`."""
    with np.errstate(divide="ignore", invalid="ignore"):
        re = e.real / part_sigma
        rr = re if not use_phase else np.concatenate([re, e.imag / part_sigma])
    return np.where(np.isfinite(rr), rr, PENALTY)


def line_residual(h_model: np.ndarray, h_meas: np.ndarray, part_sigma: np.ndarray, *, form: str = "log",
                  use_phase: bool = True) -> np.ndarray:
    """The residual of FRF lines in one of the two forms (module docstring).

    Parameters
    ----------
    h_model, h_meas : ndarray, complex, shape (n,)
        Model and measured FRFs on the used lines and channels [(m/s)/N or any common unit].
    part_sigma : ndarray, shape (n,)
        Standard deviation of each real part ``sqrt((s^2 + floor^2) / 2)`` [1].
    form : {"log", "relative"}
        ``"log"``: the log ratio ``ln(H / h)`` (the fits'); ``"relative"``: the relative error ``H / h - 1``
        (the tests').
    use_phase : bool
        Include the imaginary part (the phase). Without it the real part of ``H / h - 1`` is not the
        magnitude's likelihood: both forms give the log magnitude ``ln|H / h|`` then.

    Returns
    -------
    ndarray, shape (2 n,) with phase, else (n,)
        ``[Re e / sigma_p, Im e / sigma_p]`` of the form's ``e``; a line where either FRF is zero or
        non-finite gives :data:`PENALTY`.

    Raises
    ------
    ValueError
        For another ``form``.
    """
    if form not in ("log", "relative"):
        raise ValueError(f"form must be 'log' or 'relative', got {form!r}")
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.asarray(h_model) / np.asarray(h_meas)
        if form == "relative" and use_phase:
            e = ratio - 1.0
        else:
            e = np.log(np.abs(ratio)) + 1j * np.angle(ratio)
    return _parts(e, part_sigma, use_phase)


def whitener(sens: np.ndarray, sigma: np.ndarray, part_sigma: np.ndarray, use_phase: bool):
    """``(U, c)`` such that ``r + U (c * (U^T r))`` whitens a residual ``r`` (each part already divided by its
    ``part_sigma``) for the model-form covariance ``A A^T``, ``A = J diag(sigma)``: with ``A = U S V^T``,
    ``(I + A A^T)^(-1/2) = I + U diag(1 / sqrt(1 + s^2) - 1) U^T`` (the inverse square root of a low-rank
    update of the identity, e.g. Golub & Van Loan, *Matrix Computations*, 4th ed., Sec. 2.4 and 4.2).

    Parameters
    ----------
    sens : ndarray, complex, shape (n, k)
        ``d ln H / d theta_k`` of the model form's ``k`` parameters on the ``n`` used lines and channels.
    sigma : ndarray, shape (k,)
        The parameters' standard uncertainties (in the units of ``theta``).
    part_sigma : ndarray, shape (n,)
        Standard deviation of each real part of the residual [1].
    use_phase : bool
        The residual holds the imaginary parts too (shape (2 n,)).

    Returns
    -------
    (ndarray, ndarray) or None
        ``U``, shape (m, min(m, k)) with ``m = 2 n`` with the phase, else ``n``, and ``c``, shape
        (min(m, k),); None where ``sigma`` is empty.
    """
    if sigma.size == 0:
        return None
    parts = [sens.real] + ([sens.imag] if use_phase else [])
    a = np.concatenate(parts, axis=0) / np.concatenate([part_sigma] * len(parts))[:, None] * sigma
    u, sv, _ = np.linalg.svd(a, full_matrices=False)
    return u, 1.0 / np.sqrt(1.0 + sv**2) - 1.0


def whitened(r: np.ndarray, w) -> np.ndarray:
    """``r + U (c * (U^T r))`` for the whitener ``w = (U, c)`` of :func:`whitener` (``r`` itself for None)."""
    if w is None:
        return r
    u, c = w
    return r + u @ (c * (u.T @ r))
