"""What moves the limit cycle of a loop that is unstable on the MuJoCo plant at nominal.

A rate-feedback loop whose controller has no roll-off spills over into a
residual mode above the design model's (Sec. 6.2.1); the computation delay
and the RC filter add phase lag that grows with frequency, and the loop
oscillates where that mode's phase and gain let it (Sec. 6.1: the
dissertation's LQG ended in "a limit cycle at approximately 41 Hz"). This
module reruns the nominal loop on the MuJoCo plant with one thing changed at
a time and reads the self-excited line's frequency with
:func:`vlab.robust.simulate.judge_run`:

* the computation delay, the ends of the study's default spread (1.35 +- 0.2
  periods, Sec. 5.3);
* the residual modes' frequency, through every section's bending stiffness
  (EI x 0.95 and x 1.05: frequencies x ~0.975 and ~1.025);
* the RC filter's corner (677 Hz, Sec. 5.3) halved and doubled.

Source: Sec. 5.3 (chain), 6.1 and 6.2.1 (limit cycle, spillover).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..fe import build_fe_model
from ..fe.modal import modal_analysis
from ..lab.loop import HardwareChain
from ..spec import with_quantity
from .simulate import CHECK_NOISE_M_S, run_cases
from .study import Nominal, StudyConfig, nominal_spec

#: The changes tried: (quantity, value, unit); ``None`` is the unchanged loop.
CHANGES = (
    ("nominal", None, ""),
    ("delay_periods", 1.15, "periods"),
    ("delay_periods", 1.55, "periods"),
    ("bending_stiffness_factor", 0.95, "-"),
    ("bending_stiffness_factor", 1.05, "-"),
    ("filter_hz", 677.0 / 2, "Hz"),
    ("filter_hz", 677.0 * 2, "Hz"),
)


def _spec_with_ei(spec, factor: float):
    out = spec
    for name, sec in spec.sections.items():
        out = with_quantity(out, f"sections.{name}.ei", sec.ei.si * factor)
    return out


def fe_loop_mode_near(cfg: StudyConfig, nominal: Nominal, controller: str, frequency_hz: float) -> dict:
    """The nominal FE sampled loop's closed-loop mode nearest ``frequency_hz``: what the linear analysis predicts there.

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    controller : str
    frequency_hz : float
        E.g. the MuJoCo limit cycle's line [Hz].

    Returns
    -------
    dict
        ``frequency_hz`` [Hz] and ``damping_ratio`` [-] of the pole ``s = ln(z) / T`` nearest in frequency.
    """
    from .simulate import _linear_loop

    spec0 = nominal_spec(cfg, nominal)
    chain0 = nominal.chains[controller]
    ones = np.ones(len(nominal.actuators))
    loop = _linear_loop(spec0, nominal, controller, nominal.response_point, delay_periods=chain0.delay_periods,
                        actuator_gain=ones, sensor_gain=ones)
    s = np.log(np.linalg.eigvals(loop.a_cl).astype(complex)) / chain0.period_s
    s = s[s.imag > 0]
    f = np.abs(s) / (2 * np.pi)
    i = int(np.argmin(np.abs(f - frequency_hz)))
    return {"frequency_hz": float(f[i]), "damping_ratio": float(-s[i].real / abs(s[i]))}


def limit_cycle_sensitivity(cfg: StudyConfig, nominal: Nominal, controller: str, *, seed: int = 0,
                            nthread: int = 0) -> list[dict]:
    """Run the nominal loop of ``controller`` on the MuJoCo plant with each change of :data:`CHANGES`.

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    controller : str
    seed : int
        Seed of the excitation and the sensor noise (the same for every run).
    nthread : int
        Threads of the batch (0: all CPUs).

    Returns
    -------
    list of dict
        One per change: ``quantity``, ``value``, ``unit``, ``unstable``,
        ``frequency_hz`` (the self-excited line, None when stable),
        ``growth_rate_1_s``, ``shift_hz`` (from the unchanged loop's line;
        None where either is stable), ``residual_mode_hz`` (the FE model's
        open-loop mode nearest the line, None when stable), ``summary``.

    Raises
    ------
    SpecError
        From the changed specs.
    """
    spec0 = nominal_spec(cfg, nominal)
    chain0 = nominal.chains[controller]
    base = HardwareChain(period_s=chain0.period_s, delay_periods=chain0.delay_periods, filter_hz=chain0.filter_hz,
                         noise_m_s=CHECK_NOISE_M_S)
    specs, chains = [], []
    for q, value, _ in CHANGES:
        specs.append(_spec_with_ei(spec0, value) if q == "bending_stiffness_factor" else spec0)
        chains.append(dataclasses.replace(base, **{q: value}) if q in ("delay_periods", "filter_hz") else base)
    _, _, verdicts, _ = run_cases(cfg, nominal, controller, specs, chains, [seed] * len(specs), seed=seed,
                                  nthread=nthread)
    f0 = verdicts[0].frequency_hz
    rows = []
    for (q, value, unit), v, spec in zip(CHANGES, verdicts, specs):
        f = v.frequency_hz if v.unstable and math.isfinite(v.frequency_hz) else None
        mode = None
        if f is not None:
            fe = build_fe_model(spec)
            fn = np.asarray(modal_analysis(fe.m, fe.k, 20).frequencies_hz)
            mode = float(fn[np.argmin(np.abs(fn - f))])
        rows.append({"quantity": q, "value": value, "unit": unit, "unstable": bool(v.unstable), "frequency_hz": f,
                     "growth_rate_1_s": None if not math.isfinite(v.growth_rate_1_s) else float(v.growth_rate_1_s),
                     "shift_hz": None if f is None or not math.isfinite(f0) else float(f - f0),
                     "residual_mode_hz": mode, "summary": v.summary})
    return rows
