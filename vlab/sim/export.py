"""Export the complete plant as MJCF, and load it back.

The file is ``MjSpec.to_xml()`` of the plant's spec: bodies with explicit
inertia, hinge/slide joints with stiffness and damping, string, spring and
modal-damping tendons, loop welds or the forest's closure tendons and their
equalities, voice-coil and prestress actuators,
velocity sensors and the ``p<ID>`` sites. It loads with
:meth:`mujoco.MjModel.from_xml_path` alone and reproduces the plant's
linearised frequencies (tested).

Two things are added to MuJoCo's own XML so that the file runs as it is
written (``vlab experiment S.toml --mjcf S.xml``):

* a ``vel<ID>`` sensor (``framelinvel`` of site ``p<ID>``) at every point the
  structure's ``[test]`` table measures (``measured_points``,
  ``response_point``) that has none yet: the naming contract
  (:func:`vlab.sim.contract.check_plant_contract`) asks for one at every
  recorded point;
* the physics timestep at full precision (the shortest decimal that parses
  back to the same double, Python's ``repr``): MuJoCo writes reals with six
  significant digits, and a step like 0.5 ms / 12 would then no longer divide
  the controller period.

The naming contract and which attribute to edit for which physics are
documented in docs/mjcf.md.

Source: ``doc/python.rst`` ("Save to XML"); ``doc/XMLreference.rst``
(``option/timestep``, ``sensor/framelinvel``).
"""

from __future__ import annotations

import re
from pathlib import Path

import mujoco

from ..errors import DataFileError, SimulationError
from .plant import Plant


def export_mjcf(plant: Plant, path: str | Path, *, overwrite: bool = True) -> Path:
    """Write the plant as an MJCF file.

    Its header comment names the structure (title and name) and the spec's
    file name only, never a folder (no absolute path, no user home). Run the
    file with :func:`vlab.sim.load_plant_for_experiment` (``vlab experiment
    --mjcf``), which checks its actuators and sensors against the naming
    contract (:func:`vlab.sim.contract.check_plant_contract`).

    Parameters
    ----------
    plant : Plant
    path : str or Path
        Target file (``.xml``); its parent folder must exist (it is not
        created). Written atomically (:func:`vlab.io.atomic.atomic_file`): a
        temporary file beside it renamed onto it when complete.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    OutputError
        Empty path, not ``.xml``, a folder, an existing file without
        ``overwrite``, or a missing or read-only parent folder.
    SimulationError
        If the spec does not compile or the file cannot be written.
    """
    from ..io.atomic import atomic_file, check_output_file

    path = check_output_file(path, overwrite=overwrite, option="path", suffix=".xml")
    xml = plant_xml(plant)
    try:
        with atomic_file(path, overwrite=overwrite) as tmp:
            tmp.write_text(xml)
    except OSError as exc:
        raise SimulationError(f"cannot write {path}: {exc}") from exc
    return path


def recorded_points(plant: Plant) -> tuple[int, ...]:
    """Points whose velocity an experiment on the plant records, in order.

    Parameters
    ----------
    plant : Plant

    Returns
    -------
    tuple of int
        The plant's sensor points (actuator points first, then
        ``[instrumentation].sensors``), then the ``[test]`` table's
        ``measured_points`` and ``response_point`` not among them (none without
        a ``[test]`` table: a shipped structure's test measures its sensors).
    """
    pts = list(plant.sensor_points)
    test = plant.spec.test
    if test is not None:
        pts += [*test.measured_points, test.response_point]
    return tuple(dict.fromkeys(pts))


def plant_xml(plant: Plant) -> str:
    """The plant's MJCF text: MuJoCo's XML with a sensor at every recorded point and the exact timestep.

    Parameters
    ----------
    plant : Plant

    Returns
    -------
    str
        ``MjSpec.to_xml()`` of a copy of the plant's spec with a ``vel<ID>``
        ``framelinvel`` sensor (world frame, z component = w' [m/s]) on site
        ``p<ID>`` for each of :func:`recorded_points` without one, and the
        ``option`` element's ``timestep`` [s] written as ``repr`` of the
        plant's step.

    Raises
    ------
    SimulationError
        If the spec does not compile, or the written timestep does not read
        back as the plant's step.

    Source: ``doc/XMLreference.rst`` (``option/timestep``, ``sensor/framelinvel``).
    """
    ms = plant.mjspec.copy()
    have = {s.name for s in ms.sensors}
    for p in recorded_points(plant):
        if f"vel{p}" in have:
            continue
        s = ms.add_sensor(name=f"vel{p}", type=mujoco.mjtSensor.mjSENS_FRAMELINVEL,
                          objtype=mujoco.mjtObj.mjOBJ_SITE, objname=f"p{p}")
        s.info = f"spec [test]: velocity sensor at point {p}: world-frame velocity, z component = w' [m/s]"
    try:
        xml = ms.to_xml()
    except Exception as exc:  # compile error inside to_xml
        raise SimulationError(f"cannot export the plant: {exc}") from exc
    h = plant.timestep_s
    xml = _OPTION_TIMESTEP.sub(lambda m: f"{m.group(1)}{h!r}{m.group(3)}", xml, count=1)
    found = _OPTION_TIMESTEP.search(xml)
    written = float(found.group(2)) if found is not None else mujoco.MjSpec().option.timestep  # absent: default
    if written != h:
        raise SimulationError(f"cannot export the plant: its timestep {h!r} s is not written exactly in the "
                              f"MJCF <option> element")
    return xml


# the option element's timestep attribute (MuJoCo writes it unless it is MuJoCo's default)
_OPTION_TIMESTEP = re.compile(r'(<option\b[^>]*?\btimestep=")([^"]*)(")')


def load_mjcf(path: str | Path, *, allow_outside: bool | None = None) -> mujoco.MjModel:
    """Load an exported plant, its includes and assets checked first.

    Parameters
    ----------
    path : str or Path
        The MJCF file.
    allow_outside : bool, optional
        Allow ``<include>`` and asset files outside the file's folder (None:
        the environment, :func:`vlab.io.confine.outside_allowed`).

    Returns
    -------
    mujoco.MjModel

    Raises
    ------
    DataFileError
        If the file is missing or not a loadable MJCF model, or names an
        include or asset outside its folder, missing, not a regular file or
        too large (:func:`vlab.io.confine.check_mjcf_files`; names the file).
    """
    from ..io.confine import check_mjcf_files

    path = Path(path)
    if not path.exists():
        raise DataFileError(f"{path}: file not found")
    check_mjcf_files(path, allow=allow_outside)
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except Exception as exc:
        raise DataFileError(f"{path}: not a loadable MJCF model: {exc}") from exc
