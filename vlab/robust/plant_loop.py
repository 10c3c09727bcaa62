"""The sampled-data loop on the MuJoCo plant's linearisation: the closed-loop damping of the compared modes.

A time simulation of 4 s records (:mod:`vlab.robust.simulate`) measures
whether a loop works on the MuJoCo plant and its FRF peaks, but its line
spacing (0.25 Hz) is wider than the half-power band of the controlled modes
(the BCC's first mode at 1.85 Hz with a damping ratio of 0.05 is 0.19 Hz
wide), so a curve fit of those records would not identify their damping.
The damping comes from the same plant instead, exactly: each simulated
sample's MuJoCo plant (built from its perturbed spec, hinge chain and
geometric stiffness included) is linearised about its settled state
(:meth:`vlab.sim.MujocoPlant.modal_model`: the modes its modal damping was
designed on, mass-normalised in joint space), written as a modal plant with
the out-of-plane displacement of each mode at the actuator and response
points, and closed with the sample's chain (delay, channel gains, RC
filter, zero-order hold) in the exact sampled-data loop of
:func:`vlab.robust.sampled_loop.sampled_loop` -- the FE plant's loop with
the MuJoCo plant's modes. Modes that neither the actuators nor the response
point see (in-plane and torsion modes of a hinge chain: their displacement
there is below :data:`COUPLING_REL` of the largest) are left out: the loop
cannot move them.

Mode ``r`` is paired as on the FE plant (:func:`vlab.robust.sampled_loop.mode_damping`:
the sampled-loop eigenvalue nearest the continuous closed loop's mode ``r``);
a mode whose frequency lies more than :data:`PAIR_REL` from the nominal FE
loop's mode ``r`` is not paired (NaN).

Source: the exact discretisation of :mod:`vlab.robust.sampled_loop`
(Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, 3rd ed.,
1998, Sec. 4.3.4); modal superposition with mass-normalised shapes (e.g.
Ewins, *Modal Testing*, 2nd ed., 2000, Sec. 2.5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .sampled_loop import Plant, mode_damping, sampled_loop

#: A mode is kept when its largest displacement at the loop's points is above this share of the largest [-].
COUPLING_REL = 1e-6
#: Largest relative distance of a paired mode's frequency from the nominal FE loop's [-].
PAIR_REL = 0.15


def mujoco_modal_plant(plant, actuators, response_point: int) -> Plant:
    """The MuJoCo plant's linearisation as a modal :class:`~vlab.robust.sampled_loop.Plant`.

    Parameters
    ----------
    plant : vlab.sim.Plant
        A built plant (:func:`vlab.sim.build_plant`).
    actuators : sequence of int
        Actuator (and collocated sensor) points, channel order.
    response_point : int
        Point of the compared FRF.

    Returns
    -------
    Plant
        Modal coordinates (``m = I``, ``k = diag(omega^2)`` [1/s^2], ``c = diag(2 zeta omega)`` [1/s]) of the
        modes the loop's points see; ``b`` (n, n_act) and ``c_out`` (n,) their displacements there
        [m/sqrt(kg)].

    Raises
    ------
    SimulationError
        A point the plant lacks, or a plant whose linearisation is unstable.
    """
    from ..sim import MujocoPlant

    acts = tuple(int(p) for p in actuators)
    omega, zeta, _phi, w = MujocoPlant(plant).modal_model(acts + (int(response_point),))
    mag = np.abs(w).max(axis=0)
    keep = mag > COUPLING_REL * mag.max()
    om, ze, w = np.asarray(omega)[keep], np.asarray(zeta)[keep], w[:, keep]
    b = w[:len(acts)].T
    n = om.size
    return Plant(om, ze, b, w[len(acts)], np.eye(n), np.diag(2 * ze * om), np.diag(om ** 2), b)


@dataclass(frozen=True)
class PlantLoopDamping:
    """The sampled-data loop on one MuJoCo plant's linearisation.

    Attributes
    ----------
    damping_ratio : ndarray, shape (n_modes,)
        Closed-loop damping ratio of each compared mode [-] (NaN: not paired).
    frequency_hz : ndarray, shape (n_modes,)
        Its frequency [Hz].
    spectral_radius : float
        ``max |z|`` of the loop [-] (>= 1: unstable on the linearised plant).
    """

    damping_ratio: np.ndarray
    frequency_hz: np.ndarray
    spectral_radius: float


def plant_loop_damping(plant, nominal, controller: str, *, delay_periods: float, actuator_gain,
                       sensor_gain) -> PlantLoopDamping:
    """Closed-loop damping of the compared modes with ``controller`` on the MuJoCo plant's linearisation.

    Parameters
    ----------
    plant : vlab.sim.Plant
        The (perturbed) plant.
    nominal : vlab.robust.study.Nominal
        The designs, chains, actuators, response point, compared modes and the nominal FE loop's frequencies.
    controller : str
    delay_periods : float
        Computation delay [periods].
    actuator_gain, sensor_gain : array_like, shape (n_act,)
        Channel gains [-].

    Returns
    -------
    PlantLoopDamping

    Raises
    ------
    SimulationError
        As :func:`mujoco_modal_plant`.
    """
    modal = mujoco_modal_plant(plant, nominal.actuators, nominal.response_point)
    chain = nominal.chains[controller]
    design = nominal.designs[controller]
    ga, gs = np.asarray(actuator_gain, dtype=float), np.asarray(sensor_gain, dtype=float)
    loop = sampled_loop(modal, design, period_s=chain.period_s, delay_periods=delay_periods,
                        filter_hz=chain.filter_hz, actuator_gain=ga, sensor_gain=gs, excitation=nominal.excitation)
    n = min(nominal.n_modes, modal.omega.size)
    zeta, freq = np.full(nominal.n_modes, np.nan), np.full(nominal.n_modes, np.nan)
    zeta[:n], freq[:n] = mode_damping(loop, modal, design, n, actuator_gain=ga, sensor_gain=gs)
    ref = np.asarray(nominal.freq_hz[controller], dtype=float)
    off = ~(np.abs(freq / ref - 1.0) <= PAIR_REL)
    zeta[off], freq[off] = np.nan, np.nan
    return PlantLoopDamping(zeta, freq, loop.spectral_radius)
