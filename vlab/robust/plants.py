"""The study's numbers per plant: the sampled-data loop on the perturbed FE model, and the MuJoCo time simulation.

Two plants answer Sec. 7's question differently:

* ``fe_sampled_loop`` -- every sample's exact sampled-data loop on its
  perturbed FE model (:mod:`vlab.robust.study`): P(unstable) is the share of
  samples with ``max |z| >= 1``; peak ratios and damping of the stable ones;
* ``mujoco_time_simulation`` -- chosen samples run in time on the MuJoCo
  plant (:mod:`vlab.robust.simulate`): a loop that diverges or self-excites
  there is unstable on that plant and its peak ratios are not used.
  P(unstable) is estimated from the samples drawn *at random* only (the worst
  ones, chosen by the linear measure, are reported beside it and not counted).

Probabilities carry the Wilson score interval (Wilson, E. B., "Probable
inference, the law of succession, and statistical inference", *J. Am. Stat.
Assoc.* 22, 1927; ``scipy.stats.binomtest(...).proportion_ci(method="wilson")``),
which stays inside [0, 1] and is not degenerate at 0 or n events. Medians
carry a bootstrap interval (:func:`vlab.robust.study.median_ci`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import binomtest

from .study import LABELS, Summary, median_ci

#: Confidence level of every interval of the study [-].
LEVEL = 0.95
#: Names of the two plants in the JSON and the tables.
PLANTS = {"fe_sampled_loop": "sampled-data loop on the perturbed FE model",
          "mujoco_time_simulation": "MuJoCo plant, time simulation (H1 of noisy recordings; damping from the "
                                    "plant's linearisation)"}


#: How the MuJoCo plant's damping is found (written into the JSON).
DAMPING_METHOD = ("sampled-data loop on the linearisation of each simulated sample's MuJoCo plant (its modes, "
                  "hinge chain and geometric stiffness included) with the sample's chain; the 4 s records' line "
                  "spacing is wider than the controlled modes' half-power bands")


def binomial_ci(k: int, n: int, level: float = LEVEL) -> list:
    """Wilson score interval ``[low, high]`` of a probability from ``k`` events in ``n`` trials.

    Parameters
    ----------
    k, n : int
        ``0 <= k <= n``; ``n = 0`` gives ``[None, None]``.
    level : float
        Confidence level in (0, 1).

    Returns
    -------
    list of float or None

    Raises
    ------
    ValueError
        ``k`` outside ``[0, n]`` (from scipy).

    Source: Wilson (1927), through ``scipy.stats.binomtest``.
    """
    if n == 0:
        return [None, None]
    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=level, method="wilson")
    return [float(ci.low), float(ci.high)]


def _verdict_dict(v) -> dict:
    return {"unstable": bool(v.unstable), "diverged": bool(v.diverged),
            "frequency_hz": None if not math.isfinite(v.frequency_hz) else float(v.frequency_hz),
            "growth_rate_1_s": None if not math.isfinite(v.growth_rate_1_s) else float(v.growth_rate_1_s),
            "power_above_band": float(v.power_above_band) if math.isfinite(v.power_above_band) else None,
            "summary": v.summary}


def _damping_change(zeta: np.ndarray, nominal_zeta) -> tuple[np.ndarray, list[int]]:
    """Per row of ``zeta`` (k, n_modes) the mean over modes of ``|zeta / nominal_zeta - 1|`` [-], over the modes
    finite in every row; and those modes (0-based)."""
    if zeta is None or nominal_zeta is None or zeta.size == 0:
        return np.zeros(0), []
    dz = np.abs(zeta / np.asarray(nominal_zeta, dtype=float)[None, :] - 1.0)
    modes = np.flatnonzero(np.all(np.isfinite(dz), axis=0))
    return (dz[:, modes].mean(axis=1) if modes.size else np.zeros(0)), [int(r) for r in modes]


def mujoco_statistics(check, seed: int, nominal_zeta=None) -> dict:
    """Statistics of one controller on the MuJoCo plant from its :class:`vlab.robust.simulate.SimCheck`.

    Parameters
    ----------
    check : SimCheck
    seed : int
        Seed of the bootstrap.
    nominal_zeta : array_like, shape (n_modes,), optional
        The nominal FE loop's damping ratio of each compared mode [-] (the analysis the damping change is
        measured from; default: no damping change).

    Returns
    -------
    dict
        ``simulated_random_samples``, ``unstable_random_samples``,
        ``probability_unstable`` and ``probability_unstable_ci95`` (Wilson,
        random samples only; None without any), ``simulated_worst_samples``,
        ``unstable_worst_samples``, ``oscillation_hz_range`` ([min, max] over
        the unstable runs, None if none), ``peak_ratio_error_db_median`` and
        ``..._ci95`` (random samples stable on the plant: mean over modes of
        |20 log10(analysis/experiment)|, H1 against the nominal prediction on
        the same lines; over the modes whose +-10 % window holds a line of
        the check's resolution in every such run), ``peak_ratio_samples``,
        ``peak_ratio_modes_compared`` (1-based),
        ``damping_change_relative_median`` and ``..._ci95`` (random samples
        stable on the plant: mean over modes of ``|zeta / zeta_nominal - 1|``
        with ``zeta`` the closed-loop damping on the sample's MuJoCo plant,
        from the sampled-data loop on its linearisation,
        :mod:`vlab.robust.plant_loop`, and ``zeta_nominal`` the nominal FE
        loop's), ``damping_samples``, ``damping_modes_compared`` (1-based),
        ``damping_method``, ``nominal_plant_damping_change_relative`` (the
        unperturbed MuJoCo plant's: the model's own part of the change),
        ``linearised_unstable_random_samples`` (random samples whose
        linearised loop has ``max |z| >= 1``), ``nominal_plant`` (the
        unperturbed plant's verdict) and ``working_loop_at_nominal``.
    """
    rnd, bad = check.random, check.unstable_on_plant
    n_r, k_r = int(rnd.sum()), int((rnd & bad).sum())
    ok = rnd & ~bad
    db = np.abs(20 * np.log10(check.peak_analysis_over_experiment[ok]))
    modes = np.flatnonzero(np.all(np.isfinite(db), axis=0)) if db.size else np.zeros(0, dtype=int)
    per_sample = db[:, modes].mean(axis=1) if db.size and modes.size else np.zeros(0)
    osc = check.oscillation_hz[bad & np.isfinite(check.oscillation_hz)]
    damp = None if check.damping_ratio is None else check.damping_ratio[ok]
    dz, dz_modes = _damping_change(damp, nominal_zeta)
    dz0, _ = _damping_change(None if check.nominal_damping_ratio is None
                             else check.nominal_damping_ratio[None, :], nominal_zeta)
    rho = check.linear_spectral_radius
    return {
        "simulated_random_samples": n_r, "unstable_random_samples": k_r,
        "probability_unstable": (k_r / n_r) if n_r else None,
        "probability_unstable_ci95": binomial_ci(k_r, n_r),
        "simulated_worst_samples": int(check.worst.sum()),
        "unstable_worst_samples": int((check.worst & bad).sum()),
        "predicted_unstable_simulated": int(check.predicted_unstable.sum()),
        "oscillation_hz_range": [float(osc.min()), float(osc.max())] if osc.size else None,
        "peak_ratio_error_db_median": float(np.median(per_sample)) if per_sample.size else None,
        "peak_ratio_error_db_median_ci95": median_ci(per_sample, seed),
        "peak_ratio_samples": int(per_sample.size),
        "peak_ratio_modes_compared": [int(r) + 1 for r in modes],
        "damping_change_relative_median": float(np.median(dz)) if dz.size else None,
        "damping_change_relative_median_ci95": median_ci(dz, seed),
        "damping_samples": int(dz.size),
        "damping_modes_compared": [r + 1 for r in dz_modes],
        "damping_method": DAMPING_METHOD,
        "nominal_plant_damping_change_relative": float(dz0[0]) if dz0.size else None,
        "linearised_unstable_random_samples": None if rho is None else int((rnd & (rho >= 1.0)).sum()),
        "nominal_plant": _verdict_dict(check.nominal),
        "working_loop_at_nominal": not check.nominal.unstable,
    }


def per_plant(summary: Summary, checks, n_samples: int, seed: int) -> dict:
    """Each controller's numbers on each plant: ``{plant: {controller: dict}}`` (plants of :data:`PLANTS`).

    Parameters
    ----------
    summary : Summary
        Of :func:`vlab.robust.study.summarize` (the FE plant's statistics).
    checks : list of SimCheck
        The MuJoCo checks (may be empty: then that plant is left out).
    n_samples : int
    seed : int

    Returns
    -------
    dict
        FE plant: ``samples``, ``probability_unstable`` and its Wilson
        ``..._ci95``, ``peak_ratio_error_db_median`` and ``..._ci95``,
        ``damping_change_relative_median`` and ``..._ci95``,
        ``working_loop_at_nominal`` (the nominal sampled loop's ``max |z| < 1``). MuJoCo plant:
        :func:`mujoco_statistics` (its damping change against the FE plant's nominal damping).
    """
    fe = {}
    for c, v in summary.per_controller.items():
        k = int(round(v["probability_unstable"] * v["samples"]))
        fe[c] = {"samples": v["samples"], "probability_unstable": v["probability_unstable"],
                 "probability_unstable_ci95": binomial_ci(k, v["samples"]),
                 "peak_ratio_error_db_median": v["peak_ratio_error_db_median"],
                 "peak_ratio_error_db_median_ci95": v["peak_ratio_error_db_median_ci95"],
                 "damping_change_relative_median": v["damping_change_relative_median"],
                 "damping_change_relative_median_ci95": v["damping_change_relative_median_ci95"],
                 "working_loop_at_nominal": (None if v.get("nominal_spectral_radius") is None
                                             else bool(v["nominal_spectral_radius"] < 1.0))}
    out = {"fe_sampled_loop": fe}
    if checks:
        out["mujoco_time_simulation"] = {
            ch.controller: mujoco_statistics(ch, seed, summary.per_controller.get(ch.controller, {}).get(
                "nominal_damping_ratio")) for ch in checks}
    return out


def _ordered(values: dict, fmt) -> str:
    """``"A 0.1 < B 0.2 = C 0.2"``: controllers from the lowest value, ``=`` between equal printed values."""
    order = sorted(values, key=lambda c: (values[c], c))
    text = f"{LABELS[order[0]]} {fmt(values[order[0]])}"
    for a, b in zip(order, order[1:]):
        text += (" = " if fmt(values[a]) == fmt(values[b]) else " < ") + f"{LABELS[b]} {fmt(values[b])}"
    return text


def sec7_on_plants(plants: dict) -> dict:
    """What holds of Sec. 7's ordering (LQG least robust, LQDRF-diag most) on each plant, in words.

    Parameters
    ----------
    plants : dict
        Of :func:`per_plant`.

    Returns
    -------
    dict
        Plant -> sentence: the ordering by P(unstable) (and, where every
        controller is stable somewhere, by peak-ratio error), which
        controllers do not work at nominal on the MuJoCo plant.
    """
    out = {}
    for plant, per in plants.items():
        p = {c: v["probability_unstable"] for c, v in per.items() if v["probability_unstable"] is not None}
        e = {c: v["peak_ratio_error_db_median"] for c, v in per.items()
             if v["peak_ratio_error_db_median"] is not None and math.isfinite(v["peak_ratio_error_db_median"])}
        parts = []
        if p:
            parts.append("by P(unstable): " + _ordered(p, lambda v: f"{100 * v:.1f} %"))
        if e:
            text = "by median peak-ratio error of the stable samples: " + _ordered(e, lambda v: f"{v:.2f} dB")
            sets = {c: tuple(per[c].get("peak_ratio_modes_compared") or ()) for c in e}
            if len(set(sets.values())) > 1:
                text += (" (over different modes, so not like for like: "
                         + ", ".join(f"{LABELS[c]} modes {', '.join(map(str, m))}" for c, m in sets.items()) + ")")
            parts.append(text)
        broken = [LABELS[c] for c, v in per.items() if v.get("working_loop_at_nominal") is False]
        if broken:
            parts.append(f"not a working loop at nominal: {', '.join(broken)}")
        out[plant] = "; ".join(parts)
    return out
