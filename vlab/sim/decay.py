"""A simulated free decay of a plant: the first mode's frequency and damping ratio in the time domain.

The plant starts at rest, displaced in one mode's shape; the frequency comes
from the zero crossings of ``w`` at the shape's largest point, the damping
ratio from the logarithmic decrement of the peaks between them. The time
domain half of the FE cross-check (:mod:`vlab.sim.crosscheck`).

Source: Ewins, *Modal Testing*, Sec. 4.2 (logarithmic decrement).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import SimulationError
from .damping_matrix import load_modal_damping
from .linearize import SimModes, modes, settle, site_jacobian_w
from .plant import Plant

@dataclass(frozen=True)
class FreeDecay:
    """Result of :func:`free_decay`.

    Attributes
    ----------
    frequency_hz : float
        Mean frequency from the zero crossings [Hz].
    damping_ratio : float
        From the logarithmic decrement of successive peaks [-].
    point : int
        Point whose ``w`` was analysed.
    t : ndarray, shape (n,)
        Times [s].
    w : ndarray, shape (n,)
        Out-of-plane displacement at ``point`` [m].
    """

    frequency_hz: float
    damping_ratio: float
    point: int
    t: np.ndarray
    w: np.ndarray


def free_decay(plant: Plant, mode: int = 1, *, amplitude_m: float = 1e-3, duration_s: float | None = None,
               sim_modes: SimModes | None = None) -> FreeDecay:
    """Simulate a free decay from a displacement in one mode's shape.

    Parameters
    ----------
    plant : Plant
    mode : int
        Plant mode number (1-based) of the initial shape.
    amplitude_m : float
        Largest initial out-of-plane displacement [m].
    duration_s : float, optional
        Length of the run [s]; default 20 periods.
    sim_modes : SimModes, optional
        The plant's modes (computed when omitted).

    Returns
    -------
    FreeDecay

    Raises
    ------
    SimulationError
        If the run diverges or shows fewer than 4 zero crossings.
    """
    model = plant.model
    pts = sorted(plant.spec.points)
    if sim_modes is None:
        sim_modes = modes(model, pts, mode)
    d0 = settle(model)
    phi = sim_modes.joint_shapes[:, mode - 1]
    shape = sim_modes.shapes[:, mode - 1]
    k = int(np.argmax(np.abs(shape)))
    point = sim_modes.points[k]
    jw = site_jacobian_w(model, d0, [f"p{point}"])[0]
    scale = amplitude_m / float(jw @ phi)
    d = mujoco.MjData(model)
    d.qpos[:] = d0.qpos
    mujoco.mj_integratePos(model, d.qpos, phi * scale, 1.0)
    mujoco.mj_forward(model, d)
    f0 = sim_modes.frequencies_hz[mode - 1]
    if duration_s is None:
        duration_s = 20.0 / f0
    n = int(round(duration_s / model.opt.timestep))
    sid = model.site(f"p{point}").id
    z0 = float(d0.site_xpos[sid, 2])
    w = np.empty(n + 1)
    w[0] = d.site_xpos[sid, 2] - z0
    md = load_modal_damping(model)
    for i in range(n):
        if md is None:
            mujoco.mj_step(model, d)
        else:
            md.step(model, d)
        w[i + 1] = d.site_xpos[sid, 2] - z0
    if not np.all(np.isfinite(w)):
        raise SimulationError("free decay diverged (non-finite displacement): timestep too large for the chain")
    t = np.arange(n + 1) * model.opt.timestep
    s = np.sign(w)
    idx = np.flatnonzero((s[:-1] > 0) & (s[1:] <= 0))  # downward zero crossings
    if idx.size < 3:
        raise SimulationError(f"free decay: only {idx.size} zero crossings in {duration_s:.3g} s")
    tc = t[idx] + w[idx] / (w[idx] - w[idx + 1]) * model.opt.timestep
    periods = np.diff(tc)
    freq = 1.0 / float(np.mean(periods))
    # peaks between crossings -> logarithmic decrement
    peaks = np.array([np.max(np.abs(w[a:b])) for a, b in zip(idx[:-1], idx[1:])])
    if peaks.size >= 2 and peaks[-1] > 0:
        delta = math.log(peaks[0] / peaks[-1]) / (peaks.size - 1)
        zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    else:
        zeta = math.nan
    return FreeDecay(freq, zeta, point, t, w)
