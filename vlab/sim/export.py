"""Export the complete plant as MJCF, and load it back.

The file is ``MjSpec.to_xml()`` of the plant's spec: bodies with explicit
inertia, hinge/slide joints with stiffness and damping, string, spring and
modal-damping tendons, loop welds or the forest's closure tendons and their
equalities, voice-coil and prestress actuators,
velocity sensors and the ``p<ID>`` sites. It loads with
:meth:`mujoco.MjModel.from_xml_path` alone and reproduces the plant's
linearised frequencies (tested).

Source: ``doc/python.rst`` ("Save to XML").
"""

from __future__ import annotations

from pathlib import Path

import mujoco

from ..errors import DataFileError, SimulationError
from .builder import Plant


def export_mjcf(plant: Plant, path: str | Path, *, overwrite: bool = True) -> Path:
    """Write the plant as an MJCF file.

    Its header comment names the structure (title and name) and the spec's
    file name only, never a folder (no absolute path, no user home). Run the
    file with :func:`vlab.sim.load_plant_for_experiment` (``vlab experiment
    --mjcf``), which checks its actuators and sensors against the naming
    contract (:func:`vlab.sim.runtime.check_plant_contract`).

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
    try:
        xml = plant.mjspec.to_xml()
    except Exception as exc:  # compile error inside to_xml
        raise SimulationError(f"cannot export the plant: {exc}") from exc
    try:
        with atomic_file(path, overwrite=overwrite) as tmp:
            tmp.write_text(xml)
    except OSError as exc:
        raise SimulationError(f"cannot write {path}: {exc}") from exc
    return path


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
