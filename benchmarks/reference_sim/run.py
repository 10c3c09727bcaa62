"""Make a recording: the structure, the digital loop and the acquisition together.

This module never imports vlab.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import scipy.signal

from . import excitation as exc_mod
from .acquisition import Frontend, digitise
from .cases import Case, apply_effects
from .fe import assemble, modes
from .loop import Controller, dac_signal, run_loop
from .params import BccParams, load_bcc
from .plant import Diagonal, build_plant, modal_damping_matrix
from .uff58 import Channel, write_uff58

FINE_PER_PERIOD = 20
"""Fine integration steps per controller period (2 kHz -> 40 kHz, h = 25 us)."""


@dataclass(frozen=True)
class Settings:
    """Simulator settings that are not part of a case.

    Attributes
    ----------
    elements_per_segment, arm_elements, cable_elements : int
        FE mesh (see :func:`.fe.assemble`).
    delay_periods : float
        Nominal computation delay [periods] (Sec. 5.3: 1.35).
    rc_corner_hz : float
        RC-filter corner [Hz] (Sec. 5.3: 677).
    frontend : Frontend
        Acquisition settings.
    """

    elements_per_segment: int = 4
    arm_elements: int = 6
    cable_elements: int = 1
    delay_periods: float = 1.35
    rc_corner_hz: float = 677.0
    frontend: Frontend = Frontend()


def _excitation(case: Case, rate_hz: float, rng):
    """Generator samples (settle + analysed), and the period in samples (or None)."""
    e = case.excitation
    n_per = e["settle_periods"] + e["periods"]
    if e["kind"] == "multisine":
        one = exc_mod.multisine(e["period_s"], rate_hz, e["band_hz"], e["rms_n"], rng)
        return np.tile(one, n_per), one.size
    x = exc_mod.plain_random(e["period_s"] * n_per, rate_hz, e["band_hz"], e["rms_n"], rng)
    return x, None


def simulate(case: Case, ctrl: Controller, p: BccParams | None = None,
             settings: Settings = Settings()) -> dict:
    """Run one test and return its channels and truth.

    Parameters
    ----------
    case : Case
    ctrl : Controller
        The realised controller (:meth:`Controller.zero` for the open loop).
    p : BccParams, optional
        The nominal structure (default: ``assets/structures/bcc.toml``).
    settings : Settings

    Returns
    -------
    dict
        ``"compat"``: dict name -> (node, quantity, samples) at the controller rate;
        ``"lab"``: the same at the acquisition rate (when the case's mode asks);
        ``"dt_s"``: {"compat", "lab"}; ``"truth"``: a JSON-ready description.

    Raises
    ------
    ValueError
        Rates that do not divide the fine grid, and as the modules used.
    """
    p = p or load_bcc()
    ap = apply_effects(p, case.effects, settings.delay_periods)
    mesh = dict(elements_per_segment=settings.elements_per_segment,
                arm_elements=settings.arm_elements, cable_elements=settings.cable_elements)
    nominal, real = assemble(p, **mesh), assemble(ap.params, **mesh)
    c_damp = modal_damping_matrix(nominal, p.damping_ratios, p.default_damping_ratio,
                                  ap.damping_overrides)
    lab = case.mode in ("lab", "both")
    sensors = list(p.actuators)
    outputs = [(q, "vel") for q in sensors] + [(p.response, "vel")]
    outputs += [(q, "acc") for q in sorted(p.heights_m)] if lab else []
    diag = Diagonal(build_plant(real, c_damp, sensors, p.excitation, outputs,
                                settings.rc_corner_hz, ap.amp_gains))
    dt = ctrl.period_s
    h = dt / FINE_PER_PERIOD
    rng = np.random.default_rng(case.seed)
    f_gen, period_k = _excitation(case, 1.0 / dt, rng)
    n_k = f_gen.size
    u_exc = np.zeros((n_k * FINE_PER_PERIOD, len(sensors) + 1))
    u_exc[:, -1] = exc_mod.hold(f_gen, FINE_PER_PERIOD)
    eta0 = None
    if period_k is not None:
        eta0 = diag.periodic_start(u_exc[: period_k * FINE_PER_PERIOD], h)
    loop_rows = list(range(len(sensors) + 1))
    y_exc = diag.simulate(u_exc, h, FINE_PER_PERIOD, outputs=loop_rows, eta0=eta0)
    fe = settings.frontend
    noise = fe.velocity_noise * rng.standard_normal(y_exc.shape)
    u, y = run_loop(diag, loop_rows, ctrl, ap.delay_periods, y_exc, noise)
    skip = case.excitation["settle_periods"] * n_k // (
        case.excitation["settle_periods"] + case.excitation["periods"])
    force = f_gen + fe.force_noise * rng.standard_normal(n_k)
    compat = {f"force{p.excitation}": (p.excitation, "force", force[skip:])}
    for j, (q, _) in enumerate(outputs[: len(loop_rows)]):
        compat[f"vel{q}"] = (q, "velocity", y[skip:, j])
    result = {"compat": compat, "dt_s": {"compat": dt}, "u": u[skip:]}
    if lab:
        result["lab"], result["ranges"] = _lab_channels(
            diag, p, u, u_exc, eta0, ap.delay_periods, h, skip, outputs, fe, rng)
        result["dt_s"]["lab"] = 1.0 / fe.rate_hz
    result["truth"] = _truth(case, ctrl, settings, ap, nominal, real, real_mesh=mesh)
    return result


def _lab_channels(diag, p, u, u_exc, eta0, delay, h, skip, outputs, fe, rng):
    """Accelerations and force through the anti-alias filter, sampled, noisy, 16 bit."""
    dec = round(1.0 / (h * fe.rate_hz))
    if abs(dec * h * fe.rate_hz - 1.0) > 1e-9:
        raise ValueError(f"acquisition rate {fe.rate_hz} Hz does not divide the fine rate {1 / h} Hz")
    u_all = u_exc.copy()
    u_all[:, :-1] = dac_signal(u, delay, FINE_PER_PERIOD)
    sos = fe.anti_alias(1.0 / h)
    rows = [i for i, (_, kind) in enumerate(outputs) if kind == "acc"]
    acc = diag.simulate(u_all, h, dec, sos=sos, outputs=rows, eta0=eta0)
    force = scipy.signal.sosfilt(sos, u_exc[:, -1])[::dec]
    start = skip * FINE_PER_PERIOD // dec
    chans, ranges = {}, {}
    sig, full = digitise(force[start:], fe.force_noise, fe, rng)
    chans[f"force{p.excitation}"] = (p.excitation, "force", sig)
    ranges[f"force{p.excitation}"] = full
    for j, i in enumerate(rows):
        q = outputs[i][0]
        sig, full = digitise(acc[start:, j], fe.accel_noise, fe, rng)
        chans[f"acc{q}"] = (q, "acceleration", sig)
        ranges[f"acc{q}"] = full
    return chans, ranges


def _truth(case, ctrl, settings, ap, nominal, real, real_mesh):
    f_nom, _ = modes(nominal, 8)
    f_real, _ = modes(real, 8)
    return {
        "simulator": "benchmarks.reference_sim (independent of vlab)",
        "structure": "bcc",
        "controller": case.controller,
        "controller_period_s": ctrl.period_s,
        "effects": list(case.effects),
        "null_case": not case.effects,
        "excitation": case.excitation,
        "seed": case.seed,
        "delay_periods": ap.delay_periods,
        "amplifier_gains": list(ap.amp_gains),
        "damping_overrides": {str(k): v for k, v in ap.damping_overrides.items()},
        "rc_corner_hz": settings.rc_corner_hz,
        "mesh": real_mesh,
        "frontend": asdict(settings.frontend),
        "nominal_frequencies_hz": f_nom.tolist(),
        "true_frequencies_hz": f_real.tolist(),
    }


def write_outputs(result: dict, out: str | Path) -> list:
    """Write ``recording.uff`` (compat), ``lab.uff`` (lab) and ``truth.json``.

    Parameters
    ----------
    result : dict
        From :func:`simulate`.
    out : str or Path
        Output folder (created).

    Returns
    -------
    list of Path
        The files written.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    for key, name, desc in (("compat", "recording.uff", "controller-rate sample"),
                            ("lab", "lab.uff", "16-bit ADC after 8-pole anti-alias")):
        if key not in result:
            continue
        chans = [Channel(f"{node}+Z", node, "Z", qty, result["dt_s"][key], data,
                         f"reference_sim BCC {qty} ({desc})")
                 for _, (node, qty, data) in sorted(result[key].items())]
        files.append(write_uff58(out / name, chans))
    truth = dict(result["truth"])
    truth["files"] = [f.name for f in files]
    truth["input_ranges"] = result.get("ranges", {})
    (out / "truth.json").write_text(json.dumps(truth, indent=2) + "\n")
    files.append(out / "truth.json")
    return files
