"""``vlab crosscheck``: the MuJoCo plant against the FE model (frequencies, MAC, free decay)."""

from __future__ import annotations

import math

from . import checks
from .options import OutputFormat, arg_structure, flag, format_opt, json_flag, opt
from .output import console, err_console, print_json, print_rows, stages

#: Largest ``crosscheck --segments`` accepted (the plant's bodies grow linearly with it).
MAX_SEGMENTS = 64


def crosscheck(
    structure: str = arg_structure(),
    segments: int = opt(None, "--segments", min=1, max=MAX_SEGMENTS,
                        help=f"rigid bodies (hinges) per FE element segment of the MuJoCo plant, 1 to {MAX_SEGMENTS} "
                             "(default: chosen per member)"),
    n: int = opt(None, "--n", min=1, help="number of modes compared, >= 1 (default: 12 for the grid, 6 "
                                          "otherwise)"),
    fmt: OutputFormat = format_opt(),
    as_json: bool = json_flag(),
    yes: bool = flag("--yes", help="run a cross-check estimated to take more than 30 min"),
) -> None:
    """Cross-check the MuJoCo plant against the FE model: frequencies, MAC, free decay.

    Modes are paired one-to-one by MAC over a common band, against the structure file's mesh (for the BCC
    and the grid the thesis's) and the structure meshed at the plant's resolution; MuJoCo modes in the band
    without an FE partner are listed. A reference beyond the tolerance is named in the output. The plant's
    size, time and memory are estimated before it is built (on stderr); beyond 30 min it asks for --yes.
    """
    out = checks.output_format(fmt, as_json)
    spec = checks.load_structure(structure)
    n_modes = n or (12 if spec.name == "grid" else 6)
    mesh = _mesh_label(spec)
    _confirm_size(spec, segments, yes, quiet=out != "table")
    plant, refs, decay = _run(spec, segments, n_modes, quiet=out != "table", mesh=mesh)
    verdict, verdict_lines = _crosscheck_tolerance(refs, mesh)
    if out == "json":
        print_json(_as_json(spec, plant, refs, decay, verdict))
        return
    _print_table(out, spec, plant, refs, decay, verdict_lines, mesh)


def _confirm_size(spec, segments: int | None, yes: bool, *, quiet: bool) -> None:
    """Plan the plant (its size checks), print the estimate on stderr and refuse a run beyond 30 min unless
    ``yes`` (:func:`vlab.sim.estimate.plant_estimate`)."""
    from ..units import format_duration

    est = checks.plant_estimate(spec, segments, crosscheck=True)
    given = f"--segments {segments}" if segments is not None else f"{spec.name}'s segments_per_element"
    checks.confirm_long_run(given, est["time_s"], f"{est['what']}; dense linear algebra on {est['states']:.0f} "
                            f"states, about {est['memory_bytes'] / 1e9:.2g} GB", yes, "fewer --segments")
    if not quiet:
        err_console.print(f"estimate: {est['what']}, about {format_duration(est['time_s'])}, "
                          f"{est['memory_bytes'] / 1e9:.2g} GB", highlight=False)


def _mesh_label(spec) -> str:
    """The name of the structure file's own mesh in the output: ``"thesis mesh"`` for the dissertation's
    structures, ``"file mesh"`` (the structure file's elements per segment) for any other."""
    from ..experiment.config import dissertation_structure

    return "thesis mesh" if dissertation_structure(spec) else "file mesh"


def _run(spec, segments: int | None, n_modes: int, *, quiet: bool, mesh: str = "thesis mesh"):
    """Build the plant, pair its modes with both FE references, let mode 1 decay; the stages on stderr.

    Returns the plant, the cross-checks by reference name (``thesis_mesh``, ``plant_resolution``) and the free
    decay of mode 1 (None where mode 1 has no MuJoCo partner).
    """
    from ..sim import SimOptions, build_plant
    from ..sim import crosscheck as run_crosscheck
    from ..sim import free_decay

    with stages("crosscheck", "building the MuJoCo plant", quiet=quiet) as say:
        plant = build_plant(spec, SimOptions(segments_per_element=segments))
        say(f"pairing with the FE model ({mesh}; {plant.model.nv} plant DOFs)")
        refs = {"thesis_mesh": run_crosscheck(plant, n_modes)}
        say("pairing with the FE model (plant resolution)")
        refs["plant_resolution"] = run_crosscheck(plant, n_modes, mesh="plant")
        first = refs["thesis_mesh"].pairs[0]
        say("free decay of mode 1")
        decay = free_decay(plant, first.sim_mode, sim_modes=refs["thesis_mesh"].sim_modes) if first.sim_mode else None
    return plant, refs, decay


def _num(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _as_json(spec, plant, refs: dict, decay, verdict: dict) -> dict:
    """The JSON object of ``vlab crosscheck --format json``."""
    cc = refs["thesis_mesh"]
    return {
        "structure": spec.name,
        "frequencies_hz": {"fe": [p.fe_hz for p in cc.pairs], "mujoco": [_num(p.sim_hz) for p in cc.pairs]},
        "relative_error": [_num(p.error_pct / 100) for p in cc.pairs],
        "mac": [p.mac for p in cc.pairs],
        "mujoco_mode": [p.sim_mode for p in cc.pairs],
        "references": {key: {
            "fe_elements_per_segment": r.fe_elements,
            "pairing_band_hz": r.band_hz,
            "pairs": [{"fe_mode": p.fe_mode, "fe_hz": p.fe_hz, "mujoco_mode": p.sim_mode,
                       "mujoco_hz": _num(p.sim_hz), "error_pct": _num(p.error_pct), "mac": p.mac}
                      for p in r.pairs],
            "max_abs_error_pct": _num(r.max_error_pct()),
            "min_mac": r.min_mac(),
            "unpaired_mujoco_modes": [{"mujoco_mode": u.sim_mode, "mujoco_hz": u.sim_hz,
                                       "best_fe_mode": u.best_fe_mode, "best_mac": u.best_mac,
                                       "reason": u.reason} for u in r.unpaired],
        } for key, r in refs.items()},
        "free_decay_mode1_hz": None if decay is None else decay.frequency_hz,
        "free_decay_mode1_damping": None if decay is None else decay.damping_ratio,
        "timestep_s": plant.timestep_s,
        **verdict,
    }


def _print_table(out: str, spec, plant, refs: dict, decay, verdict_lines: list[str],
                 mesh: str = "thesis mesh") -> None:
    """The paired modes of both references side by side (table or CSV); with a table, the summary lines."""
    from ..io.tabular import Column

    thesis, fine = refs["thesis_mesh"], refs["plant_resolution"]
    rows = []
    for a, b in zip(thesis.pairs, fine.pairs):
        sm = "-" if a.sim_mode is None else str(a.sim_mode)
        if b.sim_mode != a.sim_mode:
            sm += f" / {'-' if b.sim_mode is None else b.sim_mode}"
        rows.append({"fe_mode": a.fe_mode, "mujoco_mode": sm, "mujoco_hz": _num(a.sim_hz),
                     "fe_thesis_mesh_hz": a.fe_hz, "error_thesis_mesh_pct": _num(a.error_pct),
                     "mac_thesis_mesh": a.mac, "fe_plant_resolution_hz": b.fe_hz,
                     "error_plant_resolution_pct": _num(b.error_pct), "mac_plant_resolution": b.mac})
    cols = [Column("fe_mode", "FE mode"), Column("mujoco_mode", "MuJoCo mode"),
            Column("mujoco_hz", "MuJoCo [Hz]", ".4f"), Column("fe_thesis_mesh_hz", f"FE [Hz] {mesh}", ".4f"),
            Column("error_thesis_mesh_pct", "error [%]", "+.2f"), Column("mac_thesis_mesh", "MAC [-]", ".4f"),
            Column("fe_plant_resolution_hz", "FE [Hz] plant resolution", ".4f"),
            Column("error_plant_resolution_pct", "error [%]", "+.2f"),
            Column("mac_plant_resolution", "MAC [-]", ".4f")]
    if out == "csv":
        print_rows(out, rows, cols)
        return
    print_rows(out, rows, cols, f"{spec.title}: MuJoCo plant vs FE model (timestep {plant.timestep_s * 1e3:g} ms), "
                                "modes paired one-to-one by MAC")
    by_count: dict[int, list[str]] = {}
    for k, v in fine.fe_elements.items():
        by_count.setdefault(v, []).append(k)
    els = "; ".join(f"{v} in {', '.join(ks) if len(ks) <= 3 else f'{len(ks)} members'}"
                    for v, ks in sorted(by_count.items()))
    console.print(f"FE at the plant's resolution, elements per segment: {els}")
    console.print(f"max |error|: {thesis.max_error_pct():.2f} % ({mesh}), "
                  f"{fine.max_error_pct():.2f} % (plant resolution)")
    for label, r in ((mesh, thesis), ("plant resolution", fine)):
        if not r.unpaired:
            console.print(f"{label}: every MuJoCo mode up to {r.band_hz:.4g} Hz has an FE partner")
        for u in r.unpaired:
            console.print(f"{label}: MuJoCo mode {u.sim_mode} ({u.sim_hz:.4f} Hz) unpaired: {u.reason}")
    if decay is not None:
        console.print(f"free decay of mode 1: {decay.frequency_hz:.4f} Hz, zeta = {decay.damping_ratio:.4f}")
    for line in verdict_lines:
        console.print(line, highlight=False)


def _crosscheck_tolerance(refs: dict, mesh: str = "thesis mesh") -> tuple[dict, list[str]]:
    """The cross-check's verdict against :data:`vlab.sim.crosscheck.TOL_PCT` and ``MIN_MAC``: JSON fields, lines.

    ``within_tolerance`` is true when every FE mode of every reference (``refs``: name -> CrossCheck) is paired
    within the frequency tolerance and the MAC threshold; ``beyond_tolerance`` names each reference that is not,
    with its worst error and MAC; ``tolerance`` gives both limits and their source.
    """
    from ..sim.crosscheck import MIN_MAC, TOL_PCT, TOLERANCE_SOURCE

    beyond, lines = {}, []
    for key, r in refs.items():
        if r.passed(TOL_PCT, MIN_MAC):
            continue
        err, mac = r.max_error_pct(), r.min_mac()
        worst = max(r.pairs, key=lambda p: abs(p.error_pct) if p.sim_mode is not None else math.inf)
        beyond[key] = {"max_abs_error_pct": err if math.isfinite(err) else None, "min_mac": mac,
                       "fe_mode": worst.fe_mode}
        label = mesh if key == "thesis_mesh" else key.replace("_", " ")
        err_text = f"{err:.2f} %" if math.isfinite(err) else "an unpaired FE mode"
        lines.append(f"BEYOND TOLERANCE ({label}): max |error| {err_text} (FE mode {worst.fe_mode}) against "
                     f"{TOL_PCT:g} %, min MAC {mac:.4f} against {MIN_MAC:g}")
    limits = f"|error| <= {TOL_PCT:g} %, MAC >= {MIN_MAC:g}"
    lines.append(f"tolerance: {limits} ({TOLERANCE_SOURCE})" if beyond else
                 f"within tolerance ({limits}) against every FE reference; source: {TOLERANCE_SOURCE}")
    return ({"within_tolerance": not beyond, "beyond_tolerance": beyond,
             "tolerance": {"max_abs_error_pct": TOL_PCT, "min_mac": MIN_MAC, "source": TOLERANCE_SOURCE}}, lines)
