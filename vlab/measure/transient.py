"""Transient removal for FRFs measured with a periodic excitation: the local polynomial method.

A lightly damped structure is still ringing from the start of the excitation
when the analysed periods begin. The leftover transient is not periodic, so
it leaks into every line of each period's spectrum; averaging periods does
not remove it (it decays slowly and alike in every period), and the
period-to-period scatter shows only its change. On the Beam Cross-Cable in
open loop (mode 1 at 1.85 Hz, damping ratio 0.004: time constant 21 s) the
transient left after the lab's settling time biased the quasi-static lines
near 0.5 Hz by 1-2 % in magnitude and 0.015 rad in phase, several times their
noise.

Here the analysed periods are transformed as one block of ``m`` periods.
The excitation lives only on every ``m``-th bin of that block's spectrum;
the bins in between hold the output's noise and its transient alone. A
transient is a smooth function of frequency away from the poles (a sum of
``c_r / (1 - exp(lambda_r dt - 2 pi i j / M))`` over the modes), so a low-order
polynomial fitted to the non-excited bins around each excited one and
evaluated there estimates the transient at the excited bin, which is
subtracted. The same fit's residual estimates the output noise at that bin.

Source: R. Pintelon, K. Barbe, G. Vandersteen, J. Schoukens, "Improved
(non-)parametric identification of dynamic systems excited by periodic
signals", Mechanical Systems and Signal Processing 25 (2011) 2683-2704,
Sec. 3 (the transient at the excited lines from the non-excited ones); the
local polynomial method: R. Pintelon, J. Schoukens, *System Identification:
A Frequency Domain Approach*, 2nd ed., Wiley 2012, Sec. 7.2.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import islice

import numpy as np

from ..errors import MeasurementError

#: Non-excited bins used on each side of an excited one.
HALF_WIDTH = 3
#: Degree of the local polynomial of the transient.
DEGREE = 2


@dataclass(frozen=True)
class PeriodicSpectra:
    """Spectra of ``m`` periods at the excited lines, with the transient removed.

    Attributes
    ----------
    y : ndarray, complex, shape (n_lines, n_ch)
        Mean over the periods of each period's DFT of each output at the lines, transient removed
        [output unit x samples] (the scaling of ``numpy.fft.rfft`` of one period).
    noise_var : ndarray, shape (n_lines, n_ch)
        Variance of ``y`` [same unit squared]: the output noise at the line (the non-excited bins'
        residual scatter) and the transient estimate's own uncertainty.
    transient : ndarray, complex, shape (n_lines, n_ch)
        The transient removed from ``y`` [same unit].
    dof : int
        Real degrees of freedom of each ``noise_var`` entry.
    """

    y: np.ndarray
    noise_var: np.ndarray
    transient: np.ndarray
    dof: int


def periodic_spectra(y: np.ndarray, n_per: int, lines: np.ndarray, *, half_width: int = HALF_WIDTH,
                     degree: int = DEGREE) -> PeriodicSpectra:
    """Output spectra at the excited lines of a periodic test, transient removed (module notes).

    Parameters
    ----------
    y : ndarray, shape (m n_per, n_ch)
        ``m >= 2`` whole periods of each output channel, sampled evenly.
    n_per : int
        Samples per period.
    lines : ndarray of int, shape (n_lines,)
        Excited lines, as bin indices of one period's ``rfft`` (``1 <= line < n_per / 2``).
    half_width : int
        Non-excited bins fitted on each side of an excited one (fewer at the spectrum's ends).
    degree : int
        Degree of the local polynomial; ``2 half_width > degree + 1``.

    Returns
    -------
    PeriodicSpectra

    Raises
    ------
    MeasurementError
        Fewer than two periods, a record that is not a whole number of periods, a line outside
        ``[1, n_per / 2)``, or too few non-excited bins for the polynomial.
    """
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[:, None]
    m = y.shape[0] // n_per
    if m < 2 or y.shape[0] != m * n_per:
        raise MeasurementError(f"transient removal needs two or more whole periods of {n_per} samples, got "
                               f"{y.shape[0]} samples")
    lines = np.asarray(lines, dtype=int)
    if lines.size and (lines.min() < 1 or 2 * lines.max() >= n_per):
        raise MeasurementError(f"excited lines must lie in [1, {n_per // 2}), got {lines.min()}-{lines.max()}")
    if 2 * half_width <= degree + 1:
        raise MeasurementError(f"{2 * half_width} non-excited bins cannot fit a polynomial of degree {degree} "
                               "with a residual")
    spec = np.fft.rfft(y, axis=0) / m  # at bin m k: the mean of the periods' DFTs at line k
    n_bins = spec.shape[0]
    n_ch = y.shape[1]
    out = np.empty((lines.size, n_ch), dtype=complex)
    tr = np.empty_like(out)
    var = np.empty((lines.size, n_ch))
    n_fit = 2 * half_width
    for i, k in enumerate(lines):
        b = m * k
        near = _non_excited_near(b, m, n_bins, n_fit)
        d = (near - b) / m  # offsets in lines
        a = np.vander(d, degree + 1, increasing=True)
        coef, *_ = np.linalg.lstsq(a, spec[near], rcond=None)
        res = spec[near] - a @ coef
        s2 = np.sum(np.abs(res) ** 2, axis=0) / (near.size - degree - 1)  # per-bin noise variance (complex)
        g = np.linalg.inv(a.T @ a)[0, 0]  # variance factor of the polynomial's value at the line
        tr[i] = coef[0]
        out[i] = spec[b] - coef[0]
        var[i] = s2 * (1.0 + g)
    return PeriodicSpectra(out, var, tr, 2 * (n_fit - degree - 1))


def _non_excited_near(b: int, m: int, n_bins: int, count: int) -> np.ndarray:
    """The ``count`` non-excited bins (not multiples of ``m``, not 0) nearest to bin ``b``, balanced about it
    where the spectrum's ends allow."""
    def below(n: int) -> list:
        return list(islice((j for j in range(b - 1, 0, -1) if j % m), n))

    left = below(count // 2)
    right = list(islice((j for j in range(b + 1, n_bins) if j % m), count - len(left)))
    if len(left) + len(right) < count:  # near the upper end: more on the left
        left = below(count - len(right))
    return np.array(sorted(left + right), dtype=int)
