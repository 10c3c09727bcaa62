"""What a hypothesis needs to know besides the lab state: scales of the structure and signals of the data.

:func:`context_for` makes the :class:`Context` of the nominal lab and the data.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..data.measured import FrfData
from ..model.labmodel import LabState, natural_frequencies, predict_frf


@dataclass
class Context:
    """Scales and signals a hypothesis needs besides the lab state (filled in by the problem).

    Attributes
    ----------
    band_hz : (float, float)
        Analysed band [Hz].
    closed_loop : bool
        A controller was running.
    total_mass_kg : float
        Translational mass of the structure [kg].
    f1_hz : float
        First natural frequency of the nominal model [Hz].
    point_stiffness : dict
        Point -> static driving-point stiffness of the nominal model from its modes [N/m].
    point_mass : dict
        Point -> smallest modal mass seen at the point over the modes in the band,
        ``1 / max_r phi_r(p)^2`` (mass-normalised shapes) [kg]: the added mass that
        would shift the most affected mode by about 30 %.
    point_damping : dict
        Point -> dashpot ``min_r 2 zeta_r omega_r / phi_r(p)^2`` [N*s/m] that would
        double the damping of the most affected mode in the band.
    freq_hz : ndarray or None
        Excited lines [Hz] (recordings).
    force_amplitude : ndarray or None
        Excitation amplitude per line [N] (recordings).
    velocity_rms : dict
        Point -> measured RMS velocity [m/s] (recordings).
    excitation_point : int or None
        Point of the excitation force.
    command_rms : dict
        Actuator point -> RMS amplifier command [N] of the nominal lab (cache for ``saturation``).
    _k_no_gravity : dict
        Cache of FE stiffness matrices built without gravity (``gravity_prestress``).
    _predicted : dict
        Cache of :meth:`predicted_velocity_rms`.
    """

    band_hz: tuple[float, float]
    closed_loop: bool
    total_mass_kg: float
    f1_hz: float
    point_stiffness: dict
    point_mass: dict = field(default_factory=dict)
    point_damping: dict = field(default_factory=dict)
    freq_hz: np.ndarray | None = None
    force_amplitude: np.ndarray | None = None
    velocity_rms: dict = field(default_factory=dict)
    excitation_point: int | None = None
    command_rms: dict = field(default_factory=dict)
    _k_no_gravity: dict = field(default_factory=dict, repr=False)
    _predicted: dict = field(default_factory=dict, repr=False)

    @property
    def has_signals(self) -> bool:
        """True when excitation amplitudes are known (time-history input)."""
        return self.force_amplitude is not None

    def velocity_rms_of(self, state: LabState, point: int) -> float:
        """RMS velocity [m/s] at ``point`` for the recorded excitation: the measured value where the point
        was recorded, else predicted with ``state`` (not cached; NaN without time histories)."""
        if point in self.velocity_rms:
            return self.velocity_rms[point]
        if not self.has_signals:
            return float("nan")
        h = predict_frf(state, self.freq_hz, excitation_point=self.excitation_point, output_points=(point,))
        return float(np.sqrt(0.5 * np.sum(np.abs(h[:, 0] * self.force_amplitude) ** 2)))

    def predicted_velocity_rms(self, state: LabState, point: int) -> float:
        """Like :meth:`velocity_rms_of`, cached per point: the velocity level of the nominal ``state``
        (for scales)."""
        if point not in self._predicted:
            self._predicted[point] = self.velocity_rms_of(state, point)
        return self._predicted[point]


def context_for(state: LabState, band_hz: tuple[float, float], data) -> Context:
    """Scales of the lab ``state`` in ``band_hz`` and signals of ``data`` (FrfData or other) for the hypotheses."""
    fe = state.fe
    w_rows = [i for i, (_n, dof) in enumerate(fe.dofs.labels) if dof == "w"]
    u = np.zeros(fe.n)
    u[w_rows] = 1.0
    total = float(u @ fe.m @ u)
    f, zeta, phi = natural_frequencies(state)
    om = 2 * np.pi * f
    keep = om > 1e-6
    inband = keep & (f >= band_hz[0]) & (f <= band_hz[1])
    if not inband.any():
        inband = keep
    kp, mp, cp = {}, {}, {}
    for p in state.spec.points:
        if (p, "w") in fe.dofs:
            i = fe.dofs.index(p, "w")
            flex = float(np.sum(phi[i, keep] ** 2 / om[keep] ** 2))
            if flex > 0:
                kp[p] = 1.0 / flex
            ph2 = phi[i, inband] ** 2
            if ph2.max() > 0:
                mp[p] = float(1.0 / ph2.max())
                with np.errstate(divide="ignore"):
                    cp[p] = float(np.min(2 * np.maximum(zeta[inband], 1e-4) * om[inband] / np.maximum(ph2, 1e-300)))
    closed = state.design is not None
    if isinstance(data, FrfData):
        return Context(band_hz, closed, total, float(f[keep][0]), kp, mp, cp, data.freq_hz, data.force_amplitude,
                       dict(data.velocity_rms), data.excitation_point)
    return Context(band_hz, False, total, float(f[keep][0]), kp, mp, cp)
