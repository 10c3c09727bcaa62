"""Option checks of the command line, run before any work: numbers, seeds, input files, output folders, the
structure argument.

Each raises :class:`~vlab.errors.OptionError` (or the error of the file's own check) naming the option and the
value, so that the command exits with status 2 before anything is computed or written.
"""

from __future__ import annotations

import math
from pathlib import Path

from ..errors import OptionError
from .options import OutputFormat

#: Range of ``--period-ms`` [ms]: from 10x the PC-1000's fastest rate (2 kHz, Sec. 5.3) to a Nyquist
#: frequency of 10 Hz, the top of the grid's test band (the BCC's, 25 Hz, needs <= 20 ms).
PERIOD_MS_RANGE = (0.05, 50.0)


def output_format(fmt: OutputFormat, as_json: bool) -> str:
    """The output format of ``--format`` and the older ``--json`` (= ``--format json``); OptionError if they clash."""
    if as_json and fmt not in (OutputFormat.table, OutputFormat.json):
        raise OptionError(f"--json contradicts --format {fmt.value}: give one of the two")
    return "json" if as_json else fmt.value


def number(option: str, value: float | None, *, low: float | None = None, high: float | None = None,
           low_open: bool = False, what: str = "a number") -> float | None:
    """``value`` of ``option`` checked finite and in range (None passes); raises OptionError naming both."""
    if value is None:
        return None
    v = float(value)
    if not math.isfinite(v):
        raise OptionError(f"{option} must be a finite number ({what}), got {value!r}")
    if low is not None and (v < low or (low_open and v == low)):
        raise OptionError(f"{option} must be {'>' if low_open else '>='} {low:g} ({what}), got {value!r}")
    if high is not None and v > high:
        raise OptionError(f"{option} must be <= {high:g} ({what}), got {value!r}")
    return v


def seed(value: int) -> int:
    """``--seed`` checked in [0, 2**32)."""
    if value < 0 or value >= 2**32:
        raise OptionError(f"--seed must be an integer in [0, 2**32), got {value!r}")
    return value


def period_s(period_ms: float | None) -> float | None:
    """``--period-ms`` in seconds (None stays None); raises OptionError outside :data:`PERIOD_MS_RANGE`."""
    if period_ms is None:
        return None
    if not (math.isfinite(period_ms) and period_ms > 0):
        raise OptionError(f"--period-ms must be a positive number of milliseconds, got {period_ms!r}")
    v = number("--period-ms", period_ms, low=PERIOD_MS_RANGE[0], high=PERIOD_MS_RANGE[1],
               what="controller sampling period [ms]")
    return v * 1e-3


def input_file(option: str, value: str | None) -> str | None:
    """A file to read: exists and is a regular file (None passes)."""
    from ..errors import DataFileError

    if value is None:
        return None
    if str(value).strip() == "":
        raise OptionError(f"{option}: an empty path is not a file")
    p = Path(value)
    if not p.exists():
        raise DataFileError(f"{option} {value}: file not found")
    if not p.is_file():
        raise DataFileError(f"{option} {value}: not a regular file")
    return value


def mjcf_input(value: str | None) -> str | None:
    """``--mjcf``: a regular file whose includes and assets stay in its folder (:func:`vlab.io.confine.check_mjcf_files`)."""
    from ..io.confine import check_mjcf_files

    if input_file("--mjcf", value) is not None:
        check_mjcf_files(value)
    return value


def out_dir(value: str, default: str, overwrite: bool):
    """``--out`` checked (:func:`vlab.io.atomic.check_output_dir`); the default's parent ``out/`` may be created."""
    from ..io.atomic import check_output_dir

    return check_output_dir(value, overwrite=overwrite, option="--out", create_parent=(value == default))


def load_structure(value: str):
    """The spec of a structure argument: a shipped name or a ``.toml`` path (SpecError naming the file: exit 2)."""
    from ..spec import load_spec

    if str(value).strip() == "":
        raise OptionError("structure: an empty name; give bcc, grid or the path of a .toml file")
    spec = load_spec(value)
    fixed_w = {sup.point for sup in spec.supports if "w" in sup.fixed}
    if spec.points and fixed_w >= set(spec.points):
        from ..errors import SpecError

        raise SpecError(f"{spec.path or value}: field 'supports': every point ({len(spec.points)}) is fixed out of "
                        "plane ('w' in fixed): nothing can vibrate; leave at least one point free")
    return spec


def fe_model_of(spec):
    """The checked FE model of ``spec``: cached for a shipped structure file, built afresh for any other file."""
    from ..fe import build_fe_model
    from ..models import check_fe_model, nominal_fe_model
    from ..spec import STRUCTURES_DIR

    if spec.path is not None and spec.path.resolve() == (STRUCTURES_DIR / f"{spec.name}.toml").resolve():
        return nominal_fe_model(spec.name)
    return check_fe_model(build_fe_model(spec))


def plant_estimate(spec, segments: int | None = None, *, crosscheck: bool = False) -> dict:
    """Plan the MuJoCo plant of ``spec`` (its size checks: ResourceError, exit 2) and estimate its build.

    Returns :func:`vlab.sim.estimate.plant_estimate`'s ``states``, ``time_s`` [s], ``memory_bytes`` [bytes]
    with ``what`` (``"N bodies, M joint DOFs"``).
    """
    from ..sim import SimOptions
    from ..sim.estimate import plant_estimate as estimate
    from ..sim.planner import plan_structure

    plan, _ = plan_structure(spec, SimOptions(segments_per_element=segments).resolved(spec))
    n_joints = sum(len(b.joints) for b in plan.bodies.values())
    return {**estimate(n_joints, crosscheck=crosscheck), "what": f"{len(plan.bodies)} bodies, {n_joints} joint DOFs"}


def confirm_long_run(option: str, seconds: float, what: str, yes: bool, hint: str) -> None:
    """Refuse a run estimated to take longer than :data:`vlab.robust.scheduler.CONFIRM_ABOVE_S` unless ``yes``.

    Raises
    ------
    OptionError
        Naming ``option``, the estimate, ``what`` it is made of and ``hint``.
    """
    from ..robust.scheduler import CONFIRM_ABOVE_S
    from ..units import format_duration

    if seconds > CONFIRM_ABOVE_S and not yes:
        raise OptionError(f"{option}: the run would take about {format_duration(seconds)} ({what}); pass --yes "
                          f"to run it, or {hint}")
