"""Pictures of a robustness study, written beside ``robustness.json`` (matplotlib, Agg).

* ``robustness.png`` -- per controller, violins of the damping ratio and the
  peak-ratio error [dB] per mode (sampled-data loop on the perturbed FE
  model), the energy-index ratio, and P(unstable) per plant with its Wilson
  interval;
* ``worst_time_history.png`` -- the worst time-simulated sample: the response
  velocity over the run and its spectrum with the excitation band marked.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .study import CONTROLLERS, LABELS, Nominal, StudyConfig


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _violin_panel(ax, data: list, title: str, labels: list[str], *, nominal_values: list | None = None,
                  zero_line: bool = False) -> None:
    """A violin per controller (``labels``; an empty one left blank), medians marked, nominal values as red x."""
    pos = [i + 1 for i, d in enumerate(data) if np.size(d) > 1]
    if pos:
        parts = ax.violinplot([data[p - 1] for p in pos], positions=pos, showmedians=True, showextrema=True,
                              widths=0.8)
        for body in parts["bodies"]:
            body.set_alpha(0.5)
    if nominal_values is not None:
        ax.plot(range(1, len(labels) + 1), nominal_values, "rx", label="nominal")
    if zero_line:
        ax.axhline(0.0, color="grey", lw=0.5)
    ax.set_title(title, fontsize=9)
    ax.set_xticks(range(1, len(labels) + 1), labels, rotation=45, fontsize=7)


def distribution_plots(path: Path, cfg: StudyConfig, nominal: Nominal, res: dict, plants: dict, *,
                       checks=()) -> Path:
    """``robustness.png``: the distributions per controller as violins, P(unstable) per plant with intervals.

    Parameters
    ----------
    path : Path
        PNG to write.
    cfg : StudyConfig
    nominal : Nominal
    res : dict
        Per-sample arrays of :func:`vlab.robust.study.run_study`.
    plants : dict
        Of :func:`vlab.robust.plants.per_plant`.
    checks : sequence of SimCheck
        The MuJoCo runs: a panel of their random samples' peak-ratio errors [dB] (stable runs only).

    Returns
    -------
    Path
        ``path``, the distribution plots.

    Raises
    ------
    OSError
        From writing.
    """
    plt = _pyplot()
    ctl = [c for c in CONTROLLERS if c in cfg.controllers]
    labels = [LABELS[c] for c in ctl]
    nm = nominal.n_modes
    fig, axes = plt.subplots(3, nm, figsize=(2.6 * nm, 8.5), squeeze=False)
    for r in range(nm):
        _violin_panel(axes[0, r], [res[f"{c}/zeta"][:, r] for c in ctl], f"mode {r + 1}: damping ratio", labels,
                      nominal_values=[nominal.zeta[c][r] for c in ctl])
        db = [20 * np.log10(nominal.peaks[c][r] / res[f"{c}/peaks"][:, r]) for c in ctl]
        _violin_panel(axes[1, r], [d[np.isfinite(d)] for d in db], f"mode {r + 1}: peak ratio [dB]", labels,
                      zero_line=True)
    axes[0, 0].legend(fontsize=7)
    with np.errstate(invalid="ignore"):  # an unstable nominal loop: inf / inf (NaN, not drawn)
        e = [res[f"{c}/energy_j_s"] / nominal.energy_j_s[c] for c in ctl]
    _violin_panel(axes[2, 0], [x[np.isfinite(x)] for x in e], "energy index / nominal", labels)
    ax = axes[2, 1] if nm > 1 else axes[2, 0]
    _probability_panel(ax, ctl, labels, plants)
    rest = list(axes[2, 2:])
    if checks and rest:
        by = {ch.controller: ch for ch in checks}
        data = []
        for c in ctl:
            ch = by.get(c)
            ok = np.zeros(0, dtype=bool) if ch is None else ch.random & ~ch.unstable_on_plant
            x = np.zeros(0) if ch is None else np.abs(20 * np.log10(ch.peak_analysis_over_experiment[ok])).mean(axis=1)
            data.append(x[np.isfinite(x)])
        _violin_panel(rest[0], data, "MuJoCo: peak-ratio error [dB], random stable runs", labels)
        rest = rest[1:]
    for a in rest:
        a.axis("off")
    fig.suptitle(f"{cfg.structure}: {cfg.n_samples} samples, seed {cfg.seed}; violins: sampled-data loop on the "
                 "perturbed FE model; peak ratio = analysis/experiment (Table 10)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _probability_panel(ax, ctl, labels, plants: dict) -> None:
    """Bars of P(unstable) [%] per controller and plant with their Wilson 95 % intervals."""
    width = 0.8 / max(len(plants), 1)
    names = {"fe_sampled_loop": "FE sampled loop", "mujoco_time_simulation": "MuJoCo (random samples)"}
    for j, (plant, per) in enumerate(plants.items()):
        x = np.arange(len(ctl)) + (j - (len(plants) - 1) / 2) * width
        p = np.array([100 * (per[c]["probability_unstable"] or 0.0) if c in per else np.nan for c in ctl])
        ci = np.array([[100 * (v if v is not None else np.nan) for v in per[c]["probability_unstable_ci95"]]
                       if c in per else [np.nan, np.nan] for c in ctl])
        err = np.clip(np.vstack([p - ci[:, 0], ci[:, 1] - p]), 0, None)
        ax.bar(x, p, width, yerr=np.nan_to_num(err), capsize=2, label=names.get(plant, plant))
    ax.set_xticks(range(len(ctl)), labels, rotation=45, fontsize=7)
    ax.set_ylim(0, 105)
    ax.set_title("P(unstable) [%], 95 % Wilson", fontsize=9)
    ax.legend(fontsize=6)


def time_history_plot(path: Path, result, *, title: str, response_point: int, band_hz) -> Path:
    """``worst_time_history.png``: response velocity over the run and its spectrum, the excitation band marked.

    Parameters
    ----------
    path : Path
    result : LoopResult
        The run (:class:`vlab.lab.loop.LoopResult`).
    title : str
    response_point : int
        Point whose ``vel<p>`` [m/s] is drawn.
    band_hz : (float, float)
        Excitation band [Hz].

    Returns
    -------
    Path
        ``path``, the time-history plot.

    Raises
    ------
    OSError
        From writing.
    """
    plt = _pyplot()
    rec = result.recording
    v = np.asarray(rec[f"vel{response_point}"], dtype=float)
    t = np.arange(v.size) * rec.dt_s
    fig, (a, b) = plt.subplots(2, 1, figsize=(8, 6))
    a.plot(t, v, lw=0.4)
    a.set_xlabel("time [s]")
    a.set_ylabel(f"velocity at point {response_point} [m/s]")
    half = v[v.size // 2:]
    spec = np.abs(np.fft.rfft(half - half.mean())) ** 2
    f = np.fft.rfftfreq(half.size, rec.dt_s)
    b.semilogy(f[1:], spec[1:] + 1e-300, lw=0.5)
    b.axvspan(*band_hz, color="green", alpha=0.15, label="excitation band")
    b.set_xlim(0, min(f[-1], 4 * band_hz[1]))
    b.set_xlabel("frequency [Hz]")
    b.set_ylabel("|FFT|^2, second half [(m/s)^2]")
    b.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
