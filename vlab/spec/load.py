"""Loading a structure file: :func:`vlab.spec.load_spec` (a file) and :func:`vlab.spec.spec_from_dict` (a parsed document).

The document's tables are read in order by the readers of
:mod:`vlab.spec.geometry` and :mod:`vlab.spec.settings`; the changes a
diagnosis appended (:mod:`vlab.spec.changes`) are applied last.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from ..errors import SpecError
from ..io.confine import read_utf8
from .changes import CHANGE_TABLES, apply_change_tables, damping_of, release_supports
from .hardware import read_hardware
from .geometry import (read_crosspieces, read_masses, read_members, read_points, read_sections, read_springs,
                       read_strings, read_structure, read_supports)
from .reader import TableReader
from .settings import (read_damping, read_design, read_instrumentation, read_model_form, read_reduction,
                       read_reference, read_test)
from .structure import STRUCTURES_DIR, StructureSpec


def load_spec(name_or_path: str | Path, *, allow_outside: bool | None = None) -> StructureSpec:
    """Load a structure definition.

    Parameters
    ----------
    name_or_path : str or Path
        ``"bcc"``/``"grid"`` (a file in ``assets/structures``) or a path to a TOML file.
    allow_outside : bool, optional
        Allow ``[reference]`` files outside the structure file's folder and
        the packaged data (:func:`vlab.spec.spec_from_dict`).

    Returns
    -------
    StructureSpec
        All values in SI.

    Raises
    ------
    SpecError
        If the file is missing or unreadable, is not UTF-8 (names the byte
        offset and line), is not valid TOML, has a missing, unknown or
        mistyped field, a non-positive stiffness/mass, a value outside
        :data:`vlab.spec.PLAUSIBLE_RANGES`, an unknown point id, or a ``[reference]``
        file outside its folders (:func:`vlab.spec.spec_from_dict`); the message names the file and field.
    """
    path = Path(name_or_path)
    if path.suffix != ".toml":
        path = STRUCTURES_DIR / f"{name_or_path}.toml"
        if not path.exists():
            known = sorted(p.stem for p in STRUCTURES_DIR.glob("*.toml"))
            raise SpecError(f"unknown structure {str(name_or_path)!r}: not one of {known} nor a path to a "
                            ".toml file (`vlab init KIND PATH` writes one)")
    if not path.exists():
        raise SpecError(f"{path}: file not found")
    text = read_utf8(path, SpecError, hint="; TOML files must be UTF-8")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: not valid TOML: {exc}") from None
    return spec_from_dict(doc, path=path, allow_outside=allow_outside)


@dataclass
class _Elements:
    """The element tables of a document: supports both as built and with the DOFs of ``replaces_support``
    springs released; ``added`` holds the ``(table, index)`` of the entries marked ``added = true``."""

    members: list
    strings: list
    masses: list
    crosspieces: list
    springs: list
    released: list
    built: tuple
    added: set
    fail_release: Callable
    supports: tuple = ()


def _read_elements(top: TableReader, points: dict, sections: dict) -> _Elements:
    """Members, strings, masses, crosspieces, springs and supports of the document, in that order."""
    members, strings = read_members(top, points, sections), read_strings(top, points)
    masses, added_masses = read_masses(top, points)
    crosspieces = read_crosspieces(top, points, sections)
    springs, added_springs, released = read_springs(top, points)
    built = read_supports(top, points)

    def fail_release(i: int, msg: str) -> None:
        TableReader(top.file, top.table["springs"][i], f"springs[{i}]").fail("replaces_support", msg)

    added = {("masses", i) for i in added_masses} | {("springs", i) for i in added_springs}
    el = _Elements(members, strings, masses, crosspieces, springs, released, built, added, fail_release)
    el.supports = release_supports(built, released, fail_release)
    return el


def _before_changes(spec: StructureSpec, el: _Elements) -> StructureSpec:
    """The structure without the elements marked ``added`` and their released supports."""
    return spec.replace(
        masses=tuple(m for i, m in enumerate(el.masses) if ("masses", i) not in el.added),
        springs=tuple(sp for i, sp in enumerate(el.springs) if ("springs", i) not in el.added),
        supports=release_supports(el.built, [r for r in el.released if ("springs", r[0]) not in el.added],
                                  el.fail_release))


def spec_from_dict(doc: dict[str, Any], *, path: Path | None = None,
                   allow_outside: bool | None = None) -> StructureSpec:
    """Build a :class:`vlab.spec.StructureSpec` from a parsed TOML document (see :func:`vlab.spec.load_spec`).

    The changes a diagnosis found (``vlab update``: ``[[member_stiffness]]``, ``[[joint_flexibility]]``,
    ``[[mode_damping]]``, springs that replace a support, elements marked ``added = true``) are applied
    last, keeping the damping matrix of the structure before them (:mod:`vlab.spec.changes`).

    Parameters
    ----------
    doc : dict
        The document, as ``tomllib.loads`` returns it; physical values as
        ``{ value, unit, source }`` tables, converted to SI here.
    path : Path, optional
        File the document came from: stored in the spec and named in errors
        (``"<dict>"`` when None); its folder is where ``[reference]`` files
        are looked for first (then :data:`vlab.spec.DATA_DIR`).
    allow_outside : bool, optional
        Allow ``[reference]`` files outside those two folders (None: the
        environment, :func:`vlab.io.confine.outside_allowed`).

    Returns
    -------
    StructureSpec
        The structure in SI, the changes applied.

    Raises
    ------
    SpecError
        If a field is missing, unknown or mistyped, a unit does not fit its
        quantity, a value is not positive (or negative where zero is allowed)
        or outside :data:`vlab.spec.PLAUSIBLE_RANGES`, a coordinate is not finite or beyond
        :data:`vlab.spec.MAX_COORDINATE_M`, two consecutive member points coincide,
        ``elements_per_segment`` exceeds :data:`vlab.spec.MAX_ELEMENTS_PER_SEGMENT`, a
        point, section or DOF is unknown, a referenced data file is missing,
        reaches outside the structure file's folder and the packaged data,
        is not a regular file or is too large,
        member ids repeat, or a ``[test]`` / ``[design]`` value is out of range
        (a band beyond :data:`vlab.spec.MAX_TEST_BAND_HZ`, a resolution leaving fewer than
        4 lines, a response point not recorded, ...); the message names the
        file and the dotted field.
    """
    file = str(path) if path else "<dict>"
    top = TableReader(file, doc, "")
    name, title, active, grav = read_structure(top.sub("structure"))
    points = read_points(top.sub("points"))
    sections = read_sections(top.sub("sections"))
    el = _read_elements(top, points, sections)
    instr = read_instrumentation(top.sub("instrumentation", None), points)
    damping = read_damping(top.sub("damping", None))
    model_form = read_model_form(top.sub("model_form", None))
    reference = read_reference(top, path, allow_outside)
    masters = read_reduction(top.sub("reduction", None), points)
    mj = dict(top.raw("mujoco", {}, types=(dict,)))
    top.raw("calibration", {}, types=(dict,))
    test = read_test(top.sub("test", None), instr, points)
    design = read_design(top.sub("design", None))
    hardware = read_hardware(top.sub("hardware", None), instr)
    changes = {name: top.raw(name, [], types=(list,)) for name in CHANGE_TABLES}
    top.done()

    ids = [m.id for m in el.members]
    if len(set(ids)) != len(ids):
        raise SpecError(f"{file}: field 'members': duplicate member ids {ids}")
    spec = StructureSpec(
        name=name, title=title, path=path, active_dofs=active, gravity_direction=grav, points=points,
        sections=sections, members=tuple(el.members), strings=tuple(el.strings), masses=tuple(el.masses),
        crosspieces=tuple(el.crosspieces), springs=tuple(el.springs), supports=tuple(el.supports),
        instrumentation=instr, damping=damping, model_form=model_form, reference=reference, master_dofs=masters,
        mujoco=mj, test=test, design_settings=design, hardware=hardware, raw=doc)
    base = None
    if el.added or changes["member_stiffness"] or changes["joint_flexibility"]:  # the structure before them
        base = _before_changes(spec, el)
    return damping_of(apply_change_tables(spec, changes, lambda t, where: TableReader(file, t, where)), base)
