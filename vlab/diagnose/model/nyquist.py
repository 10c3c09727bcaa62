"""Stability of the lab's closed loop from its frequency-domain model: the generalised Nyquist criterion.

A loop that oscillates by itself has a closed loop with poles in the right
half-plane. With the loop transfer ``L(w) = A(w) K(w) S(w) G_fb(w)`` of
:mod:`vlab.diagnose.model.labmodel` (the matrix that :func:`~vlab.diagnose.model.labmodel.predict_frf`
inverts as ``I + L``), the number of unstable closed-loop poles is

    Z = P - (1 / pi) * [arg det(I + L(w))] from w = 0 to w_max

(``P``: unstable open-loop poles, those of the controller's state matrix
``F22`` outside the unit circle; the structure is stable). The phase change
over ``0 < w < w_max`` is half that over the whole axis (``L(-w)`` is the
conjugate of ``L(w)``), and ``det(I + L)`` starts real at ``w = 0`` (a velocity
FRF vanishes there) and returns near 1 at ``w_max`` where ``|L|`` is small.

The phase is followed on a grid refined until no step turns it by more than
:data:`MAX_STEP_RAD` (lightly damped modes of the structure turn it within a
fraction of a hertz); the grid starts with points at every natural frequency
of the structure and of the controller.

Like the whole frequency-domain model, the loop here neglects aliasing: valid
while ``|L|`` is small beyond the Nyquist frequency, which the count checks
(:class:`LoopStability` ``closure``).

Source: generalised Nyquist criterion (MacFarlane & Postlethwaite, Int. J.
Control 25 (1977) 81-127; Skogestad & Postlethwaite, *Multivariable Feedback
Control*, 2nd ed., 2005, Theorem 4.9).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import ModelError
from .labmodel import LabState, actuator_path, controller_frf, frequencies, plant_frf, sensor_path, structure_modes

#: Largest phase turn of ``det(I + L)`` between neighbouring grid points [rad] before the step is halved.
MAX_STEP_RAD = 0.25

#: Most halvings of a grid step (a step of 1 Hz is refined down to about 1e-6 Hz).
MAX_REFINE = 20

#: ``|L|`` (largest singular value) at the top of the grid below which the contour counts as closed.
CLOSURE = 0.5


@dataclass(frozen=True)
class LoopStability:
    """The closed loop's stability from :func:`loop_stability`.

    Attributes
    ----------
    unstable_poles : int
        ``Z``, the closed-loop poles to the right of ``Re s = sigma_1_s`` (complex pairs count 2): with
        ``sigma_1_s = 0`` the unstable poles.
    open_loop_unstable : int
        ``P``, the controller's poles there (``|z| > e^{sigma T}``).
    winding : float
        Phase change of ``det(I + L)`` over ``0 < f < f_max`` divided by ``2 pi`` (half the turns).
    f_max_hz : float
        Top of the grid [Hz].
    closure : float
        Largest singular value of ``L`` at ``f_max_hz``: the count is exact only when it is small.
    n_points : int
        Grid points after refinement.
    sigma_1_s : float
        The shift of the contour [1/s]: poles that grow faster than ``e^{sigma t}`` were counted.
    """

    unstable_poles: int
    open_loop_unstable: int
    winding: float
    f_max_hz: float
    closure: float
    n_points: int
    sigma_1_s: float = 0.0

    @property
    def unstable(self) -> bool:
        """Whether the closed loop has a pole right of the contour: in the right half-plane, or growing faster
        than ``e^{sigma t}`` for a shifted contour (``sigma_1_s > 0``)."""
        return self.unstable_poles > 0

    @property
    def trusted(self) -> bool:
        """Whether the contour closes (``|L|`` small at the top) and the winding is near a whole number."""
        return self.closure < CLOSURE and abs(2 * self.winding - round(2 * self.winding)) < 0.1


def return_difference(state: LabState, freq_hz: np.ndarray) -> np.ndarray:
    """``det(I + L(w))`` of the lab's closed loop, ``L = A K S G_fb``.

    Parameters
    ----------
    state : LabState
        A closed-loop lab (with a design).
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz], > 0.

    Returns
    -------
    ndarray, complex, shape (n_f,)

    Raises
    ------
    ModelError
        Open loop (no design), or as :func:`~vlab.diagnose.model.labmodel.plant_frf`.

    Source: the loop of :func:`~vlab.diagnose.model.labmodel.predict_frf` (Fig. 21).
    """
    return np.linalg.det(np.eye(len(state.actuators))[None] + loop_transfer(state, freq_hz))


def loop_transfer(state: LabState, freq_hz: np.ndarray) -> np.ndarray:
    """The loop transfer ``L(w) = A K S G_fb`` at the feedback points.

    Parameters
    ----------
    state : LabState
        A closed-loop lab.
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz].

    Returns
    -------
    ndarray, complex, shape (n_f, n_act, n_act) [-]

    Raises
    ------
    ModelError
        Open loop (no design), or as :func:`~vlab.diagnose.model.labmodel.plant_frf`.

    Source: the loop of :func:`~vlab.diagnose.model.labmodel.predict_frf` (Fig. 21).
    """
    f = frequencies(freq_hz)
    k = controller_frf(state, f)
    if k is None:
        raise ModelError("the loop's stability needs a controller (the lab is open loop)")
    acts = state.actuators
    g = plant_frf(state, f, acts, acts)
    a, s = actuator_path(state, f), sensor_path(state, f)
    return (a[:, :, None] * k * s[:, None, :]) @ g


def _controller_poles(state: LabState) -> np.ndarray:
    """Eigenvalues of the controller's state matrix ``F22`` (Eq. 5.1), shape (n_x,) (empty for a static law)."""
    f22 = np.atleast_2d(state.design.f22)
    return np.linalg.eigvals(f22) if f22.size else np.zeros(0, dtype=complex)


def _seed_frequencies(state: LabState, f_max: float) -> np.ndarray:
    """Natural frequencies [Hz] of the structure (and their half-power points) and the controller below
    ``f_max``: where the phase of ``det(I + L)`` turns fastest."""
    fn, zeta = structure_modes(state)
    lam = _controller_poles(state)
    lam = lam[np.abs(lam) > 0]
    s = np.concatenate([fn, fn * (1 - zeta), fn * (1 + zeta),
                        np.abs(np.angle(lam)) / (2 * math.pi * state.chain.period_s)])
    return s[(s > 0) & (s < f_max)]


def unstable_closed_loop_poles(det_of, f_max_hz: float, open_loop_unstable: int, *, df_hz: float = 1.0,
                               seeds_hz=()) -> tuple[int, float, int]:
    """Closed-loop poles in the right half-plane from the phase of a return difference (Nyquist).

    Parameters
    ----------
    det_of : callable ``ndarray (n_f,) [Hz] -> ndarray complex (n_f,)``
        ``det(I + L(j 2 pi f))`` of a loop whose ``L`` is real-rational-like (``L(-w) = conj L(w)``),
        1 at ``f = 0`` up to a real factor, and small at ``f_max_hz``.
    f_max_hz : float
        Top of the grid [Hz].
    open_loop_unstable : int
        ``P``, the open loop's poles in the right half-plane.
    df_hz : float
        Step of the starting grid [Hz]; it is refined until no step turns the phase by more than
        :data:`MAX_STEP_RAD`.
    seeds_hz : array_like
        Extra starting points [Hz] (natural frequencies, where the phase turns fastest).

    Returns
    -------
    (Z, winding, n_points)
        ``Z = P - round(2 winding)``, the winding the phase change over ``0 < f < f_max`` in turns,
        and the grid's final size.

    Raises
    ------
    ModelError
        The phase cannot be followed after :data:`MAX_REFINE` halvings (a pole on the imaginary axis).

    Source: Nyquist criterion (Skogestad & Postlethwaite, 2005, Theorem 4.9).
    """
    seeds = np.asarray(seeds_hz, dtype=float)
    seeds = seeds[(seeds > 0) & (seeds < f_max_hz)]
    f = np.unique(np.concatenate([np.arange(df_hz * 1e-3, f_max_hz, df_hz), [f_max_hz], seeds]))
    f, d = _followed(det_of, f, lambda x: f"{x:.6g} Hz (a closed-loop pole on the imaginary axis?)")
    winding = float(np.sum(np.angle(d[1:] / d[:-1])) + np.angle(d[0])) / (2 * math.pi)
    return open_loop_unstable - int(round(2 * winding)), winding, int(f.size)


def loop_stability(state: LabState, *, f_max_hz: float | None = None, df_hz: float = 1.0,
                   sigma_1_s: float = 0.0) -> LoopStability:
    """Number of unstable closed-loop poles of the lab's linear model (generalised Nyquist criterion).

    With ``sigma_1_s > 0`` the contour is shifted to ``Re s = sigma_1_s``: the count is that of the poles
    growing faster than ``e^{sigma t}`` (the structure's own poles lie left of it; the controller's count
    when ``|z| > e^{sigma T}``). A recorded oscillation that grew ``r``-fold within ``t`` seconds needs a
    pole with ``Re s >= ln(r) / t`` in the loop that made it.

    Parameters
    ----------
    state : LabState
        A closed-loop lab. Its structure is that of ``state.point_modes`` when set (the MuJoCo plant's
        linearisation), else the FE model's.
    f_max_hz : float, optional
        Top of the grid [Hz]; default the sampling frequency ``1 / T`` (twice the Nyquist frequency:
        the hold and the structure's roll-off make ``|L|`` small there).
    df_hz : float
        Step of the starting grid [Hz], refined where the phase turns fast.
    sigma_1_s : float
        Growth rate [1/s], >= 0, of the shifted contour (default 0: the imaginary axis).

    Returns
    -------
    LoopStability

    Raises
    ------
    ModelError
        Open loop, bad grid arguments, or a grid that cannot follow the phase (a closed-loop pole on the
        imaginary axis).

    Source: module notes (generalised Nyquist criterion).
    """
    if state.design is None:
        raise ModelError("the loop's stability needs a controller (the lab is open loop)")
    top = 1.0 / state.chain.period_s if f_max_hz is None else float(f_max_hz)
    if not (math.isfinite(top) and top > 0 and math.isfinite(df_hz) and 0 < df_hz < top):
        raise ModelError(f"loop_stability: f_max_hz {f_max_hz!r} and df_hz {df_hz!r} must be finite, "
                         "0 < df_hz < f_max_hz")
    if not (math.isfinite(sigma_1_s) and sigma_1_s >= 0):
        raise ModelError(f"loop_stability: sigma_1_s {sigma_1_s!r} must be finite and >= 0")
    shift = 1j * sigma_1_s / (2 * math.pi)  # f - j sigma / (2 pi) is s = sigma + j 2 pi f
    p = int(np.sum(np.abs(_controller_poles(state)) > math.exp(sigma_1_s * state.chain.period_s)))
    z, winding, n = unstable_closed_loop_poles(lambda f: return_difference(state, f - shift), top, p,
                                               df_hz=df_hz, seeds_hz=_seed_frequencies(state, top))
    closure = float(np.linalg.norm(loop_transfer(state, np.array([top - shift]))[0], 2))
    return LoopStability(z, p, winding, top, closure, n, float(sigma_1_s))


def _followed(fun, x: np.ndarray, where) -> tuple[np.ndarray, np.ndarray]:
    """``(x, fun(x))`` on the increasing grid ``x`` refined (:data:`MAX_REFINE` halvings at most) until no
    step turns the phase of ``fun`` by more than :data:`MAX_STEP_RAD`. Raises ModelError naming
    ``where(x_bad)`` where it cannot be followed (a zero on the path)."""
    d = fun(x)
    for _ in range(MAX_REFINE):
        bad = np.abs(np.angle(d[1:] / d[:-1])) > MAX_STEP_RAD
        if not bad.any():
            return x, d
        mid = 0.5 * (x[:-1][bad] + x[1:][bad])
        x_new, d_new = np.concatenate([x, mid]), np.concatenate([d, fun(mid)])
        order = np.argsort(x_new)
        x, d = x_new[order], d_new[order]
    raise ModelError(f"the phase of det(I + L) cannot be followed near {where(x[1:][bad][0])}")


def _phase_change(fun, s0: complex, s1: complex, n: int = 64) -> float:
    """Change of ``arg fun(s)`` [rad] along the straight segment from ``s0`` to ``s1``, followed on a grid of
    ``n`` steps refined where it turns fast (:func:`_followed`). Raises ModelError where it cannot be followed
    (a zero on the segment)."""
    _t, d = _followed(lambda t: fun(s0 + t * (s1 - s0)), np.linspace(0.0, 1.0, n + 1),
                      lambda t: f"s = {s0 + t * (s1 - s0):.6g} (a closed-loop pole on the contour)")
    return float(np.sum(np.angle(d[1:] / d[:-1])))


def zeros_in_box(fun, sigma: tuple[float, float], omega: tuple[float, float]) -> float:
    """Zeros minus poles of an analytic ``fun`` inside the box ``sigma[0] < Re s < sigma[1]``,
    ``omega[0] < Im s < omega[1]`` (argument principle: the phase change around its edges, counter-clockwise,
    over ``2 pi``; a float, near a whole number when the contour is followed).

    Parameters
    ----------
    fun : callable ``ndarray complex (n,) -> ndarray complex (n,)``
        Evaluated at points ``s`` [1/s] of the edges.
    sigma, omega : (float, float)
        The box's real and imaginary extents [1/s], each increasing.

    Raises
    ------
    ModelError
        Extents that are not finite and increasing (names them); a zero or pole on an edge (the phase cannot
        be followed).

    Source: the argument principle (e.g. Ahlfors, *Complex Analysis*, 3rd ed., 1979, Sec. 5.2), as the
    Nyquist criterion applies it to ``det(I + L)``.
    """
    a, b = (float(v) for v in sigma)
    c, d = (float(v) for v in omega)
    if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(c) and math.isfinite(d) and a < b and c < d):
        raise ModelError(f"zeros_in_box: sigma {sigma!r} and omega {omega!r} must be finite and increasing")
    corners = (complex(a, c), complex(b, c), complex(b, d), complex(a, d), complex(a, c))
    return sum(_phase_change(fun, s0, s1) for s0, s1 in zip(corners[:-1], corners[1:])) / (2 * math.pi)


def poles_near(state: LabState, band_hz: tuple[float, float], sigma_1_s: float) -> int:
    """Closed-loop poles of the lab's linear loop that grow faster than ``e^{sigma t}`` with a frequency in
    ``band_hz``: the zeros of ``det(I + L(s))`` in the box ``sigma_1_s < Re s < 2 pi band_hz[1]``,
    ``2 pi band_hz[0] < Im s < 2 pi band_hz[1]`` (:func:`zeros_in_box`), less the controller's own poles there
    (``ln(z) / T`` and its images ``+ j 2 pi m / T``). Which mode a loop drives unstable, where
    :func:`loop_stability` counts all of them.

    Parameters
    ----------
    state : LabState
        A closed-loop lab (its structure as in :func:`loop_stability`).
    band_hz : (float, float)
        Frequencies [Hz], 0 <= low < high <= the Nyquist frequency ``1 / (2 T)``.
    sigma_1_s : float
        Growth rate [1/s], >= 0.

    Returns
    -------
    int
        Number of such poles (the count rounded; complex poles of positive frequency count once).

    Raises
    ------
    ModelError
        Open loop, a band outside ``[0, 1 / (2 T)]``, or a pole on the box's edge.
    """
    if state.design is None:
        raise ModelError("the loop's stability needs a controller (the lab is open loop)")
    lo, hi = float(band_hz[0]), float(band_hz[1])
    period = state.chain.period_s
    if not (0 <= lo < hi <= 0.5 / period + 1e-9) or not (math.isfinite(sigma_1_s) and sigma_1_s >= 0):
        raise ModelError(f"poles_near: band {band_hz!r} Hz must lie in [0, {0.5 / period:g}] and sigma_1_s "
                         f"{sigma_1_s!r} be >= 0")
    box_s, box_w = (float(sigma_1_s), 2 * math.pi * hi + float(sigma_1_s)), (2 * math.pi * lo, 2 * math.pi * hi)
    count = zeros_in_box(lambda s: return_difference(state, s / (2j * math.pi)), box_s, box_w)
    lam = _controller_poles(state)
    s_c = np.log(lam[np.abs(lam) > 0].astype(complex)) / period
    own = 0
    for m in range(int(math.floor(box_w[0] * period / (2 * math.pi))) - 1,
                   int(math.ceil(box_w[1] * period / (2 * math.pi))) + 2):
        s_m = s_c + 2j * math.pi * m / period
        own += int(np.sum((s_m.real > box_s[0]) & (s_m.real < box_s[1]) & (s_m.imag > box_w[0])
                          & (s_m.imag < box_w[1])))
    return int(round(count)) + own
