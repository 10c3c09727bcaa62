"""vlab's naming contract for a MuJoCo plant, and the checks of a plant loaded from MJCF.

A plant's elements are found by name: voice-coil actuators ``coil<ID>``,
velocity sensors ``vel<ID>`` (``actuatorvel``, or ``framelinvel`` /
``velocimeter`` whose z component is used) and sites ``p<ID>``
(:func:`numbered`, :func:`sensor_rows`). What vlab cannot honour is refused
when an MJCF is loaded (:func:`check_plant_contract`): a missing or renamed
``coil<ID>`` / ``vel<ID>``, a ``vel<ID>`` of another sensor type, and a
non-zero ``noise`` (MuJoCo does not apply it; the lab's sensor noise is
``--noise``), ``delay``, ``interval`` or ``nsample``; and so are non-finite
or implausible physical values (:func:`check_plant_values`).

Sources: MuJoCo documentation (``doc/XMLreference.rst``: sensor, actuator);
Sec. 5.3 of the dissertation (the PC-1000's controller periods).
"""

from __future__ import annotations

import math
import re

import mujoco
import numpy as np

from ..errors import ModelError, SimulationError


def numbered(model: mujoco.MjModel, objtype, count: int, prefix: str) -> dict[int, int]:
    """The objects of one type named ``<prefix><ID>``, by their number.

    Parameters
    ----------
    model : mujoco.MjModel
    objtype : mujoco.mjtObj
        The object type (actuator, sensor, site).
    count : int
        Objects of that type in the model (``model.nu``, ``model.nsensor``, ...).
    prefix : str
        The name's prefix (``"coil"``, ``"vel"``, ``"p"``).

    Returns
    -------
    dict of int to int
        ``ID`` -> object id, for every object whose whole name is the prefix and a number.
    """
    out = {}
    pat = re.compile(rf"^{prefix}(\d+)$")
    for i in range(count):
        name = mujoco.mj_id2name(model, objtype, i)
        m = pat.match(name or "")
        if m:
            out[int(m.group(1))] = i
    return out


def sensor_rows(model: mujoco.MjModel) -> dict[int, int]:
    """Point id -> row in ``sensordata`` of the out-of-plane velocity of every ``vel<ID>`` sensor.

    Parameters
    ----------
    model : mujoco.MjModel
        A vlab plant (compiled or loaded from MJCF).

    Returns
    -------
    dict of int to int
        ``actuatorvel`` sensors: their address; ``framelinvel`` and
        ``velocimeter``: address + 2 (the z component, in the sensor's frame).

    Raises
    ------
    SimulationError
        For a ``vel<ID>`` sensor of another type.
    """
    rows = {}
    for p, i in numbered(model, mujoco.mjtObj.mjOBJ_SENSOR, model.nsensor, "vel").items():
        kind = int(model.sensor_type[i])
        adr = int(model.sensor_adr[i])
        if kind == int(mujoco.mjtSensor.mjSENS_ACTUATORVEL):
            rows[p] = adr
        elif kind in (int(mujoco.mjtSensor.mjSENS_FRAMELINVEL), int(mujoco.mjtSensor.mjSENS_VELOCIMETER)):
            rows[p] = adr + 2
        else:
            raise SimulationError(f"sensor vel{p} has type {mujoco.mjtSensor(kind).name}: not a velocity sensor")
    return rows


#: Velocity sensor types a ``vel<ID>`` sensor may have, with the offset of the out-of-plane component.
VELOCITY_SENSORS = {
    int(mujoco.mjtSensor.mjSENS_ACTUATORVEL): 0,
    int(mujoco.mjtSensor.mjSENS_FRAMELINVEL): 2,
    int(mujoco.mjtSensor.mjSENS_VELOCIMETER): 2,
}


def check_plant_contract(model: mujoco.MjModel, *, actuators, sensors, source: str) -> None:
    """Refuse a plant whose actuators or sensors break vlab's naming contract.

    The contract (as :func:`vlab.sim.build_plant` writes it): a voice-coil
    actuator ``coil<ID>`` at every actuator point, and a velocity sensor
    ``vel<ID>`` of type ``actuatorvel``, ``framelinvel`` or ``velocimeter`` at
    every sensor / measured point. Every ``vel<ID>`` sensor of the model must
    also be one vlab reads as MuJoCo computes it: ``noise`` 0 (MuJoCo 4.0 does
    not apply sensor noise; give the lab's sensor noise with ``--noise``,
    :attr:`vlab.lab.loop.HardwareChain.noise_m_s`), and no ``delay``,
    ``interval`` or ``nsample`` (the loop samples every sensor at each tick;
    the chain's delay and sensor lag model the hardware). A ``cutoff`` is
    honoured (MuJoCo clips the reading to ``[-cutoff, cutoff]`` m/s).

    Parameters
    ----------
    model : mujoco.MjModel
        The plant, e.g. loaded from an edited MJCF.
    actuators : sequence of int
        Points that need a ``coil<ID>`` actuator.
    sensors : sequence of int
        Points that need a ``vel<ID>`` velocity sensor.
    source : str
        Where the model came from (the MJCF file), named in the error.

    Raises
    ------
    ModelError
        Naming ``source`` and every missing, renamed or unsupported element
        (and the model's sensors/actuators outside the naming scheme, which a
        renamed one would be).
    """
    problems = []
    coils = numbered(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu, "coil")
    vels = numbered(model, mujoco.mjtObj.mjOBJ_SENSOR, model.nsensor, "vel")
    for p in dict.fromkeys(actuators):
        if p not in coils:
            problems.append(f"actuator coil{p} (voice coil at point {p}) is missing")
    for p in dict.fromkeys(sensors):
        if p not in vels:
            problems.append(f"sensor vel{p} (velocity sensor at point {p}) is missing")
    for p, i in sorted(vels.items()):
        kind = int(model.sensor_type[i])
        if kind not in VELOCITY_SENSORS:
            problems.append(f"sensor vel{p} has type {mujoco.mjtSensor(kind).name}; vlab reads only "
                            "actuatorvel, framelinvel and velocimeter sensors")
        if float(model.sensor_noise[i]) != 0.0:
            problems.append(f"sensor vel{p} has noise=\"{float(model.sensor_noise[i]):g}\", which MuJoCo does not "
                            "apply; remove the attribute and give the sensor noise with --noise "
                            "(HardwareChain.noise_m_s)")
        if float(model.sensor_delay[i]) != 0.0:
            problems.append(f"sensor vel{p} has delay=\"{float(model.sensor_delay[i]):g}\", which vlab does not "
                            "support; use --delay-periods (HardwareChain.delay_periods) or sensor_lag_hz")
        if float(model.sensor_interval[i][0]) != 0.0:
            problems.append(f"sensor vel{p} has interval=\"{float(model.sensor_interval[i][0]):g}\", which vlab "
                            "does not support (the loop samples every sensor each tick)")
        if int(model.sensor_history[i][0]) != 0:
            problems.append(f"sensor vel{p} has nsample=\"{int(model.sensor_history[i][0])}\", which vlab does "
                            "not support")
    if problems:
        others = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i) or f"#{i}" for i in range(model.nsensor)
                  if i not in vels.values()]
        others += [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) or f"#{i}" for i in range(model.nu)
                   if i not in coils.values()
                   and not (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) or "").startswith("prestress")]
        hint = f" (elements outside the naming scheme: {', '.join(others)})" if others else ""
        raise ModelError(f"{source}: the plant breaks vlab's naming contract (actuators coil<ID>, velocity "
                         f"sensors vel<ID>): " + "; ".join(problems) + hint)


#: Longest physics step an MJCF plant may have [s]: the PC-1000's slowest controller period
#: (2 samples/s, Sec. 5.3); the loop needs whole physics steps per controller period.
MAX_TIMESTEP_S = 0.5
#: Heaviest plausible body of a plant [kg]: the lab structures weigh a few kg to tens of kg
#: (the grid's end plates, 27 kg, are the heaviest parts); 1000 kg is a unit or exponent slip.
MAX_BODY_MASS_KG = 1.0e3

# (MjModel attribute, object type, what it is) of the values checked for finiteness
_FINITE_FIELDS = (
    ("body_mass", mujoco.mjtObj.mjOBJ_BODY, "mass [kg]"),
    ("body_inertia", mujoco.mjtObj.mjOBJ_BODY, "inertia [kg*m^2]"),
    ("body_pos", mujoco.mjtObj.mjOBJ_BODY, "pos [m]"),
    ("jnt_stiffness", mujoco.mjtObj.mjOBJ_JOINT, "stiffness"),
    ("jnt_pos", mujoco.mjtObj.mjOBJ_JOINT, "pos [m]"),
    ("jnt_axis", mujoco.mjtObj.mjOBJ_JOINT, "axis"),
    ("qpos_spring", None, "springref"),
    ("dof_damping", mujoco.mjtObj.mjOBJ_DOF, "damping"),
    ("dof_armature", mujoco.mjtObj.mjOBJ_DOF, "armature"),
    ("actuator_gear", mujoco.mjtObj.mjOBJ_ACTUATOR, "gear"),
    ("actuator_gainprm", mujoco.mjtObj.mjOBJ_ACTUATOR, "gainprm"),
    ("tendon_stiffness", mujoco.mjtObj.mjOBJ_TENDON, "stiffness"),
    ("tendon_damping", mujoco.mjtObj.mjOBJ_TENDON, "damping"),
    ("tendon_lengthspring", mujoco.mjtObj.mjOBJ_TENDON, "springlength [m]"),
    ("site_pos", mujoco.mjtObj.mjOBJ_SITE, "pos [m]"),
)


def check_plant_values(model: mujoco.MjModel, *, source: str) -> None:
    """Refuse an MJCF plant with non-finite or implausible physical values.

    MuJoCo 4.0 loads an MJCF with ``mass="inf"``, ``timestep="nan"`` or
    ``gravity="0 nan 0"`` (it only warns about a NaN on stderr); such a plant
    would run and give NaN or meaningless results. Checked: the physics step
    (finite, positive, at most :data:`MAX_TIMESTEP_S` = 0.5 s, the PC-1000's
    slowest period, Sec. 5.3), gravity (finite), every body mass (finite, at
    most :data:`MAX_BODY_MASS_KG` = 1000 kg), and body inertias and positions,
    joint stiffnesses, positions, axes and spring references, DOF damping and
    armature, actuator gears and gains, tendon stiffnesses, damping and
    spring lengths, site positions and custom numeric data (finite).

    Parameters
    ----------
    model : mujoco.MjModel
        The loaded plant.
    source : str
        Where it came from (the MJCF file), named in the error.

    Raises
    ------
    ModelError
        Naming ``source``, the element (``body 'J1'``), the attribute and the value.
    """
    ts = float(model.opt.timestep)
    if not (math.isfinite(ts) and 0.0 < ts <= MAX_TIMESTEP_S):
        raise ModelError(f"{source}: option timestep=\"{ts:g}\" s must be positive, finite and at most "
                         f"{MAX_TIMESTEP_S:g} s (the PC-1000's slowest controller period, Sec. 5.3)")
    g = np.asarray(model.opt.gravity, dtype=float)
    if not np.all(np.isfinite(g)):
        raise ModelError(f"{source}: option gravity=\"{' '.join(f'{v:g}' for v in g)}\" is not finite")
    for attr, objtype, what in _FINITE_FIELDS:
        arr = np.asarray(getattr(model, attr), dtype=float)
        if arr.size == 0:
            continue
        rows = np.flatnonzero(~np.all(np.isfinite(arr.reshape(arr.shape[0], -1)), axis=1))
        if rows.size:
            i = int(rows[0])
            if objtype is None:
                label = f"{attr}[{i}]"
            elif objtype == mujoco.mjtObj.mjOBJ_DOF:  # DOFs are named by their joint
                j = int(model.dof_jntid[i])
                label = f"joint {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f'#{j}'!r}"
            else:
                label = f"{objtype.name[6:].lower()} {mujoco.mj_id2name(model, objtype, i) or f'#{i}'!r}"
            raise ModelError(f"{source}: {label}: {what} {np.ravel(arr[i]).tolist()} is not finite")
    for i in range(model.nnumeric):  # custom data (vlab's modal damping matrices)
        adr, size = int(model.numeric_adr[i]), int(model.numeric_size[i])
        vals = np.asarray(model.numeric_data[adr:adr + size], dtype=float)
        bad = np.flatnonzero(~np.isfinite(vals))
        if bad.size:
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_NUMERIC, i) or f"#{i}"
            raise ModelError(f"{source}: custom numeric {name!r}: value {vals[bad[0]]} at position {bad[0]} "
                             "is not finite")
    heavy = np.flatnonzero(np.asarray(model.body_mass) > MAX_BODY_MASS_KG)
    if heavy.size:
        i = int(heavy[0])
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) or f"#{i}"
        raise ModelError(f"{source}: body {name!r}: mass {float(model.body_mass[i]):g} kg is beyond "
                         f"{MAX_BODY_MASS_KG:g} kg, implausible for the lab's structures (a unit slip?)")
