"""``vlab update``: the structure file updated with a diagnosis, and optionally the check that the design on
it predicts the experiment again.

Thin: parses the options, calls :func:`vlab.model_update.update` and :func:`vlab.model_update.verify`,
prints a table or (``--format json``) one JSON object with the keys of :meth:`UpdateResult.as_dict` and,
with ``--verify``, ``verify`` (:func:`vlab.model_update.verify`).
"""

from __future__ import annotations

from typing import Any

from rich.markup import escape

from ..errors import OptionError
from . import checks
from .options import ExpController, OutputFormat, arg_structure, flag, format_opt, opt
from .output import console, print_json, print_rows, print_warnings


def update_cmd(
    structure: str = arg_structure(),
    diagnosis: str = opt(..., "--diagnosis", help="the folder `vlab diagnose --out` wrote (or its diagnosis.json)"),
    out: str = opt(..., "--out", help="updated structure file to write, ending in .toml; its folder must exist"),
    overwrite: bool = flag("--overwrite", help="replace an existing file"),
    verify: bool = flag("--verify", help="then design on the original and on the updated file, run both on the "
                                         "--mjcf plant and print, side by side, the average peak level error "
                                         "(Table 10) and the closed-loop damping ratios predicted and measured"),
    mjcf: str = opt(None, "--mjcf", help="with --verify: the plant both designs run on (an MJCF file, e.g. "
                                         "`vlab export-mjcf` of the changed structure; default: none)"),
    controller: ExpController = opt(None, "--controller",
                                    help="with --verify: the controller designed on each model (default: the "
                                         "diagnosis's, MFDRF for an open-loop diagnosis)"),
    seed: int = opt(0, "--seed", help="with --verify: seed of the excitation, noise and designs"),
    duration: float = opt(None, "--duration", help="with --verify: run length [s] (default: the structure's)"),
    fmt: OutputFormat = format_opt(),
    yes: bool = flag("--yes", help="with --verify: run two experiments estimated to take more than 30 min"),
) -> None:
    """Write the structure file with the physics a diagnosis found, as commented entries; --verify checks it.

    With --verify the two runs are estimated before the file is written; beyond 30 min they ask for --yes.
    """
    from ..model_update import update, verify as run_verify

    out_fmt = checks.output_format(fmt, False)
    spec = checks.load_structure(structure)
    if verify:
        if mjcf is None:
            raise OptionError("--verify needs --mjcf PLANT.xml: the plant both designs run on")
        checks.mjcf_input(mjcf)
        checks.number("--duration", duration, low=0.0, low_open=True, what="run length [s]")
        checks.seed(seed)
    elif mjcf is not None or controller is not None or duration is not None:
        raise OptionError("--mjcf, --controller and --duration belong to --verify: add --verify or drop them")
    ctrl = _verify_controller(spec, diagnosis, controller, duration, yes) if verify else None
    res = update(spec, diagnosis, out=out, overwrite=overwrite)
    obj: dict[str, Any] = res.as_dict()
    if verify:
        obj["verify"] = run_verify(spec, res.path, mjcf, controller=ctrl, seed=seed, duration_s=duration)
    if out_fmt == "json":
        print_json(obj)
        return
    _print_update(out_fmt, obj)


def _verify_controller(spec, diagnosis: str, controller: ExpController | None, duration: float | None,
                       yes: bool) -> str:
    """The controller --verify designs (the option, else the diagnosis's, else MFDRF); refuses ``none`` and two
    runs estimated beyond 30 min without ``yes`` (:func:`vlab.experiment.estimate.estimate_experiment`)."""
    from ..experiment.config import default_chain
    from ..experiment.estimate import estimate_experiment
    from ..model_update import read_diagnosis

    ctrl = controller.value if controller is not None else None
    if ctrl is None:
        d, _ = read_diagnosis(diagnosis)
        ctrl = d.get("controller") if d.get("controller") not in (None, "none", "lqr") else "mfdrf"
    if ctrl == "none":
        raise OptionError("--controller none: --verify compares designs; choose a controller")
    chain = default_chain(ctrl)
    est = estimate_experiment(checks.fe_model_of(spec), plant="mujoco", period_s=chain.period_s,
                              duration_s=duration, delay_periods=chain.delay_periods)
    checks.confirm_long_run("--duration" if duration is not None else "--verify", 2 * est["time_s"],
                            f"two runs of {est['n_ticks']:.3g} ticks", yes, "a shorter --duration")
    return ctrl


def _print_update(out_fmt: str, obj: dict[str, Any]) -> None:
    """The written entries and, with ``verify``, the side-by-side comparison (table or CSV)."""
    from ..io.tabular import Column

    rows = [{"effect": e["effect"], "location": ", ".join(f"{k} {v}" for k, v in e["location"].items()),
             "table": e["table"], "value": f"{v:.6g} {e['unit']}",
             "ci95": f"[{e['ci95'][n][0]:.4g}, {e['ci95'][n][1]:.4g}]"}
            for e in obj["entries"] for n, v in e["parameters"].items()]
    cols = [Column("effect", "effect"), Column("location", "location"), Column("table", "entry"),
            Column("value", "value"), Column("ci95", "95 % interval")]
    v = obj.get("verify")
    if out_fmt == "csv" and v is not None:
        print_rows(out_fmt, _verify_rows(v), _verify_cols())
        return
    print_rows(out_fmt, rows, cols, f"{obj['structure']}: entries written to {obj['out']}")
    if out_fmt == "csv":
        return
    if v is None:
        console.print(f"wrote {escape(str(obj['out']))}; check it: `vlab update ... --verify --mjcf PLANT.xml`",
                      highlight=False)
        return
    print_rows(out_fmt, _verify_rows(v), _verify_cols(),
                f"{v['controller']} designed on each model, run on {v['plant']}")
    console.print(f"average peak level error (Table 10): original {v['original']['average_peak_level_error']:.4f}, "
                  f"updated {v['updated']['average_peak_level_error']:.4f}", highlight=False)
    dz = [v[k]["damping_ratio_largest_relative_difference"] for k in ("original", "updated")]
    if None not in dz:
        console.print(f"closed-loop damping ratios, largest |measured / predicted - 1|: original {dz[0]:.1%}, "
                      f"updated {dz[1]:.1%}", highlight=False)
    for label in ("original", "updated"):
        print_warnings(v[label]["warnings"], label=f"warning ({label})")


def _verify_rows(v: dict) -> list[dict]:
    rows = []
    for a, b in zip(v["original"]["modes"], v["updated"]["modes"]):
        rows.append({"mode": a["mode"], "zeta_pred_orig": a["damping_ratio_predicted"],
                     "zeta_meas_orig": a["damping_ratio_measured"], "ratio_orig": a["peak_level_ratio"],
                     "zeta_pred_upd": b["damping_ratio_predicted"], "zeta_meas_upd": b["damping_ratio_measured"],
                     "ratio_upd": b["peak_level_ratio"]})
    return rows


def _verify_cols() -> list:
    from ..io.tabular import Column

    return [Column("mode", "mode"),
            Column("zeta_pred_orig", "original: zeta pred [-]", ".4f"),
            Column("zeta_meas_orig", "original: zeta meas [-]", ".4f"),
            Column("ratio_orig", "original: peak ratio [-]", ".3f"),
            Column("zeta_pred_upd", "updated: zeta pred [-]", ".4f"),
            Column("zeta_meas_upd", "updated: zeta meas [-]", ".4f"),
            Column("ratio_upd", "updated: peak ratio [-]", ".3f")]
