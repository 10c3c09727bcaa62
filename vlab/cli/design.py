"""``vlab design``: a controller designed with the dissertation's settings; gains, damping and performance."""

from __future__ import annotations

from enum import Enum

import numpy as np
from rich.markup import escape

from ..errors import OptionError
from ..lab.blocks import PC1000_DELAY_PERIODS, RC_CORNER_HZ
from . import checks
from .figure_option import figure_path, write_atomically
from .options import REDUCTION_HELP, DesignReduction, OutputFormat, arg_structure, flag, format_opt, json_flag, opt
from .output import console, err_console, print_json, print_rows


class ControllerName(str, Enum):
    """``--controller`` of ``vlab design``."""

    lqr = "lqr"
    lqg = "lqg"
    mfdrf = "mfdrf"
    lqdrf = "lqdrf"
    lqdrf_diag = "lqdrf-diag"


def design(
    structure: str = arg_structure(),
    controller: ControllerName = opt(ControllerName.mfdrf, "--controller",
                                     help="controller: LQR (full state), LQG, MFDRF, LQDRF or LQDRF with a "
                                          "diagonal gain"),
    reduction: DesignReduction = opt(None, "--reduction", help=REDUCTION_HELP),
    modes_file: str = opt(None, "--modes", help="UFF 55 file of measured modes, read only with --reduction "
                                                 "corrected-guyan (default: a virtual modal test of the MuJoCo plant)"),
    seed: int = opt(0, "--seed", help="seed of the optimiser's multi-start, an integer in [0, 2**32)"),
    period_ms: float = opt(None, "--period-ms",
                           help="sampling period of the realization [ms], > 0 (default: the thesis's, "
                                "Sec. 5.3: LQG 1 ms, the others 0.5 ms)"),
    margins: bool = flag("--margins", help="also analyse the lab's sampled-data loop on the FE model (delay "
                                           f"{PC1000_DELAY_PERIODS:g} periods, hold, {RC_CORNER_HZ:g} Hz RC filter): loop-at-a-time gain and phase margins "
                                           "per channel and the peak sensitivity M_s (a second table; JSON key loop; "
                                           "with --format csv the margins' rows instead of the modes')"),
    figure: str = opt(None, "--figure", help="also draw the loop into this file (.png, .svg or .pdf): Bode and "
                                             "Nyquist of each loop-at-a-time gain, sigma_max of the sensitivity "
                                             "(default: no figure)"),
    overwrite: bool = flag("--overwrite", help="replace an existing --figure file"),
    fmt: OutputFormat = format_opt(),
    as_json: bool = json_flag("the tables"),
) -> None:
    """Design a controller with the dissertation's settings; print gains, damping and performance."""
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from ..design import design_controller
    from ..experiment.config import dissertation_structure, period_source
    from ..experiment.results import design_summary

    out = checks.output_format(fmt, as_json)
    period_s = checks.period_s(period_ms)
    checks.seed(seed)
    if modes_file is not None and reduction is not DesignReduction.corrected_guyan:
        raise OptionError("--modes is read only with --reduction corrected-guyan "
                          f"(got --reduction {reduction.value if reduction else 'default'})")
    checks.input_file("--modes", modes_file)
    if controller is ControllerName.lqr and (margins or figure is not None):
        raise OptionError("--margins and --figure analyse the sensor loop; LQR feeds back every state "
                          "(use --controller lqg, mfdrf, lqdrf or lqdrf-diag)")
    fig_path = figure_path(figure, overwrite)
    spec = checks.load_structure(structure)
    fe = checks.fe_model_of(spec)
    measured = _measured_modes(fe, modes_file) if reduction is DesignReduction.corrected_guyan else None
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=err_console,
                  transient=True, disable=out != "table") as bar:
        bar.add_task(f"designing {controller.value} for {spec.name}", total=None)
        d = design_controller(fe, controller.value, model=reduction.value if reduction else None,
                              measured_modes=measured, seed=seed, period_s=period_s)
    loop = _loop(fe, d, fig_path, overwrite) if (margins or fig_path is not None) else None
    thesis = dissertation_structure(spec)
    source = period_source(d.controller, d.period_s, spec)
    if out == "json":
        extra = {"loop": _loop_json(loop)} if margins else {}
        print_json({**design_summary(d), "period_source": source, "weights": _weights_json(spec), **extra})
        return
    if margins and out == "csv":
        _print_margins(loop, out)
        return
    rows, cols = _mode_rows(d, thesis)
    if out == "csv":
        print_rows(out, rows, cols)
        return
    console.print(f"[bold]{escape(spec.name)} {d.controller}[/] on the {d.model} model — converged: {d.converged} "
                  f"({escape(str(d.message))})")
    console.print(f"sampling period {d.period_s * 1e3:g} ms ({source})")
    console.print(escape(_weights_line(spec, thesis)))
    _print_gains(d, thesis)
    print_rows(out, rows, cols, "closed loop on the design model")
    if margins:
        _print_margins(loop, out)


def _weights_json(spec) -> dict:
    """The JSON key ``weights``: ``units_read`` (``"SI"``, ``"thesis"``: the ``units`` of the file's ``[design]``
    table; None: no weight given, the defaults) and ``si``, the weights used in SI (:func:`vlab.design.weights.
    weights_si`), each key ending in its unit (``q_displacement_per_m2``, ..., ``alpha_per_s``)."""
    from ..design import design_settings
    from ..design.weights import weights_si

    st = design_settings(spec)
    return {"units_read": st.weights_units,
            "si": {f"{k}_{_SI_SUFFIX[k]}": v for k, v in weights_si(st).items()}}


#: The unit of each SI weight as the JSON key's suffix (:data:`vlab.spec.DESIGN_WEIGHTS_SI`).
_SI_SUFFIX = {"q_displacement": "per_m2", "q_velocity": "s2_per_m2", "q_rotation": "per_rad2",
              "q_rotation_rate": "s2_per_rad2", "r": "per_n2", "r_corrected": "per_n2",
              "v1_displacement": "m2_per_s", "v1_velocity": "m2_per_s3", "v1_rotation": "rad2_per_s",
              "v1_rotation_rate": "rad2_per_s3", "v2": "m2_per_s", "alpha": "per_s"}


def _weights_line(spec, thesis: bool) -> str:
    """The text line saying in which units the LQ and Kalman weights were read (``[design] units``)."""
    from ..design import design_settings

    units = design_settings(spec).weights_units
    if units == "SI":
        return "weights read in SI (m, N, s) from the [design] table"
    if units == "thesis":
        return "weights read in the dissertation's units (in, lbf, cs) from the [design] table"
    if thesis:
        return "weights: the dissertation's (Secs. 6.1, 6.2; in, lbf, cs)"
    return "weights: the defaults (the BCC's, Sec. 6.1; the file's [design] table gives none)"


def _mode_rows(d, thesis: bool) -> tuple[list[dict], list]:
    """Rows (mode, frequency, damping, J) and columns of the closed-loop table: J in thesis units for the
    dissertation's structures (its tables), else in SI (:func:`vlab.design.performance_index_si`)."""
    from ..io.tabular import Column

    n_rows = min(max(len(d.performance_index_thesis_units), 6), len(d.damping_ratios))
    key = "performance_index_thesis_units" if thesis else "performance_index_si_1m_ic_s"
    j = np.asarray(d.performance_index_thesis_units, dtype=float) if thesis else d.performance_index_s
    rows = [{"mode": i + 1, "frequency_hz": float(d.frequencies_hz[i]), "damping_ratio": float(d.damping_ratios[i]),
             key: float(j[i]) if i < len(j) else None} for i in range(n_rows)]
    cols = [Column("mode", "mode"), Column("frequency_hz", "f [Hz]", ".3f"),
            Column("damping_ratio", "zeta [-]", ".4f"),
            Column(key, "J (modal IC) [thesis units]" if thesis else "J (modal IC, 1 m peak) [s]", ".4g")]
    return rows, cols


def _print_gains(d, thesis: bool) -> None:
    """The DRF objective and gain: in SI (N*s/m) and, for the dissertation's structures, as its tables print
    them (lb*s/in); an LQ design's gain is in the JSON."""
    if d.gamma_lb_s_per_in is not None:
        beta = "" if d.beta_s is None else (f", beta = {d.beta_thesis_units:.4g} (thesis units)" if thesis else
                                            f", beta = {d.beta_s:.4g} s (modal IC, 1 m peak)")
        si = f"{d.gamma_n_s_per_m:.4g} N*s/m"
        console.print((f"gamma = {d.gamma_lb_s_per_in:.4f} lb*s/in ({si})" if thesis else f"gamma = {si}") + beta)
    g = d.extra.get("gain_thesis_lb_s_per_in")
    if g is None:
        return
    if thesis:
        console.print("D in lb*s/in (thesis units, the form of Tables 7, 11, 15):")
        console.print(np.array2string(np.asarray(g), precision=4, suppress_small=True))
    else:
        console.print("D in N*s/m (u = -D y, y the sensor velocities in m/s):")
        console.print(np.array2string(np.asarray(d.gain), precision=4, suppress_small=True))


def _loop(fe, d, fig_path, overwrite: bool):
    """:func:`vlab.design.loop.analyse_loop` of the design; its figure written to ``fig_path`` when given."""
    from ..design.loop import analyse_loop

    loop = analyse_loop(fe, d)
    if fig_path is not None:
        from ..viz.loop_figures import loop_figure

        labels = [f"point {p}" for p in loop.points]
        cross = {lb: (m.crossover_hz, m.phase_crossover_hz) for lb, m in zip(labels, loop.margins)}
        title = (f"{fe.spec.name} {d.controller}: loop-at-a-time gains L = K G "
                 f"(T = {d.period_s * 1e3:g} ms, delay {loop.delay_periods:g} T, hold, RC)")
        write_atomically(fig_path, overwrite, lambda tmp: loop_figure(
            loop.freq_hz, loop.channel_gain, labels, loop.sigma_max_s, tmp, crossovers=cross,
            det_return_difference=loop.return_difference_det, title=title))
    return loop


def _loop_json(loop) -> dict:
    from ..design.loop import loop_summary

    return loop_summary(loop)


def _print_margins(loop, out: str) -> None:
    """The loop-at-a-time margins, one row per channel, and the peak sensitivity."""
    from ..design.loop import loop_summary
    from ..io.tabular import Column

    rows = loop_summary(loop)["channels"]
    cols = [Column("point", "channel (point)"), Column("gain_margin_db", "gain margin [dB]", ".2f"),
            Column("phase_crossover_hz", "at [Hz]", ".2f"), Column("phase_margin_deg", "phase margin [deg]", ".1f"),
            Column("crossover_hz", "crossover [Hz]", ".3f")]
    if out == "csv":
        print_rows(out, rows, cols)
        return
    print_rows(out, rows, cols, "loop-at-a-time margins of the sampled-data loop on the FE model (others closed)")
    console.print(f"peak sensitivity M_s = {loop.peak_sensitivity:.3f} at {loop.peak_sensitivity_hz:.3f} Hz "
                  f"(max sigma_max of S = (I + K G)^-1; no crossing on {loop.freq_hz[0]:g}-{loop.freq_hz[-1]:.0f} "
                  "Hz: blank)")
    verdict = "stable" if loop.closed_loop_unstable_poles == 0 else \
        f"UNSTABLE ({loop.closed_loop_unstable_poles} closed-loop poles in the right half-plane)"
    console.print(f"Nyquist of det(I + L): {loop.encirclements} encirclements of the origin, "
                  f"{loop.open_loop_unstable_poles} unstable open-loop poles: {verdict}")


def _measured_modes(fe, modes_file: str | None):
    """Measured modes (frequencies, shapes at the Guyan masters) for corrected-guyan."""
    from ..errors import DataFileError
    from ..models import master_indices

    if modes_file is None:
        if "frequencies" not in fe.spec.reference:
            raise OptionError(f"--reduction corrected-guyan: structure {fe.spec.name!r} has no published frequency "
                              "table ([reference] frequencies) for a virtual modal test: give --modes FILE (UFF 55)")
        return _virtual_measured_modes(fe)
    from ..io.uff import read_mode_shapes

    ms = read_mode_shapes(modes_file)
    idx = master_indices(fe, "guyan")
    labels = [fe.dofs.labels[i] for i in idx]
    rows = []
    for node, dof in labels:
        if dof != "w":
            raise DataFileError(f"{modes_file}: the Guyan master {dof}@{node} is a rotation; UFF 55 gives translations only")
        if node not in ms.point_ids:
            raise DataFileError(f"{modes_file}: no shape value at master point {node}")
        rows.append(list(ms.point_ids).index(node))
    return np.asarray(ms.freq_hz), np.real(np.asarray(ms.shapes))[rows, :]


def _virtual_measured_modes(fe):
    """:func:`vlab.sim.modaltest.virtual_measured_modes`, saying on stderr where the modes come from."""
    from ..sim.modaltest import virtual_measured_modes

    freq, shapes = virtual_measured_modes(fe)
    err_console.print(
        f"corrected-guyan: {len(freq)} modes, shapes from a virtual modal test on the MuJoCo plant (paired with the "
        f"FE modes by MAC), frequencies from {fe.spec.reference['frequencies']} (experimental)"
    )
    return freq, shapes
