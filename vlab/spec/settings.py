"""Reading the tables of a structure file that describe how it is tested, modelled and controlled.

``[instrumentation]``, ``[damping]``, ``[model_form]``, ``[reference]``,
``[reduction]``, ``[test]`` and ``[design]``: one reader function per table,
each returning the dataclasses of :mod:`vlab.spec.structure` (or plain values)
and raising :class:`vlab.errors.SpecError` naming the file and the dotted field.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..errors import SpecError
from ..io.confine import confined_file
from .reader import TableReader, is_fraction, is_number, read_damping_ratio, read_number, read_point, read_points_list
from .structure import DATA_DIR, DOF_NAMES, Damping, Instrumentation, ModelFormDeclared, StructureTest

#: Response quantities a test can compare (Sec. 5.4.2: BCC displacement, Fig. 22; grid velocity, Figs. 23-31).
RESPONSE_QUANTITIES = ("displacement", "velocity")

#: Highest test-band edge allowed [Hz]: below the Nyquist frequency of the 2 kHz laboratory loop (Sec. 5.3)
#: by a factor four, so that the digital controller, hold and RC filter act as modelled.
MAX_TEST_BAND_HZ = 250.0

#: Unit systems a ``[design]`` table's ``units`` key may name for its weights.
DESIGN_UNITS = ("SI", "thesis")

#: Fields of a ``[design]`` table that carry no unit (the damping constraint, the counts, the design model).
DESIGN_OPTIONS: dict[str, type | tuple[type, ...]] = {
    "zeta_min": (int, float), "n_modes": int, "n_f": int, "default_model": str,
}

#: Weights of a ``[design]`` table with ``units = "thesis"`` (Secs. 3.1, 6.1, 6.2: in, lbf, cs), key -> unit:
#: ``Q = q_scale I`` on the states in/cs, rad/cs, in, rad; ``R = r I`` on lbf; ``V1 = v1 I`` (the same
#: states per cs), ``V2 = v2 I`` (the velocity outputs in in/cs); ``alpha`` in 1/cs (Eqs. 4.1-4.10).
DESIGN_WEIGHTS_THESIS: dict[str, str] = {
    "q_scale": "1/x^2 for x in in/cs, rad/cs, in, rad", "r": "1/lbf^2", "v1": "(x/cs)^2 cs for the same x",
    "v2": "(in/cs)^2 cs", "alpha": "1/cs", "r_corrected": "1/lbf^2",
}

#: Weights of a ``[design]`` table with ``units = "SI"`` (m, N, s), key -> unit: one LQ weight per kind of
#: state (``Q`` diagonal on ``[q'; q]``) and per kind of state excitation noise (``V1`` diagonal), the
#: control weight on N, the measurement noise on the sensors' m/s, alpha in 1/s
#: (:mod:`vlab.design.weights` converts them to the thesis units in which the design is made).
DESIGN_WEIGHTS_SI: dict[str, str] = {
    "q_displacement": "1/m^2", "q_velocity": "s^2/m^2", "q_rotation": "1/rad^2", "q_rotation_rate": "s^2/rad^2",
    "r": "1/N^2", "r_corrected": "1/N^2",
    "v1_displacement": "m^2/s", "v1_velocity": "m^2/s^3", "v1_rotation": "rad^2/s", "v1_rotation_rate": "rad^2/s^3",
    "v2": "m^2/s", "alpha": "1/s",
}

#: Every field a ``[design]`` table may have (the ``units`` key, the unit-free options and the weights of
#: both unit systems) and its type: the controller-design settings of :class:`vlab.design.ThesisSettings`.
DESIGN_FIELDS: dict[str, type | tuple[type, ...]] = {
    "units": str, **DESIGN_OPTIONS,
    **{k: (int, float) for k in [*DESIGN_WEIGHTS_THESIS, *DESIGN_WEIGHTS_SI]},
}


def read_instrumentation(ir: TableReader | None, points: dict) -> Instrumentation | None:
    """The ``[instrumentation]`` table: actuator and sensor points, excitation and response point (Sec. 5.4).

    Parameters
    ----------
    ir : TableReader or None
        Reader of the table; None when the file has none.
    points : dict
        Point id -> (x, y) [m].

    Returns
    -------
    Instrumentation or None

    Raises
    ------
    SpecError
        An unknown or repeated point, an excitation point that is not an actuator.
    """
    if ir is None:
        return None
    acts = read_points_list(ir, "actuators", points)
    sens = read_points_list(ir, "sensors", points)
    exc = read_point(ir, "excitation", points)
    if exc not in acts:
        ir.fail("excitation", f"excitation point {exc} must be one of the actuators {list(acts)}")
    instr = Instrumentation(acts, sens, exc, read_point(ir, "response", points), ir.str("source"))
    ir.done()
    return instr


def read_damping(dr: TableReader | None) -> Damping | None:
    """The ``[damping]`` table: open-loop modal damping ratios in [0, 1) and the default of higher modes.

    Parameters
    ----------
    dr : TableReader or None
        Reader of the table; None when the file has none.

    Returns
    -------
    Damping or None
    """
    if dr is None:
        return None
    ratios = dr.raw("modal_ratios", types=(list,))
    for z in ratios:
        if not is_fraction(z):
            dr.fail("modal_ratios", f"damping ratios must be in [0, 1), got {z!r}")
    default = read_damping_ratio(dr, "default_ratio")
    damping = Damping(tuple(float(z) for z in ratios), float(default), dr.str("source"))
    dr.done()
    return damping


def read_model_form(mr: TableReader | None) -> ModelFormDeclared | None:
    """The ``[model_form]`` table: a stated relative uncertainty of the frequencies, one value or one per mode.

    Parameters
    ----------
    mr : TableReader or None
        Reader of the table; None when the file has none.

    Returns
    -------
    ModelFormDeclared or None
    """
    if mr is None:
        return None
    fr = mr.raw("frequency_rel", types=(int, float, list))
    vals = fr if isinstance(fr, list) else [fr]
    if not vals or not all(is_fraction(v) for v in vals):
        mr.fail("frequency_rel", f"expected a relative uncertainty in [0, 1) or a list of them, got {fr!r}")
    model_form = ModelFormDeclared(tuple(float(v) for v in vals), mr.str("source"))
    mr.done()
    return model_form


def reference_file(file: str, field_name: str, fname: str, path: Path | None, allow_outside: bool | None) -> str:
    """A ``[reference]`` file name checked: inside the structure file's folder or :data:`vlab.spec.DATA_DIR`.

    Parameters
    ----------
    file : str
        The structure file, named in errors.
    field_name : str
        The field (``"reference.frequencies"``), named in errors.
    fname : str
        The file name as written.
    path : Path or None
        The structure file (its folder is searched first).
    allow_outside : bool or None
        Allow files outside both folders (see :func:`vlab.io.confine.confined_file`).

    Returns
    -------
    str
        The name as given when the file is in :data:`vlab.spec.DATA_DIR` (read as ``DATA_DIR / name``), else its
        absolute real path.

    Raises
    ------
    SpecError
        Naming the file and field when the name reaches outside both folders (unless ``allow_outside``),
        is missing, not a regular file or over :data:`vlab.io.confine.MAX_NAMED_BYTES`.
    """
    folders = ([Path(path).parent] if path is not None else []) + [DATA_DIR]
    real = confined_file(fname, folders, where=f"{file}: field {field_name!r}", allow=allow_outside,
                         error=SpecError)
    data = Path(DATA_DIR).resolve()
    return fname if data in real.parents and (data / fname).resolve() == real else str(real)


def read_reference(top: TableReader, path: Path | None, allow_outside: bool | None) -> dict[str, str]:
    """The ``[reference]`` table: name -> published-table file, each checked by :func:`reference_file`.

    Parameters
    ----------
    top : TableReader
        Reader of the whole document.
    path : Path or None
        The structure file.
    allow_outside : bool or None
        See :func:`reference_file`.

    Returns
    -------
    dict[str, str]
    """
    reference = dict(top.raw("reference", {}, types=(dict,)))
    for key, fname in reference.items():
        if not isinstance(fname, str):
            top.fail(f"reference.{key}", f"expected a file name, got {fname!r}")
        reference[key] = reference_file(top.file, f"reference.{key}", fname, path, allow_outside)
    return reference


def read_reduction(rr: TableReader | None, points: dict) -> dict[str, tuple[tuple[int, str], ...]]:
    """The ``[reduction]`` table: method (``exact``, ``guyan``) -> master DOFs as ``(point, dof)`` (Sec. 3.3).

    Parameters
    ----------
    rr : TableReader or None
        Reader of the table; None when the file has none.
    points : dict
        Point id -> (x, y) [m].

    Returns
    -------
    dict[str, tuple of (int, str)]
    """
    masters: dict[str, tuple[tuple[int, str], ...]] = {}
    if rr is None:
        return masters
    rr.str("source")
    for key in [k for k in rr.table if k != "source"]:
        if key not in ("exact", "guyan"):
            rr.fail(key, "unknown reduction; use 'exact' or 'guyan'")
        labels = []
        for item in rr.raw(key, types=(list,)):
            if (not isinstance(item, list) or len(item) != 2 or not isinstance(item[0], int)
                    or item[1] not in DOF_NAMES):
                rr.fail(key, f"expected [point, dof] pairs, got {item!r}")
            if item[0] not in points:
                rr.fail(key, f"unknown point id {item[0]}; points are {sorted(points)}")
            labels.append((item[0], item[1]))
        masters[key] = tuple(labels)
    rr.done()
    return masters


def read_test(r: TableReader | None, instr: Instrumentation | None, points: dict) -> StructureTest | None:
    """The ``[test]`` table (Sec. 5.4): band and resolution [Hz], force RMS [N], modes, points, quantity.

    ``response_point`` defaults to the instrumentation's response point and
    ``measured_points`` to its sensors; the table needs ``[instrumentation]``
    (the excitation point and the actuators come from there).

    Parameters
    ----------
    r : TableReader or None
        Reader of the table; None when the file has none.
    instr : Instrumentation or None
        The ``[instrumentation]`` table read.
    points : dict
        Point id -> (x, y) [m].

    Returns
    -------
    StructureTest or None

    Raises
    ------
    SpecError
        No ``[instrumentation]``, a band beyond :data:`vlab.spec.MAX_TEST_BAND_HZ`, a resolution leaving fewer than
        4 lines, a response point not recorded, an unknown response quantity.
    """
    if r is None:
        return None
    r.str("source")
    if instr is None:
        r.fail("", "a [test] table needs an [instrumentation] table (actuators, sensors, excitation point)")
    band = r.raw("band_hz", types=(list,))
    if (len(band) != 2 or not all(is_number(x) and math.isfinite(x) for x in band)
            or not 0 <= band[0] < band[1] <= MAX_TEST_BAND_HZ):
        r.fail("band_hz", f"expected [low, high] with 0 <= low < high <= {MAX_TEST_BAND_HZ:g} Hz, got {band!r}")
    res = read_number(r, "resolution_hz")
    if res > (band[1] - band[0]) / 4:
        r.fail("resolution_hz", f"{res:g} Hz leaves fewer than 4 lines in the band {band!r} Hz")
    rms = read_number(r, "rms_n", high=1e4)
    n_modes = r.int("n_modes")
    if n_modes < 1:
        r.fail("n_modes", f"must be >= 1, got {n_modes}")
    resp = r.int("response_point", instr.response)
    if resp not in points:
        r.fail("response_point", f"unknown point id {resp}; points are {sorted(points)}")
    measured = read_points_list(r, "measured_points", points, instr.sensors)
    if resp not in set(measured) | set(instr.actuators):
        r.fail("response_point", f"point {resp} is neither measured {list(measured)} nor an actuator "
                                 f"{list(instr.actuators)}: its FRF would not be recorded")
    quantity = r.str("response_quantity", "velocity")
    if quantity not in RESPONSE_QUANTITIES:
        r.fail("response_quantity", f"{quantity!r} is not one of {RESPONSE_QUANTITIES}")
    r.done()
    return StructureTest((float(band[0]), float(band[1])), res, rms, n_modes, resp, measured, quantity)


def read_design(r: TableReader | None) -> dict[str, Any]:
    """The ``[design]`` table: its options and weights, type- and range-checked (all optional; Secs. 4, 6).

    Weights (:data:`DESIGN_WEIGHTS_THESIS` or :data:`DESIGN_WEIGHTS_SI`) are read only with a ``units``
    key, ``"SI"`` or ``"thesis"``: a table that sets a weight without it is refused, not reinterpreted,
    and so is a weight of the other unit system. A table that sets no weight needs no ``units``.

    Parameters
    ----------
    r : TableReader or None
        Reader of the table; None when the file has none.

    Returns
    -------
    dict[str, Any]
        The fields given (empty when there is no table), the weights in the unit system of ``"units"``
        (converted by :func:`vlab.design.design_settings`).

    Raises
    ------
    SpecError
        Naming the file and the field ``design.<key>``: a weight without ``units`` (the message names the
        two values), an unknown ``units``, a weight of the other unit system, a value out of range.
    """
    if r is None:
        return {}
    r.str("source")
    out: dict[str, Any] = {}
    units = r.str("units", None)
    if units is not None and units not in DESIGN_UNITS:
        r.fail("units", f"{units!r} is not one of \"SI\", \"thesis\" (the unit system of the weights)")
    weights = DESIGN_WEIGHTS_SI if units == "SI" else DESIGN_WEIGHTS_THESIS
    for key in [k for k in r.table if k in DESIGN_WEIGHTS_THESIS or k in DESIGN_WEIGHTS_SI]:
        if units is None:
            r.fail(key, "a weight needs the unit system of the [design] table: add units = \"SI\" (m, N, s) "
                        "or units = \"thesis\" (the dissertation's in, lbf, cs); the weights are not "
                        "reinterpreted silently")
        if key not in weights:
            other = "thesis" if units == "SI" else "SI"
            r.fail(key, f"a weight of units = \"{other}\", not of units = \"{units}\"; with \"{units}\" the "
                        f"weights are {', '.join(weights)}")
    for key, types in {**DESIGN_OPTIONS, **{k: (int, float) for k in weights}}.items():
        if r.has(key):
            out[key] = _design_value(r, key, types)
    if units is not None:
        out["units"] = units
    r.done()
    return out


def _design_value(r: TableReader, key: str, types) -> Any:
    """One ``[design]`` value checked: counts >= 1, a known design model, zeta_min in (0, 1), alpha >= 0,
    the other weights > 0."""
    if types is int:
        v = r.int(key)
        if v < 1:
            r.fail(key, f"must be >= 1, got {v}")
    elif types is str:
        v = r.str(key)
        if v not in ("full", "exact", "guyan"):
            r.fail(key, f"{v!r} is not one of full, exact, guyan")
    elif key == "zeta_min":
        v = read_number(r, key, high=1.0, high_open=True)
    elif key == "alpha":
        v = read_number(r, key, low_open=False)
    else:
        v = read_number(r, key)
    return v
