"""Cross-check of the MuJoCo plant against the FE model of the same spec.

Two checks:

* **Modal** -- the FE modes (:func:`vlab.fe.modal_analysis`) and the plant's
  linearised modes (:func:`vlab.sim.linearize.modes`) are compared at the
  structure's points (``w`` DOFs / ``p<ID>`` sites). Modes are paired by the
  Modal Assurance Criterion (one-to-one assignment maximising the total MAC,
  Hungarian algorithm); each pair reports the frequency error and MAC.
  Plant modes without an FE counterpart (the crosspiece arms' anti-symmetric
  bending, absent from the FE's single-DOF crosspiece) stay unpaired.
* **Time domain** -- the first mode's frequency from a simulated free decay
  (initial displacement in the mode's shape, zero crossings of ``w`` at its
  largest point), and its damping ratio from the logarithmic decrement.

Sources: MAC, Allemang & Brown (1982); DESIGN.md (cross-check targets);
Ewins, *Modal Testing*, Sec. 4.2 (logarithmic decrement).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import scipy.optimize

from ..errors import SimulationError
from ..spec import StructureSpec
from .builder import Plant, SimOptions, build_plant
from .linearize import SimModes, modes, settle


def mac_matrix(phi_a: np.ndarray, phi_b: np.ndarray) -> np.ndarray:
    """MAC between every column of ``phi_a`` and of ``phi_b``.

    Parameters
    ----------
    phi_a : ndarray, shape (n_points, n_a)
    phi_b : ndarray, shape (n_points, n_b)

    Returns
    -------
    ndarray, shape (n_a, n_b)
        ``|a^H b|^2 / (a^H a  b^H b)``; 0 where a shape is zero at all points.

    Raises
    ------
    SimulationError
        If the two sets have different numbers of points.
    """
    a = np.asarray(phi_a)
    b = np.asarray(phi_b)
    if a.shape[0] != b.shape[0]:
        raise SimulationError(f"MAC: shapes have {a.shape[0]} and {b.shape[0]} points")
    na = np.sum(np.abs(a) ** 2, axis=0)
    nb = np.sum(np.abs(b) ** 2, axis=0)
    cross = np.abs(a.conj().T @ b) ** 2
    den = np.outer(na, nb)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(den > 1e-30 * max(den.max(initial=0.0), 1e-300), cross / den, 0.0)
    return np.clip(out, 0.0, 1.0)


def pair_modes(fe_shapes: np.ndarray, sim_shapes: np.ndarray, *, min_mac: float = 0.5
               ) -> list[tuple[int | None, float]]:
    """Pair each FE mode with one plant mode by MAC (one-to-one, maximal total MAC).

    Parameters
    ----------
    fe_shapes : ndarray, shape (n_points, n_fe)
    sim_shapes : ndarray, shape (n_points, n_sim)
    min_mac : float
        Pairs with a lower MAC are reported unpaired.

    Returns
    -------
    list of (int or None, float)
        For each FE mode: the index of its plant mode (None if unpaired) and the MAC.
    """
    mac = mac_matrix(fe_shapes, sim_shapes)
    rows, cols = scipy.optimize.linear_sum_assignment(-mac)
    out: list[tuple[int | None, float]] = [(None, 0.0)] * mac.shape[0]
    for r, c in zip(rows, cols):
        out[r] = (int(c), float(mac[r, c])) if mac[r, c] >= min_mac else (None, float(mac[r, c]))
    return out


@dataclass(frozen=True)
class ModePair:
    """One row of the modal cross-check.

    Attributes
    ----------
    fe_mode : int
        FE mode number (1-based).
    fe_hz : float
        FE frequency [Hz].
    sim_mode : int or None
        Plant mode number (1-based), None if unpaired.
    sim_hz : float
        Plant frequency [Hz] (nan if unpaired).
    error_pct : float
        ``100 (sim - fe) / fe`` [%].
    mac : float
        MAC at the structure points [-].
    sim_zeta : float
        Plant damping ratio [-].
    """

    fe_mode: int
    fe_hz: float
    sim_mode: int | None
    sim_hz: float
    error_pct: float
    mac: float
    sim_zeta: float


@dataclass(frozen=True)
class CrossCheck:
    """Result of :func:`crosscheck`.

    Attributes
    ----------
    structure : str
    pairs : tuple of ModePair
    points : tuple of int
        Points used for the MAC.
    sim_modes : SimModes
    fe_frequencies_hz : ndarray, shape (n_modes,)
    """

    structure: str
    pairs: tuple[ModePair, ...]
    points: tuple[int, ...]
    sim_modes: SimModes
    fe_frequencies_hz: np.ndarray

    def max_error_pct(self) -> float:
        """Largest |frequency error| [%] over the pairs (inf if any FE mode is unpaired)."""
        return max((abs(p.error_pct) if p.sim_mode is not None else math.inf) for p in self.pairs)

    def min_mac(self) -> float:
        """Smallest MAC over the pairs."""
        return min(p.mac for p in self.pairs)

    def passed(self, tol_pct: float, min_mac: float) -> bool:
        """True when every FE mode is paired within ``tol_pct`` [%] and with MAC >= ``min_mac``."""
        return self.max_error_pct() <= tol_pct and self.min_mac() >= min_mac

    def table(self) -> str:
        """A plain-text table (mode, FE Hz, plant mode, plant Hz, error %, MAC, zeta)."""
        lines = [f"{self.structure}: MuJoCo plant vs FE model",
                 " FE mode   FE [Hz]  plant mode  plant [Hz]  error [%]    MAC    zeta"]
        for p in self.pairs:
            sm = "-" if p.sim_mode is None else str(p.sim_mode)
            lines.append(f"{p.fe_mode:8d} {p.fe_hz:9.4f} {sm:>11} {p.sim_hz:11.4f} {p.error_pct:+10.3f} "
                         f"{p.mac:7.4f} {p.sim_zeta:7.4f}")
        return "\n".join(lines)


def crosscheck(spec_or_plant: StructureSpec | Plant, n_modes: int, *, options: SimOptions | None = None,
               points: list[int] | None = None) -> CrossCheck:
    """Compare the first ``n_modes`` FE modes with the plant's modes.

    Parameters
    ----------
    spec_or_plant : StructureSpec or Plant
        A spec (a plant is built with ``options``) or a built plant.
    n_modes : int
        Number of FE modes compared.
    options : SimOptions, optional
        Build options when a spec is given.
    points : list of int, optional
        Points for the MAC; default all points whose ``w`` is free in the FE model.

    Returns
    -------
    CrossCheck

    Raises
    ------
    SimulationError
        If the plant cannot be built, settled or linearised.
    ModelError
        If the FE model cannot be built.
    """
    from ..fe import modal_analysis

    plant = spec_or_plant if isinstance(spec_or_plant, Plant) else build_plant(spec_or_plant, options)
    spec = plant.spec
    fe = fe_reference(spec)
    if points is None:
        points = [p for p in sorted(spec.points) if (p, "w") in fe.dofs]
    fem = modal_analysis(fe.m, fe.k, n_modes)
    rows = [fe.dofs.index(p, "w") for p in points]
    phi_fe = fem.shapes[rows, :]
    n_sim = min(3 * n_modes + 6, 2 * plant.model.nv)
    sm = modes(plant.model, points, n_sim)
    pairs = pair_modes(phi_fe, sm.shapes)
    out = []
    for r, (j, mac) in enumerate(pairs):
        f_fe = float(fem.frequencies_hz[r])
        if j is None:
            out.append(ModePair(r + 1, f_fe, None, math.nan, math.nan, mac, math.nan))
        else:
            f = float(sm.frequencies_hz[j])
            out.append(ModePair(r + 1, f_fe, j + 1, f, 100 * (f - f_fe) / f_fe, mac, float(sm.damping_ratios[j])))
    return CrossCheck(spec.name, tuple(out), tuple(points), sm, fem.frequencies_hz)


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
    from .linearize import site_jacobian_w

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
    from .damping import load_modal_damping

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


def fe_reference(spec: StructureSpec):
    """The FE model used as cross-check reference (:func:`vlab.fe.build_fe_model`).

    Its crosspiece single-DOF model carries the arms' exact participating mass
    (:func:`vlab.fe.crosspiece.cantilever_tip_mass_sdof`), which the plant's
    flexible arms converge to.

    Parameters
    ----------
    spec : StructureSpec
        The structure the plant was built from.

    Returns
    -------
    FEModel

    Raises
    ------
    ModelError
        If the FE model cannot be assembled.
    """
    from ..fe import build_fe_model

    return build_fe_model(spec)


@dataclass(frozen=True)
class StudyRow:
    """One discretisation of :func:`convergence_study`.

    Attributes
    ----------
    segments : int
        Links per member segment (crosspiece arms alike).
    layout : str
        Hinge layout (``"gauss"`` or ``"uniform"``).
    timestep_s : float
        Step used [s] (automatic unless given).
    nv : int
        Degrees of freedom.
    f_max_hz : float
        Highest hinge-spring frequency [Hz].
    errors_pct : tuple of float
        Frequency error of each FE mode [%].
    macs : tuple of float
        MAC of each FE mode.
    decay_hz : float
        First-mode frequency from a free decay [Hz] (nan if not run).
    us_per_step : float
        Wall time of one bare ``mj_step`` [us] (nan if not measured).
    """

    segments: int
    layout: str
    timestep_s: float
    nv: int
    f_max_hz: float
    errors_pct: tuple[float, ...]
    macs: tuple[float, ...]
    decay_hz: float
    us_per_step: float

    @property
    def max_error_pct(self) -> float:
        """Largest |error| [%]."""
        return max(abs(e) for e in self.errors_pct)

    @property
    def min_mac(self) -> float:
        """Smallest MAC."""
        return min(self.macs)


def convergence_study(spec: StructureSpec, n_modes: int, *, segments=(2, 3, 4), layouts=("gauss",),
                      timesteps=(None,), decay: bool = False, speed_steps: int = 0) -> list[StudyRow]:
    """Cross-check the plant for several segment counts, hinge layouts and timesteps.

    Parameters
    ----------
    spec : StructureSpec
    n_modes : int
        FE modes compared.
    segments : sequence of int
        Links per member segment (and per crosspiece arm); shear-dominated
        members keep their default (see :class:`~vlab.sim.builder.SimOptions`).
    layouts : sequence of str
        Hinge layouts.
    timesteps : sequence of float or None
        Steps [s]; None = automatic.
    decay : bool
        Also measure the first mode's frequency from a free decay.
    speed_steps : int
        Steps timed per row (0: no timing).

    Returns
    -------
    list of StudyRow

    Raises
    ------
    SimulationError
        If a combination cannot be built or is unstable (timestep too large).
    """
    import time

    from .timestep import hinge_omega_max

    rows = []
    for layout in layouts:
        for n in segments:
            for dt in timesteps:
                opts = SimOptions(segments_per_element=n, crosspiece_segments=n, hinge_layout=layout,
                                  timestep_s=dt, modal_damping=False, stiffness_damping_s=0.0,
                                  check_timestep=dt is None)
                plant = build_plant(spec, opts)
                cc = crosscheck(plant, n_modes)
                omega, _ = hinge_omega_max(plant.model)
                f_decay = math.nan
                if decay:
                    j = cc.pairs[0].sim_mode or 1
                    f_decay = free_decay(plant, j, sim_modes=cc.sim_modes).frequency_hz
                us = math.nan
                if speed_steps:
                    d = mujoco.MjData(plant.model)
                    t0 = time.perf_counter()
                    mujoco.mj_step(plant.model, d, nstep=speed_steps)
                    us = (time.perf_counter() - t0) / speed_steps * 1e6
                rows.append(StudyRow(n, layout, plant.timestep_s, plant.model.nv, omega / (2 * math.pi),
                                     tuple(p.error_pct for p in cc.pairs), tuple(p.mac for p in cc.pairs),
                                     f_decay, us))
    return rows
