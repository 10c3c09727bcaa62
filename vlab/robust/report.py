"""Outputs of a robustness study: JSON (units in keys), per-sample arrays, box plots, a rerun file, Markdown.

Files written into the output folder:

* ``robustness.json`` -- settings (distributions with sources), timings,
  per-controller statistics of the FE loop (:class:`vlab.robust.study.Summary`),
  the ranking per metric, the numbers per plant (:mod:`vlab.robust.plants`:
  the FE sampled loop and the MuJoCo time simulation, probabilities with
  Wilson intervals), the time-simulated samples, the limit cycle's
  sensitivity where a loop is unstable on MuJoCo at nominal;
* ``samples.npz`` -- every sample's values (keys ``<controller>/<quantity_unit>``);
* ``robustness.png`` -- violins per controller and P(unstable) per plant
  (:mod:`vlab.robust.figures`);
* ``worst_time_history.png`` and ``worst.rrd`` -- the worst time-simulated
  sample (unstable on the MuJoCo plant first): its response and spectrum,
  and its recording for rerun;
* ``robustness.md`` -- the conclusion with its numbers.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .study import METRICS, Nominal, StudyConfig, Summary
from .study import LABELS as _LABELS


def _peak_unit(nominal: Nominal) -> str:
    return "m_per_n" if nominal.displacement else "m_s_per_n"


def _f(v) -> float | None:
    return float(v) if v is not None and np.isfinite(v) else None


def check_dict(ch) -> dict:
    """JSON of one :class:`vlab.robust.simulate.SimCheck` (units in the keys; NaN -> None).

    Parameters
    ----------
    ch : SimCheck

    Returns
    -------
    dict
        Lists of length k (samples), ``..._by_mode`` lists of k lists of n_modes.
    """
    rows = lambda a: [[_f(v) for v in row] for row in a]  # noqa: E731
    return {"controller": ch.controller, "samples": ch.indices.tolist(), "batches": ch.batches,
            "chosen_as_worst": ch.worst.tolist(), "drawn_at_random": ch.random.tolist(),
            "predicted_unstable_fe": ch.predicted_unstable.tolist(), "diverged": ch.diverged.tolist(),
            "unstable_on_mujoco": ch.unstable_on_plant.tolist(),
            "oscillation_frequency_hz": [_f(v) for v in ch.oscillation_hz],
            "oscillation_growth_rate_1_s": [_f(v) for v in ch.growth_rate_1_s],
            "power_above_band": [_f(v) for v in ch.power_above_band],
            "verdicts": list(ch.summaries),
            "peak_measured_over_linear_by_mode": rows(ch.peak_sim_over_linear),
            "peak_analysis_over_experiment_by_mode": rows(ch.peak_analysis_over_experiment),
            "damping_ratio_linearised_mujoco_by_mode": ([] if ch.damping_ratio is None else rows(ch.damping_ratio)),
            "spectral_radius_linearised_mujoco": ([] if ch.linear_spectral_radius is None
                                                  else [_f(v) for v in ch.linear_spectral_radius]),
            "nominal_plant": {"unstable": ch.nominal.unstable, "frequency_hz": _f(ch.nominal.frequency_hz),
                              "growth_rate_1_s": _f(ch.nominal.growth_rate_1_s), "summary": ch.nominal.summary,
                              "damping_ratio_linearised_by_mode": (None if ch.nominal_damping_ratio is None else
                                                                   [_f(v) for v in ch.nominal_damping_ratio]),
                              "spectral_radius_linearised": _f(ch.nominal_linear_spectral_radius)}}


def results_dict(cfg: StudyConfig, nominal: Nominal, summary: Summary, checks, timings: dict, *,
                 extras: dict | None = None) -> dict:
    """The JSON object of ``robustness.json`` (every number's unit in its key).

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    summary : Summary
    checks : list of SimCheck
        Time-simulated samples (may be empty).
    timings : dict
        Seconds per stage (``"total"``, ``"study"``, ...) and ``"where"``.
    extras : dict, optional
        ``"time_simulation"`` (settings of the check: samples per controller, selection, resolution),
        ``"limit_cycle_sensitivity"`` (controller -> rows of
        :func:`vlab.robust.limit_cycle.limit_cycle_sensitivity`), ``"fe_loop_mode_near_limit_cycle"``
        (controller -> :func:`vlab.robust.limit_cycle.fe_loop_mode_near`); copied in as they are.
    """
    from .plants import PLANTS, per_plant, sec7_on_plants

    plants = per_plant(summary, checks, cfg.n_samples, cfg.seed)
    extras = extras or {}
    from .study import is_dissertation, nominal_spec

    spec = nominal_spec(cfg, nominal)
    out = {
        "structure": cfg.structure,
        "structure_name": spec.name,
        "structure_title": spec.title,
        "dissertation_structure": is_dissertation(cfg),
        "samples": cfg.n_samples,
        "seed": cfg.seed,
        "chunk_size_samples": cfg.chunk_size,
        "uncertainties": [{"group": u.group, "kind": u.kind,
                           ("spread_periods" if u.group == "delay_periods" else "spread_relative"): u.spread,
                           "source": u.source} for u in cfg.uncertainties],
        "controllers": {c: {"period_s": nominal.chains[c].period_s, "delay_periods": nominal.chains[c].delay_periods,
                            "filter_hz": nominal.chains[c].filter_hz} for c in cfg.controllers},
        "response_point": nominal.response_point,
        "compared_frf": "displacement [m/N]" if nominal.displacement else "velocity [(m/s)/N]",
        "timings_s": timings,
        "plants": {k: v for k, v in PLANTS.items() if k in plants},
        "per_plant": plants,
        "sec7_on_plants": sec7_on_plants(plants),
        "per_controller": summary.per_controller,
        "metrics": METRICS,
        "ranking_most_to_least_robust": summary.ranking,
        "thesis_conclusion_sec7": summary.thesis_conclusion,
        "time_simulation": extras.get("time_simulation", {}),
        "time_simulation_checks": [check_dict(ch) for ch in checks],
        "limit_cycle_sensitivity": extras.get("limit_cycle_sensitivity", {}),
        "fe_loop_mode_near_limit_cycle": extras.get("fe_loop_mode_near_limit_cycle", {}),
    }
    return out


def write_samples(path: Path, cfg: StudyConfig, nominal: Nominal, res: dict) -> None:
    """``samples.npz``: per-sample arrays, keys with units.

    Parameters
    ----------
    path : Path
    cfg : StudyConfig
    nominal : Nominal
    res : dict
        Per-sample arrays of :func:`vlab.robust.study.run_study`.
    """
    pu = _peak_unit(nominal)
    arrays = {"sample_index": res["index"], "delay_periods": res["delay_periods"]}
    for c in cfg.controllers:
        arrays[f"{c}/damping_ratio"] = res[f"{c}/zeta"]
        arrays[f"{c}/frequency_hz"] = res[f"{c}/freq_hz"]
        arrays[f"{c}/spectral_radius"] = res[f"{c}/spectral_radius"]
        arrays[f"{c}/energy_index_j_s"] = res[f"{c}/energy_j_s"]
        arrays[f"{c}/peak_level_{pu}"] = res[f"{c}/peaks"]
    np.savez_compressed(path, **arrays)


def worst_run(checks):
    """The worst time-simulated run that kept its recording: unstable on MuJoCo first, then the largest
    |log(measured/linear)| peak; ``(check, row)`` or None when no run kept one.

    Parameters
    ----------
    checks : list of SimCheck

    Returns
    -------
    tuple of (SimCheck, int) or None
    """
    best, key = None, None
    for ch in checks:
        for row, rec in enumerate(ch.recordings):
            if rec is None:
                continue
            dev = np.abs(np.log(ch.peak_sim_over_linear[row]))
            k = (bool(ch.unstable_on_plant[row]), float(ch.power_above_band[row]) if ch.unstable_on_plant[row]
                 else float(np.nanmax(dev, initial=0.0)))
            if key is None or k > key:
                best, key = (ch, row), k
    return best


def write_outputs(folder: Path, cfg: StudyConfig, nominal: Nominal, res: dict, summary: Summary, checks,
                  timings: dict, command: str, *, extras: dict | None = None) -> dict:
    """Write every output into ``folder`` (exists); return name -> path.

    Parameters
    ----------
    folder : Path
    res : dict
        Per-sample arrays of :func:`vlab.robust.study.run_study`.
    cfg, nominal, summary, checks, timings, extras
        As :func:`results_dict`.
    command : str
        The command line named in the Markdown.

    Returns
    -------
    dict of str to Path
        ``json``, ``samples``, ``plot``, ``markdown``, and with a time-simulated run ``time_history`` and ``rerun``.

    Raises
    ------
    OSError
        From writing.
    """
    from ..experiment.config import test_definition
    from .figures import distribution_plots, time_history_plot
    from .markdown import markdown
    from .plants import per_plant
    from .study import nominal_spec

    folder = Path(folder)
    files = {"json": folder / "robustness.json", "samples": folder / "samples.npz",
             "plot": folder / "robustness.png", "markdown": folder / "robustness.md"}
    files["json"].write_text(json.dumps(_clean(results_dict(cfg, nominal, summary, checks, timings, extras=extras)),
                                        indent=2, allow_nan=False, default=_json_default) + "\n")
    write_samples(files["samples"], cfg, nominal, res)
    distribution_plots(files["plot"], cfg, nominal, res, per_plant(summary, checks, cfg.n_samples, cfg.seed),
                       checks=checks)
    files["markdown"].write_text(markdown(cfg, nominal, summary, checks, timings, command, extras=extras))
    worst = worst_run(checks)
    if worst is not None:
        from ..viz.rerun_log import log_experiment

        ch, row = worst
        rec = ch.recordings[row]
        state = ("diverged on MuJoCo" if ch.diverged[row] else
                 f"self-excited on MuJoCo at {ch.oscillation_hz[row]:.2f} Hz, "
                 f"{100 * ch.power_above_band[row]:.1f} % of the power above the band"
                 if ch.unstable_on_plant[row] else "stable on MuJoCo")
        state += f"; FE sampled loop: {'unstable' if ch.predicted_unstable[row] else 'stable'}"
        spec = nominal_spec(cfg, nominal)
        test, test_name = test_definition(spec), spec.name
        files["time_history"] = time_history_plot(
            folder / "worst_time_history.png", rec, response_point=test.response_point, band_hz=test.band_hz,
            title=f"{_LABELS[ch.controller]}, sample {int(ch.indices[row])}: {state}")
        files["rerun"] = log_experiment(folder / "worst.rrd", recording=rec.recording,
                                        metadata={"structure": test_name, "controller": ch.controller,
                                                  "sample": int(ch.indices[row])})
    return files


def _clean(obj):
    """Non-finite floats -> None (JSON has no inf/NaN), recursively."""
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (float, np.floating)) and not np.isfinite(obj):
        return None
    return obj


def _json_default(obj):
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
