"""vlab: a virtual laboratory for active vibration control of flexible structures.

Rebuilds the laboratory of the 1990 dissertation "Experimental and theoretical
investigation of optimal control methods with model reduction": FE models of
the Beam Cross-Cable and Hanging Grid structures, reduction and correction,
MuJoCo plants, a 2 kHz digital control loop, modal-test style measurements and
mismatch diagnosis.

Python entry points (stable signatures; ``docs/python-api.md`` is the
tutorial): :func:`load_spec`, :func:`modes`, :func:`design`,
:func:`run_experiment`, :func:`diagnose`, :func:`update`, :func:`verify_update`,
:func:`export_mjcf`. They are
imported lazily, so ``import vlab`` stays fast.

``vlab.design`` and ``vlab.diagnose`` are also the names of subpackages.
``vlab.design("bcc")`` and ``vlab.diagnose("bcc", "recording.uff")`` always
call the entry points below. Until the subpackage has been imported
(``import vlab.design``, or by vlab itself), ``vlab.design`` is the entry-point
function and has no attribute ``design_controller``: reach the subpackage's
names with ``from vlab.design import design_controller``. Once it is imported,
``vlab.design`` is the module, made callable.
"""

from __future__ import annotations

import sys
import types
from pathlib import Path
from typing import Any

__version__ = "0.1.0"

__all__ = ["load_spec", "modes", "design", "run_experiment", "diagnose", "update", "verify_update", "export_mjcf",
           "__version__"]


def load_spec(name_or_path: str | Path):
    """Load a structure spec: a shipped structure's name or the path of a TOML file.

    Parameters
    ----------
    name_or_path : str or Path
        ``"bcc"`` (Beam Cross-Cable), ``"grid"`` (Hanging Grid) or a TOML file
        in the format of ``assets/structures/*.toml``.

    Returns
    -------
    StructureSpec
        SI units throughout (:class:`vlab.spec.StructureSpec`).

    Raises
    ------
    SpecError
        Unknown name, missing file or an invalid field (named in the message).
    """
    from .spec import load_spec as _load

    return _load(name_or_path)


def _fe_model(structure):
    from .models import nominal_fe_model
    from .spec import StructureSpec

    if isinstance(structure, (str, Path)) and str(structure).endswith(".toml"):
        structure = load_spec(structure)  # a user's file: read afresh (it may have been edited), not cached
    if isinstance(structure, StructureSpec):
        from .fe import build_fe_model
        from .models import check_fe_model

        return check_fe_model(build_fe_model(structure))
    return nominal_fe_model(str(structure))



def modes(structure: Any = "bcc", n: int = 12, *, reduction: str = "full"):
    """Natural frequencies and mode shapes of a structure's FE model (``vlab modes``).

    Parameters
    ----------
    structure : str or StructureSpec
        ``"bcc"``, ``"grid"``, the path of a ``.toml`` structure file (read afresh
        on every call) or a spec from :func:`load_spec`.
    n : int
        Number of modes, 1 to the model's degrees of freedom.
    reduction : {"full", "exact", "guyan"}
        Model: the full FE model, its exact reduction or its Guyan reduction
        (:func:`vlab.models.reduce_model`).

    Returns
    -------
    frequencies_hz : ndarray, shape (n,)
        Undamped natural frequencies [Hz], ascending (compare with Table 1
        for the BCC, Table 3 for the grid).
    shapes : ndarray, shape (n_dof, n)
        Mass-normalised mode shapes over the model's degrees of freedom
        (``fe.dofs`` of the full model, the masters of a reduced one).

    Raises
    ------
    OptionError
        ``n`` out of range or an unknown ``reduction``.
    SpecError, ModelError, ReductionError
        As :func:`load_spec` and the model build.
    """
    import numpy as np

    from .errors import OptionError
    from .fe import modal_analysis

    if reduction not in ("full", "exact", "guyan"):
        raise OptionError(f"reduction {reduction!r} is not one of full, exact, guyan")
    fe = _fe_model(structure)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= fe.m.shape[0]:
        raise OptionError(f"n must be an integer in [1, {fe.m.shape[0]}] (the model's degrees of freedom), got {n!r}")
    if reduction == "full":
        m, k = fe.m, fe.k
    else:
        from .models import reduce_model

        red = reduce_model(fe, reduction)
        m, k = red.m, red.k
        n = min(int(n), m.shape[0])
    res = modal_analysis(m, k, int(n))
    return res.frequencies_hz, res.shapes


def design(structure: Any = "bcc", controller: str = "mfdrf", *, reduction: str | None = None, seed: int = 0,
           period_s: float | None = None, measured_modes=None):
    """Design one of the dissertation's controllers with its settings (``vlab design``).

    Parameters
    ----------
    structure : str or StructureSpec
        As :func:`modes`.
    controller : {"mfdrf", "lqdrf", "lqdrf-diag", "lqg", "lqr"}
        Controller type.
    reduction : {"full", "exact", "guyan", "corrected-guyan"}, optional
        Design model; None = the thesis's choice (DRF on the full model for
        the BCC, everything else on the structure's default reduction).
    seed : int
        Seed of the optimiser's multi-start, in [0, 2**32).
    period_s : float, optional
        Sampling period of the discrete realization [s]; None = the thesis's
        (Sec. 5.3: LQG 1 ms, the others 0.5 ms).
    measured_modes : (ndarray, ndarray), optional
        For ``"corrected-guyan"``: measured frequencies [Hz], shape (m,), and
        shapes at the Guyan masters, shape (n_masters, m).

    Returns
    -------
    ControllerDesign
        Gains, closed-loop frequencies [Hz] and damping ratios, performance
        index, realization (:class:`vlab.design.ControllerDesign`).

    Raises
    ------
    ModelError
        Unknown controller or design model, a period that is not positive.
    """
    from .design import design_controller

    return design_controller(_fe_model(structure), controller, model=reduction, measured_modes=measured_modes,
                             seed=seed, period_s=period_s)


def _checked_run_numbers(delay_periods, noise_m_s, duration_s, period_s, seed) -> float:
    """Check :func:`run_experiment`'s numbers; return the delay [sampling periods] (None: the PC-1000's).

    Raises
    ------
    OptionError
        Naming the first number that is not finite, out of its range or not a number, or a seed that is
        not an integer in [0, 2**32).
    """
    import math

    from .errors import OptionError

    if delay_periods is None:  # imported here: `import vlab` stays light
        from .lab.blocks import PC1000_DELAY_PERIODS

        delay_periods = PC1000_DELAY_PERIODS
    for name, v, strict in (("delay_periods", delay_periods, False), ("noise_m_s", noise_m_s, False),
                            ("duration_s", duration_s, True), ("period_s", period_s, True)):
        try:
            x = None if v is None or isinstance(v, bool) else float(v)
        except (TypeError, ValueError):
            x = math.nan
        if v is not None and (x is None or not math.isfinite(x) or x < 0.0 or (strict and x <= 0.0)):
            raise OptionError(f"{name} must be a finite number {'>' if strict else '>='} 0, got {v!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
        raise OptionError(f"seed must be an integer in [0, 2**32), got {seed!r}")
    return float(delay_periods)


def run_experiment(structure: Any = "bcc", controller: str = "mfdrf", *, plant: str = "mujoco",
                   excitation: str = "random", reduction: str | None = None, duration_s: float | None = None,
                   delay_periods: float | None = None, period_s: float | None = None, noise_m_s: float = 1e-6,
                   seed: int = 0, mjcf: str | Path | None = None, out_dir: str | Path | None = None,
                   overwrite: bool = False, progress=None):
    """Run a closed-loop experiment and measure it like a modal test (``vlab experiment``).

    The defaults are those of the command: the thesis's hardware chain
    (Sec. 5.3), the structure's test (Sec. 5.4), the MuJoCo plant.

    Parameters
    ----------
    structure : str or StructureSpec
        ``"bcc"``, ``"grid"``, the path of a structure file or a spec from
        :func:`load_spec`, with a test definition (its ``[test]`` table or a
        shipped one: :func:`vlab.experiment.config.test_definition`).
    controller : {"none", "lqg", "mfdrf", "lqdrf", "lqdrf-diag"}
        Controller in the loop (``"none"``: open loop).
    plant : {"mujoco", "linear"}
        MuJoCo plant, or the linear FE model stepped exactly (fast).
    excitation : {"random", "sweep", "impulse"}
        Periodic test force in the structure's band.
    reduction : {"full", "exact", "guyan", "corrected-guyan"}, optional
        Design model; None = the thesis's choice.
    duration_s : float, optional
        Run length [s], at least two records of ``1 / resolution`` (BCC 40 s,
        grid 100 s); None = the settling records plus two measured.
    delay_periods : float, optional
        Computation delay [sampling periods], >= 0; None = the PC-1000's 1.35 (Sec. 5.3).
    period_s : float, optional
        Controller sampling period [s]; None = the thesis's for the controller.
    noise_m_s : float
        Velocity-sensor noise standard deviation [m/s], >= 0.
    seed : int
        Seed of excitation, noise and design, in [0, 2**32).
    mjcf : str or Path, optional
        An exported (and edited) MJCF plant to run (``plant="mujoco"``).
    out_dir : str or Path, optional
        Folder to write the outputs to (``results.json``, ``recording.uff``,
        ``frf.uff``, figures, ``run.rrd``), as ``vlab experiment --out``;
        None = nothing written.
    overwrite : bool
        Replace an existing non-empty ``out_dir``.
    progress : callable, optional
        Receives the fraction of the run done, in [0, 1].

    Returns
    -------
    ExperimentResult
        Measured and predicted modes (``.modes``: frequencies [Hz], damping
        ratios, peak level ratios), FRFs, the recording
        (:class:`vlab.experiment.runner.ExperimentResult`).

    Raises
    ------
    OptionError
        A value out of range (named), ``controller="lqr"`` (it needs every
        state measured: use ``"lqg"``).
    SpecError
        Unknown structure, invalid file, or no test definition.
    ModelError, SimulationError, MeasurementError, OutputError
        As :func:`vlab.experiment.runner.run_experiment` and the output writer.
    """
    from .errors import OptionError
    from .experiment.config import ExperimentConfig, default_chain, test_definition
    from .experiment.runner import run_experiment as _run

    if controller == "lqr":
        raise OptionError("controller 'lqr' needs every state measured; the laboratory ran it as LQG (use 'lqg')")
    delay_periods = _checked_run_numbers(delay_periods, noise_m_s, duration_s, period_s, seed)
    chain = default_chain(controller, delay_periods=delay_periods, noise_m_s=noise_m_s,
                          **({} if period_s is None else {"period_s": period_s}))
    fe = _fe_model(structure)
    test_definition(fe.spec)  # SpecError before any work when the structure has no test
    cfg = ExperimentConfig(structure=fe.spec.name, controller=controller, reduction=reduction, excitation=excitation,
                           duration_s=duration_s, chain=chain, seed=seed, plant=plant,
                           mjcf=Path(mjcf) if mjcf is not None else None)
    out_path = None
    if out_dir is not None:
        from .io.atomic import check_output_dir

        out_path = check_output_dir(str(out_dir), overwrite=overwrite, option="out_dir", create_parent=False)
    from .diagnose.instability_cause import oscillation_cause

    result = _run(cfg, fe, progress=progress, explain_oscillation=oscillation_cause)
    if out_path is not None:
        from .experiment.results import write_outputs

        write_outputs(result, fe.spec, out_path, spawn=False, overwrite=overwrite)
    return result


def diagnose(structure: Any, recording: str | Path, *, controller: str | None = None, out_dir: str | Path | None = None,
             plant: str = "auto", baseline: str | Path | None = None, seed: int | None = None, **options: Any):
    """Locate a mismatch between a recording and the simulation, name and fit the missing physics (``vlab diagnose``).

    Parameters
    ----------
    structure : str or StructureSpec
        As :func:`modes`.
    recording : str or Path
        UFF 58 time histories (as :func:`run_experiment` writes them), UFF 58
        FRFs, or a CSV modal table.
    controller : {"none", "lqg", "mfdrf", "lqdrf", "lqdrf-diag"}, optional
        Controller that was running during the recording; default: the
        recording's metadata, else "none". One that contradicts the metadata
        raises OptionError unless ``force=True``.
    out_dir : str or Path, optional
        Folder for ``diagnosis.md``, ``diagnosis.json`` and the figures.
    plant : {"auto", "linear", "mujoco"}
        Plant of the replay and the validation rerun (``"auto"``: the one the
        recording's metadata names, else MuJoCo).
    baseline : str or Path, optional
        Recording of the same test before the change (default: the recording
        is compared with the nominal plant's replay of its force).
    seed : int, optional
        Seed of the controller design (default: the recording's metadata, else 0).
    **options
        Further keywords of :func:`vlab.diagnose.pipeline.diagnose`
        (``resolution_hz``, ``effects``, ``floor``, ``pairs``, ...).

    Returns
    -------
    DiagnosisResult
        ``.mismatch``, ``.selected``, ``.ranked``; ``.as_dict()`` is the
        ``vlab diagnose --json`` object (:class:`vlab.diagnose.report.result.DiagnosisResult`).

    Raises
    ------
    DataFileError, MeasurementError
        A recording that cannot be read or analysed.
    SpecError, ModelError
        As :func:`load_spec`.
    OptionError
        ``controller``, ``seed`` or ``plant`` contradicts the recording's metadata (without ``force=True``).
    """
    from .diagnose.pipeline import diagnose as _diagnose

    return _diagnose(structure, Path(recording), controller=controller, out_dir=out_dir, plant=plant,
                     baseline=baseline, seed=seed, **options)


def update(structure: Any, diagnosis: str | Path, *, out: str | Path | None = None, overwrite: bool = False):
    """Write the structure file with the physics a diagnosis found, as commented entries (``vlab update``).

    The original file's text is kept as written; each selected effect of the diagnosis is appended as an
    ordinary entry (an added mass, a spring, a member's rigidity, a joint's flexibility, a mode's damping
    ratio) with the source ``"vlab diagnose <recording>: fitted, 95 % interval [...]"``, read back and
    checked against the structure the diagnosis evaluated (:mod:`vlab.model_update`).

    Parameters
    ----------
    structure : str, Path or StructureSpec
        The diagnosed structure: ``"bcc"``, ``"grid"``, a ``.toml`` path or a spec loaded from one.
    diagnosis : str or Path
        The folder :func:`diagnose` wrote (``out_dir``) or its ``diagnosis.json``.
    out : str or Path, optional
        The updated ``.toml`` file to write (None: nothing written, the text is in the result).
    overwrite : bool
        Replace an existing ``out``.

    Returns
    -------
    UpdateResult
        ``.spec`` (the updated structure), ``.text``, ``.entries``, ``.path``
        (:class:`vlab.model_update.UpdateResult`).

    Raises
    ------
    DataFileError
        A diagnosis with nothing selected, outside the library, or made for another structure.
    ModelError
        A selected effect a structure file cannot hold (the hardware chain's delay, lags, gains; damping
        at a point, friction, gravity pre-stress).
    OutputError
        ``out`` exists without ``overwrite``, or its folder is missing.
    """
    from .model_update import update as _update

    return _update(structure, diagnosis, out=out, overwrite=overwrite)


def verify_update(original: Any, updated: Any, mjcf: str | Path, *, controller: str = "mfdrf", seed: int = 0,
                  duration_s: float | None = None, lab_chain=None) -> dict:
    """Design on the original and on the updated structure, run both on the same plant (``vlab update --verify``).

    Parameters
    ----------
    original, updated, mjcf, controller, seed, duration_s, lab_chain
        As :func:`vlab.model_update.verify`: the structure before and after :func:`update`, the MJCF plant
        both designs run on (e.g. the changed structure from :func:`export_mjcf`), the controller designed
        on each model, the seed, the run length and the hardware chain both runs really have where it
        differs from what the models know (a :class:`vlab.lab.loop.HardwareChain`; None: each model's).

    Returns
    -------
    dict
        For ``original`` and ``updated``: ``average_peak_level_error`` [1] (Table 10's measure) and
        ``modes`` with ``damping_ratio_predicted`` and ``damping_ratio_measured``
        (:func:`vlab.model_update.verify`).

    Raises
    ------
    ModelError
        Open loop or LQR; a plant without the structure's coils and sensors.
    SimulationError, MeasurementError
        As :func:`run_experiment`.
    """
    from .model_update import verify

    return verify(original, updated, mjcf, controller=controller, seed=seed, duration_s=duration_s,
                  lab_chain=lab_chain)


def export_mjcf(structure: Any, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write a structure's complete MuJoCo plant as an MJCF file (``vlab export-mjcf``).

    Parameters
    ----------
    structure : str or StructureSpec
        As :func:`modes`.
    path : str or Path
        The ``.xml`` file to write; its folder must exist.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path
        The file written; run it with ``run_experiment(..., mjcf=path)``.

    Raises
    ------
    OutputError
        ``path`` exists without ``overwrite``, its folder is missing, or it
        does not end in ``.xml``.
    SpecError, ModelError
        As :func:`load_spec` and the plant build.
    """
    from .io.atomic import check_output_file
    from .sim import build_plant
    from .sim import export_mjcf as _export
    from .spec import StructureSpec

    spec = structure if isinstance(structure, StructureSpec) else load_spec(structure)
    out = check_output_file(str(path), overwrite=overwrite, option="path", suffix=".xml")
    return _export(build_plant(spec), out, overwrite=overwrite)


# ----------------------------------------------------------------- ``vlab.design`` / ``vlab.diagnose`` ---
# The entry points share their names with the subpackages ``vlab.design`` and ``vlab.diagnose``; importing a
# subpackage sets the attribute of this package to the module. The module is made callable (calling the entry
# point) so that both ``vlab.design(...)`` and ``vlab.design.design_controller`` work, in whatever order
# they are imported.

_ENTRY = {"design": design, "diagnose": diagnose}


class _CallableModule(types.ModuleType):
    """A submodule that, called, calls the package's entry point of the same name."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return _ENTRY[self.__name__.rpartition(".")[2]](*args, **kwargs)


def _callable(module: types.ModuleType) -> types.ModuleType:
    name = module.__name__.rpartition(".")[2]
    if module.__name__ == f"{__name__}.{name}" and name in _ENTRY and type(module) is types.ModuleType:
        module.__class__ = _CallableModule
        module.__wrapped__ = _ENTRY[name]  # inspect.signature(vlab.design) gives the entry point's
    return module


class _Package(types.ModuleType):
    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(value, types.ModuleType) and name in _ENTRY:
            value = _callable(value)
        super().__setattr__(name, value)


for _name in _ENTRY:  # a subpackage imported before this module finished (python -m vlab.design, ...)
    _mod = sys.modules.get(f"{__name__}.{_name}")
    if _mod is not None:
        globals()[_name] = _callable(_mod)
sys.modules[__name__].__class__ = _Package
del _name
