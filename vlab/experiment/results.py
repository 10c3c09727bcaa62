"""Writing an experiment's output folder: results.json, report.md, UFF files, figures, rerun.

``results.json`` keys (stable):

- ``structure``, ``controller``, ``reduction``, ``excitation``, ``plant``, ``seed``
- ``period_s``: the controller's sampling period [s], and ``period_source``: whether it is
  the thesis's value for the controller (Sec. 5.3: LQG 1 ms, DRF 0.5 ms) or a user setting
- ``duration_s``, ``resolution_hz``, ``hardware`` (period_s, delay_periods, filter_hz,
  amplifier_gain_n_per_n, amplifier_limit_n, noise_m_s)
- ``design``: :func:`design_summary` (gains with their units in the keys) or null
- ``modes``: list of {mode, frequency_predicted_hz, frequency_measured_hz,
  damping_predicted, damping_measured, peak_predicted_m_per_n and peak_measured_m_per_n (BCC,
  displacement FRF; ``_m_s_per_n`` for the grid's velocity FRF), peak_level_ratio, response}
- ``avg_peak_error``: mean ``|1 - ratio|`` (Tables 10, 19-21)
- ``mode_shapes``: :func:`shapes_summary` (the shapes identified from the H1 FRFs of all measured points,
  their MAC against the FE model's) or null
- ``files``: names of the other outputs
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..design.controller import DRF_CONTROLLERS
from .shape_results import paired_model_shapes, shapes_report_lines, shapes_summary, write_shape_outputs


def jsonable(o: Any) -> Any:
    """``o`` as plain JSON types.

    Parameters
    ----------
    o : any
        Nested dicts, lists, tuples, numpy arrays and scalars, Paths.

    Returns
    -------
    any
        Numpy scalars as Python numbers, arrays as lists (complex arrays as
        ``[re, im]`` pairs), non-finite floats as None, Paths as strings.
    """
    if isinstance(o, np.ndarray):
        return [jsonable(v) for v in o.tolist()] if o.dtype != complex else [[v.real, v.imag] for v in o.ravel()]
    if isinstance(o, (np.floating, float)):
        v = float(o)
        return v if np.isfinite(v) else None
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, np.bool_):
        return bool(o)
    if isinstance(o, dict):
        return {str(k): jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if isinstance(o, Path):
        return str(o)
    return o


def write_json(path: Path, obj: dict) -> Path:
    """Write ``obj`` as indented JSON (NaN -> null). Returns the path.

    Parameters
    ----------
    path : Path
        File to write (replaced if it exists).
    obj : dict
        Data; numpy arrays and scalars and Paths are converted, complex arrays
        become ``[re, im]`` pairs, non-finite floats ``null``.

    Returns
    -------
    Path
        ``path``.
    """
    path.write_text(json.dumps(jsonable(obj), indent=2) + "\n")
    return path




#: SI units of the state labels and the thesis's units of the same columns (Sec. 3.1: 1 cs = 0.01 s).
_THESIS_STATE_UNITS = (("[m/s]", "[in/cs]"), ("[rad/s]", "[rad/cs]"), ("[m]", "[in]"), ("[rad]", "[rad]"))


def thesis_state_label(label: str) -> str:
    """A state label with its SI unit (``"dw/dt@9 [m/s]"``) in the thesis's units (``"dw/dt@9 [in/cs]"``):
    the columns of ``gain_thesis_lbf_per_thesis_state`` (Sec. 3.1). A label without a known unit is returned
    as it is."""
    for si, th in _THESIS_STATE_UNITS:
        if label.endswith(si):
            return label[: -len(si)] + th
    return label


def design_summary(d) -> dict:
    """A controller design as a JSON object whose every number carries its unit in its key.

    SI for every structure; the dissertation's structures (the BCC and the grid,
    :func:`vlab.experiment.config.dissertation_structure`) also get the numbers
    its tables print, in its inch, lbf, centisecond system (Sec. 3.1), under
    keys with ``thesis`` in their names. Used by ``vlab design --json`` and the
    ``design`` entry of results.json.

    Parameters
    ----------
    d : ControllerDesign
        The design (:func:`vlab.design.design_controller`).

    Returns
    -------
    dict
        ``structure``, ``controller``, ``reduction``; ``period_s`` (sampling
        period of the Eq. (5.1) realization [s]); for DRF ``gain_n_s_per_m``
        (D, shape (n_c, n_c), ``u = -D y``); for LQR/LQG ``gain_n_per_si_state``
        (F, shape (n_c, 2n_d), ``u = -F x``) and ``gain_state_labels`` (name
        and SI unit of each column); ``damping_ratios`` [-] and
        ``frequencies_hz`` of the closed loop; ``performance_index_si_1m_ic_s``
        (J_i [s] for modal initial conditions of 1 m peak, Eqs. 4.7, 4.20,
        4.33 with the SI weights); ``gamma_n_s_per_m`` (MFDRF/LQDRF max row
        sum of ``|D|``, null for LQ designs); ``beta_si_1m_ic_s`` (LQDRF);
        ``converged``, ``message``; ``extra`` (the design's further numbers,
        keys with units). The dissertation's structures add
        ``gain_thesis_lb_s_per_in`` (DRF, the form of Tables 7, 11, 15) or
        ``gain_thesis_lbf_per_thesis_state`` and ``gain_thesis_state_labels``
        (LQ, per in/cs, rad/cs, in, rad, :func:`thesis_state_label`),
        ``performance_index_thesis_units``, ``gamma_lb_s_per_in`` and
        ``beta_thesis_units``.
    """
    from .config import dissertation_structure

    drf = d.controller in DRF_CONTROLLERS
    thesis = dissertation_structure(d.structure)
    out: dict = {"structure": d.structure, "controller": d.controller, "reduction": d.model,
                 "period_s": d.period_s}
    extra = dict(d.extra)
    gain_thesis = extra.pop("gain_thesis_lb_s_per_in" if drf else "gain_thesis_lbf_per_thesis_state", None)
    if drf:
        out["gain_n_s_per_m"] = d.gain
    else:
        out["gain_n_per_si_state"] = d.gain
        out["gain_state_labels"] = list(d.state_labels)
    out.update({
        "damping_ratios": d.damping_ratios, "frequencies_hz": d.frequencies_hz,
        "performance_index_si_1m_ic_s": d.performance_index_s,
        "gamma_n_s_per_m": d.gamma_n_s_per_m, "beta_si_1m_ic_s": d.beta_s,
        "converged": d.converged, "message": d.message,
        "extra": {k: v for k, v in extra.items() if not isinstance(v, np.ndarray) or v.ndim < 3},
    })
    if thesis:
        if drf:
            out["gain_thesis_lb_s_per_in"] = gain_thesis
        else:
            out["gain_thesis_lbf_per_thesis_state"] = gain_thesis
            out["gain_thesis_state_labels"] = [thesis_state_label(x) for x in d.state_labels]
        out.update({"performance_index_thesis_units": d.performance_index_thesis_units,
                    "gamma_lb_s_per_in": d.gamma_lb_s_per_in, "beta_thesis_units": d.beta_thesis_units})
    return out


def experiment_summary(result) -> dict:
    """The results.json object of an :class:`~vlab.experiment.runner.ExperimentResult`.

    Parameters
    ----------
    result : ExperimentResult
        The experiment.

    Returns
    -------
    dict
        The stable keys listed in the module docstring (without ``files``).
    """
    from .config import period_source

    cfg = result.config
    d = result.design
    ch = cfg.chain
    return {
        "structure": cfg.structure,
        "controller": cfg.controller,
        "reduction": getattr(d, "model", None),
        "excitation": cfg.excitation,
        "plant": result.plant_info.get("kind"),
        "seed": cfg.seed,
        "period_s": ch.period_s,
        "period_source": period_source(cfg.controller, ch.period_s),
        "duration_s": cfg.duration_s,
        "resolution_hz": cfg.resolution_hz,
        "hardware": {
            "period_s": ch.period_s, "delay_periods": ch.delay_periods, "filter_hz": ch.filter_hz,
            "amplifier_gain_n_per_n": ch.amplifier_gain, "amplifier_limit_n": ch.amplifier_limit_n,
            "noise_m_s": ch.noise_m_s,
        },
        "design": None if d is None else design_summary(d),
        "modes": [m.as_dict() for m in result.modes],
        "avg_peak_error": result.avg_peak_error,
        "mode_shapes": shapes_summary(result),
        "warnings": list(result.warnings) + failed_premises(result),
    }


def failed_premises(result) -> list[str]:
    """Why an experiment's comparison of analysis and measurement is meaningless, from its settings and analysis.

    - the analysis predicts the loop unstable: a mode's predicted damping ratio
      is negative (the sampled-data loop with its hold, delay and filter,
      Sec. 5.3), so the measured FRF has no steady state to compare with;
    - the computation delay is at least one record of the test
      (``1 / resolution_hz``): the controller acts on the response to another
      record's excitation.

    ``vlab experiment`` exits with status 1 when there is one, unless
    ``--allow-unstable``.

    Parameters
    ----------
    result : ExperimentResult
        The experiment (:func:`vlab.experiment.runner.run_experiment`).

    Returns
    -------
    list of str
        One sentence per failed premise, naming the mode and its predicted
        damping ratio [-] or the delay [samples, s] and the record [s]; empty
        when none failed.
    """
    out = []
    cfg = result.config
    delay = cfg.chain.delay_periods
    unstable = [m for m in result.modes if m.damping_predicted is not None and m.damping_predicted < 0]
    if unstable:
        m = min(unstable, key=lambda m: m.damping_predicted)
        out.append(f"the loop is predicted unstable: mode {m.mode} ({m.frequency_predicted_hz:.4g} Hz) has a "
                   f"predicted damping ratio of {m.damping_predicted:.4g} < 0 (delay {delay:g} samples, "
                   f"{len(unstable)} mode(s) negative); the measured FRF has no steady state to compare with")
    delay_s = delay * cfg.chain.period_s
    if cfg.resolution_hz and delay_s >= 1.0 / cfg.resolution_hz:
        out.append(f"the delay of {delay:g} samples is {delay_s:g} s, at least one record of the test "
                   f"({1.0 / cfg.resolution_hz:g} s): the controller acts on the response to another record's "
                   "excitation")
    return out


def report_markdown(summary: dict) -> str:
    """A markdown report of an experiment (tables in the form of Table 10).

    Parameters
    ----------
    summary : dict
        The results.json object (:func:`experiment_summary`; keys listed in
        the module docstring).

    Returns
    -------
    str
        The report: settings, one row per mode (frequencies [Hz], damping
        ratios, their errors, peak level ratio) and the average peak level
        error (Tables 10, 19-21), the identified mode shapes' table (:func:`shapes_report_lines`), then any
        warnings.

    Raises
    ------
    KeyError
        If ``summary`` lacks a key of results.json.
    """
    lines = [
        f"# vlab experiment: {summary['structure']}, {summary['controller']}",
        "",
        f"Plant: {summary['plant']}; excitation: {summary['excitation']}; duration {summary['duration_s']:.1f} s; "
        f"resolution {summary['resolution_hz']:g} Hz; seed {summary['seed']}.",
        f"Hardware: period {summary['hardware']['period_s'] * 1e3:g} ms "
        f"({summary.get('period_source', 'period source not recorded')}), delay {summary['hardware']['delay_periods']} periods, "
        f"RC filter {summary['hardware']['filter_hz']} Hz, sensor noise {summary['hardware']['noise_m_s']} m/s.",
        "",
        "Prediction: the sampled-data analysis (zero-order hold, delay and filter) on the FE model, measured",
        "with the same curve fit as the experiment.",
        "",
        "| mode | f predicted [Hz] | f measured [Hz] | error | zeta predicted | zeta measured | error | peak level ratio |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for m in summary["modes"]:
        def pct(a, b):
            return f"{100 * (b / a - 1):+.2f} %" if a and b else "n/a"
        fp, fm, zp, zm = (m["frequency_predicted_hz"], m["frequency_measured_hz"], m["damping_predicted"],
                          m["damping_measured"])
        ratio = m["peak_level_ratio"]
        lines.append(
            f"| {m['mode']} | {fp or float('nan'):.3f} | {fm or float('nan'):.3f} | {pct(fp, fm)} | "
            f"{zp or float('nan'):.4f} | {zm or float('nan'):.4f} | {pct(zp, zm)} | "
            f"{ratio if ratio is None else f'{ratio:.3f}'} |"
        )
    lines += ["", f"Average peak level error mean|1 - ratio|: {summary['avg_peak_error']:.3f}", ""]
    lines += shapes_report_lines(summary)
    for w in summary.get("warnings", []):
        lines += [f"**Warning:** {w}", ""]
    return "\n".join(lines)


def write_outputs(result, spec, out_dir: Path, *, spawn: bool = False, overwrite: bool = True,
                  log_freq: bool = False) -> dict[str, Path]:
    """Write the output folder of an experiment.

    Files: ``recording.uff`` (UFF 58 time histories), ``frf.uff`` (UFF 58 FRFs),
    ``results.json``, ``report.md``, ``frf.png`` (the response point's velocity
    FRF of ``frf.uff`` [(m/s)/N] over the excited band: magnitude with the
    analysis dashed over it as Figs. 22-31, phase, coherence), ``shapes.csv`` and
    ``shapes.png`` (the identified mode shapes and their MAC against the FE model's,
    :func:`~vlab.experiment.shape_results.write_shape_outputs`; only when a mode was
    identified) and ``run.rrd`` (rerun: signals, the animated structure, and on the
    ``frequency_mhz`` timeline the response point's measured and predicted FRF
    (``frf/experiment``, ``frf/analysis``) and every measured channel's H1 FRF
    (``frf/h1/vel<point>``), each with magnitude, phase and, for H1, coherence).
    ``frf.uff`` holds only the excited band's lines.

    The folder is written atomically (:func:`vlab.io.atomic.atomic_dir`):
    every file goes into a temporary folder beside ``out_dir`` that is
    renamed into place only when complete, so that an interrupted or failed
    write leaves ``out_dir`` as it was.

    Parameters
    ----------
    result : ExperimentResult
        The experiment (:func:`vlab.experiment.runner.run_experiment`).
    spec : StructureSpec
        The structure, for the geometry drawn in the rerun recording.
    out_dir : Path
        Output folder; its parent must exist (it is not created).
    spawn : bool
        Open the rerun viewer live while logging. If the viewer cannot be
        started or reached, the recording is logged to ``run.rrd`` alone and
        a warning is returned under ``files["warnings"]`` (a list of str).
    overwrite : bool
        Replace an existing non-empty ``out_dir`` whole (the old folder is
        deleted only after the new one is in place); with False such a
        folder is an error.
    log_freq : bool
        Draw ``frf.png``'s frequency on a logarithmic axis (default linear, as Figs. 22-31).

    Returns
    -------
    dict[str, Path]
        Output kind (``"recording"``, ``"frf"``, ``"results"``, ``"report"``,
        ``"figure"``, ``"rerun"``, and ``"shapes"``, ``"shapes_figure"`` when a mode shape
        was identified) -> file path in ``out_dir``; plus
        ``"warnings"`` (list of str, possibly empty).

    Raises
    ------
    OutputError
        ``out_dir`` is a file, a non-empty folder without ``overwrite``, or
        its parent folder is missing or not writable.
    DataFileError
        If a UFF file cannot be written.
    """
    from ..io.atomic import atomic_dir

    final = Path(out_dir)
    with atomic_dir(final, overwrite=overwrite) as tmp:
        files, warnings = _write_outputs_into(result, spec, tmp, spawn=spawn, log_freq=log_freq)
    out = {k: final / p.name for k, p in files.items()}
    out["warnings"] = warnings
    return out


def _write_outputs_into(result, spec, out: Path, *, spawn: bool, log_freq: bool = False
                        ) -> tuple[dict[str, Path], list[str]]:
    """Write the experiment's files into the (temporary, empty) folder ``out``."""
    from ..viz.figures import frf_panels_figure
    from ..viz.rerun_log import log_experiment
    from ..viz.rerun_structure import structure_geometry
    from ..io.frf import FRF
    from ..io.uff import write_frfs, write_recording

    overwrite = False
    files = {
        "recording": out / "recording.uff",
        "frf": out / "frf.uff",
        "results": out / "results.json",
        "report": out / "report.md",
        "figure": out / "frf.png",
        "rerun": out / "run.rrd",
    }
    write_recording(files["recording"], result.loop.recording, overwrite=overwrite)
    from .config import test_definition

    test = test_definition(spec)
    band = test.band_hz
    write_frfs(files["frf"], result.frfs, overwrite=overwrite, band_hz=band,
               metadata=result.loop.recording.metadata)
    files.update(write_shape_outputs(result, spec, out))
    summary = experiment_summary(result)
    summary["files"] = {k: p.name for k, p in files.items()}
    write_json(files["results"], summary)
    files["report"].write_text(report_markdown(summary))
    cfg = result.config
    # frf.png: the response point's velocity FRF of frf.uff [(m/s)/N], analysis in the same unit
    resp = result.frfs[f"vel{test.response_point}"]
    to_vel = 2j * np.pi * result.freq_hz if test.response_quantity == "displacement" else 1.0
    frf_panels_figure(
        resp.freq_hz,
        {"experiment (H1)": resp.h, "analysis (sampled-data)": result.analysis_sampled * to_vel,
         "analysis (continuous, as 1990)": result.analysis_continuous * to_vel},
        resp.coherence, unit=resp.unit,
        title=f"{cfg.structure} {cfg.controller}, {cfg.excitation}: {resp.name}, "
              f"excited band {band[0]:g}-{band[1]:g} Hz",
        path=files["figure"], log_freq=log_freq,
    )
    pts, members = structure_geometry(spec)
    loop = result.loop
    # points without an out-of-plane DOF (supports) stay at rest in the animation
    all_points = list(pts)
    disp = np.zeros((loop.displacements.shape[0], len(all_points)))
    for j, p in enumerate(loop.shape_points):
        disp[:, all_points.index(p)] = loop.displacements[:, j]
    rerun_args = dict(
        recording=loop.recording, structure_points=pts, members=members,
        displacement=disp, displacement_dt_s=loop.recording.dt_s, point_ids=all_points,
        frfs={"experiment": FRF(result.freq_hz, result.measured, test.response_quantity),
              "analysis": FRF(result.freq_hz, result.analysis_sampled, test.response_quantity),
              **{f"h1/{name}": frf for name, frf in result.frfs.items()}}, frf_phase=True,
        extra_signals={f"u{p}": loop.commands[:, j] for j, p in enumerate(result.plant_info.get("actuators", []))},
        metadata=summary, identified_shapes=_identified_for_rerun(result))
    warnings: list[str] = []
    if spawn:
        try:
            log_experiment(files["rerun"], spawn=True, **rerun_args)
            return files, warnings
        except (RuntimeError, OSError) as exc:  # no viewer executable, no display, gRPC connection refused
            warnings.append(f"the rerun viewer could not be started or reached ({exc}); "
                            f"{files['rerun'].name} is written, open it with `rerun {files['rerun'].name}`")
            files["rerun"].unlink(missing_ok=True)
    log_experiment(files["rerun"], spawn=False, **rerun_args)
    return files, warnings


def _identified_for_rerun(result) -> dict | None:
    """The identified shapes and their paired model shapes as :func:`vlab.viz.rerun_log.log_experiment` takes
    them; None when none was identified."""
    sh = result.shapes
    if sh is None:
        return None
    return {"point_ids": list(sh.point_ids), "w": sh.shapes, "freq_hz": sh.freq_hz, "modes": list(sh.modes),
            "w_model": paired_model_shapes(result)[0]}
