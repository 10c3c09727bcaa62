"""Blind benchmark of ``vlab diagnose``: concealed effects, recorded with noise, diagnosed without knowing them.

Each case draws (reproducibly from ``--seed``):

- a structure (BCC or grid, alternating) and a controller (none, or the
  thesis controller: MFDRF on the BCC, LQG on the grid);
- sizes are redrawn (up to 8 times) until the effect changes the
  frequency-domain prediction of some line by at least 5 % on the plant
  used for the draw (a chosen threshold, meant to keep out effects the
  diagnosis could rightly call "no significant mismatch"; it is measured
  on the plant's noise-free FRFs, not on the recording, and does not make
  every effect stand out of the diagnosis's 0.5 % model floor: grid
  seed-1 case 2 is found only by the test on the recordings' noise alone,
  :func:`vlab.diagnose.fit.rules.changed_beyond_noise`); a pair
  is redrawn until its first effect is also visible in the final plant,
  next to the second (:func:`conceal`);
- nothing (one case in four: the false-alarm check), one effect, or (one
  case in six) two effects of the library, at random locations and sizes
  (a controller-path delay, lag or force limit closed loop on all channels
  or, one case in two, on one coil channel: an extra delay of 1-3 samples,
  a corner 1.5-6 times the top of the band, a limit 1-1.8 times that
  channel's RMS command, on a channel other than the one of the largest
  command, where it would be a limit on all channels)
  (sizes are drawn relative to the structure's own scales so that each is
  visible above the noise: added masses of 3-25 % of the modal mass at the
  point, springs of 5-100 % of the point stiffness, ...);
- the effect is concealed in the *plant* of the run -- the spec (structural
  effects), the FE model (gravity pre-stress), the linear plant (dashpots,
  Coulomb friction) or the hardware chain (delay, lags, gains,
  saturation) -- while the diagnosis uses the nominal lab;
- the experiment is run through the 2 kHz loop (:func:`vlab.lab.loop.run_loop`)
  on the linear FE plant with sensor noise in the feedback (1e-6 m/s) and 1 %
  white measurement noise added to every recorded velocity; the recording is
  written as UFF 58 and diagnosed with :func:`vlab.diagnose.diagnose` (linear
  plant for the validation rerun).

Printed: share of cases with the right effect(s) and location(s), the
parameter errors (of the FE fit, the diagnosis's answer; with a MuJoCo
plant also of the value refitted on the plant's linearisation that the
rerun used, ``validated.parameters``), the misfit reduction of the validation rerun (FRF and
time domain; also the share that is 5x lower *or* within 1.5x of the misfit
the measured noise alone leaves, ``validated.noise_misfit``, since a small
effect's misfit cannot fall 5x below a noise floor it starts less than 5x
above), false alarms on the no-effect cases, time per case. Targets
(issue 6): >= 90 % right, parameter error within 15 %, misfit >= 5x lower,
no false alarms, < 2 min per case. With ``--jobs 1`` (the default) each
case is diagnosed alone on the machine (its recording and baseline are
simulated in two processes before), so its time is the time a user waits;
``--jobs 2`` runs two cases at once and roughly doubles it.

With ``--plant mujoco`` the recordings (and the validation reruns) come
from the MuJoCo plant built from the edited spec instead, so the diagnosis
(fitted on the linear FE model) also faces the model-form error between the
two models; only effects the spec or the hardware chain can carry are drawn
(no point dashpots, Coulomb friction or gravity scaling), and ``--structures
bcc`` keeps to the structure whose MuJoCo plant runs 30x real time (the
MuJoCo grid's forced response is not yet linear enough to diagnose: README).

Without ``--baseline`` (the headline mode) the diagnosis compares each
recording with the nominal plant's replay of its recorded force (the
recording's metadata names the plant; :mod:`vlab.diagnose.data.reference`). With
``--baseline`` each case also records the unmodified plant excited by another
record of the same spectrum (other phases, other noise) and the diagnosis gets
it as its measured baseline (``vlab diagnose --baseline``) instead.

What it does not measure: real hardware.

Usage::

    python benchmarks/diagnose_benchmark.py --cases 24 [--seed 0] [--jobs 2] [--json out.json]
    python benchmarks/diagnose_benchmark.py --cases 24 --plant mujoco --structures bcc --baseline
    python benchmarks/diagnose_benchmark.py --cases 24 --plant mujoco --structures bcc --baseline --keep DIR
    python benchmarks/diagnose_benchmark.py --kept DIR [--only 2 5] [--json out.json]

``--keep DIR`` only generates: the recordings (and baselines) and each case's
truth (``case<i>.json``) are left in DIR, to diagnose with ``vlab diagnose``;
``--kept DIR [--only ...]`` diagnoses and scores them (another release on the
same recordings, without simulating them again).
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import glob
import json
import math
import os
import re
import sys
import tempfile
import time
from dataclasses import replace

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from vlab.diagnose import diagnose  # noqa: E402
from vlab.diagnose.data.replay import rerun  # noqa: E402
from vlab.diagnose.effects import specedit  # noqa: E402
from vlab.diagnose.model.labmodel import LabState, natural_frequencies, predict_frf, with_command_rms  # noqa: E402
from vlab.diagnose.model.nominal import nominal_design, settling_time  # noqa: E402
from vlab.diagnose.problem.context import Context, context_for  # noqa: E402
from vlab.errors import ModelError  # noqa: E402
from vlab.fe import build_fe_model  # noqa: E402
from vlab.io.uff import write_recording  # noqa: E402
from vlab.lab.excitation import pseudo_random  # noqa: E402
from vlab.lab.experiment import TESTS, default_chain  # noqa: E402
from vlab.lab.recording import Recording  # noqa: E402
from vlab.spec import load_spec  # noqa: E402
from vlab.units import G_SI  # noqa: E402

RES_HZ = 0.05
CONTROLLERS = {"bcc": "mfdrf", "grid": "lqg"}
#: The recordings' ``plant`` metadata, as ``vlab experiment`` writes it (the diagnosis replays on that plant).
RECORDED_PLANT = {"linear": "linear FE model", "mujoco": "MuJoCo plant"}
STRUCT = ("added_mass", "support_stiffness", "joint_flexibility", "member_stiffness", "damping_mode",
          "damping_point", "friction")
CHAIN_OPEN = ("actuator_lag", "actuator_gain")
CHAIN_CLOSED = ("loop_delay", "actuator_lag", "sensor_lag", "actuator_gain", "sensor_gain", "saturation")


def _logu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _two_sided(rng, lo, hi):
    """A factor in [lo, hi] or [1/hi, 1/lo] (lo, hi > 1)."""
    f = rng.uniform(lo, hi)
    return f if rng.random() < 0.5 else 1.0 / f


def _channel(rng, acts: list, ctx: Context):
    """Where a controller-path effect is drawn: all channels or (closed loop, one case in two) one actuator
    channel, uniformly. Open loop only the excited coil carries force: all channels."""
    if not ctx.closed_loop or not acts or rng.random() < 0.5:
        return "all"
    return int(rng.choice(acts))


def nominal_state(structure: str, controller: str) -> LabState:
    spec = load_spec(structure)
    fe = build_fe_model(spec)
    return LabState(spec, fe, default_chain(controller, noise_m_s=1e-6), nominal_design(fe, controller, 0))


def draw_effect(rng, family: str, st: LabState, ctx: Context, used: set) -> tuple[LabState, dict]:
    """Conceal one effect of ``family`` in ``st``; returns the plant state and the truth record."""
    spec = st.spec
    free = [p for p in sorted(spec.points) if (p, "w") in st.fe.dofs and p not in used]
    acts = [p for p in st.actuators if p not in used]
    if family == "added_mass":
        p = int(rng.choice(free))
        # a point near a support has a huge modal mass (8 t at the grid's top-beam ends): the scale is capped
        # at twice the structure's own mass, so that no draw is a mass no one would hang on it
        m = min(ctx.point_mass[p], MASS_CAP * _structure_mass(st)) * _logu(rng, 0.03, 0.25)
        return st.with_spec(specedit.add_mass(spec, p, m)), {"effect": "added_mass", "location": {"point": p},
                                                            "parameters": {"mass_kg": m}}
    if family == "support_stiffness":
        p = int(rng.choice(free))
        k = ctx.point_stiffness[p] * _logu(rng, 0.05, 1.0)
        return (st.with_spec(specedit.add_spring(spec, p, "w", k)),
                {"effect": "support_stiffness", "location": {"point": p, "dof": "w"},
                 "parameters": {"stiffness_n_per_m": k}})
    if family == "joint_flexibility":
        joints = [p for p in sorted(spec.points) if len(specedit.joint_segments(spec, p)) >= 2 and p not in used]
        p = int(rng.choice(joints))
        segs = specedit.joint_segments(spec, p)
        kref = float(np.mean([ei / length for _a, _b, length, ei in segs]))
        k = kref * _logu(rng, 0.3, 3.0)
        return (st.with_spec(specedit.soften_joint(spec, p, k)),
                {"effect": "joint_flexibility", "location": {"point": p},
                 "parameters": {"rotational_stiffness_n_m_per_rad": k}})
    if family == "member_stiffness":
        m = spec.members[int(rng.integers(len(spec.members)))]
        f = _two_sided(rng, 1.25, 1.8)
        ei = spec.sections[m.section].ei.si * f
        if len(m.points) > 2:
            i = int(rng.integers(len(m.points) - 1))
            seg = (m.points[i], m.points[i + 1])
            return (st.with_spec(specedit.scale_segments(spec, {seg: f})),
                    {"effect": "member_stiffness", "location": {"member": m.id, "segment": list(seg)},
                     "parameters": {"ei_n_m2": ei}})
        return (st.with_spec(specedit.scale_member(spec, m.id, f)),
                {"effect": "member_stiffness", "location": {"member": m.id}, "parameters": {"ei_n_m2": ei}})
    if family == "damping_mode":
        f, z, _ = natural_frequencies(st)
        lo, hi = ctx.band_hz
        modes = [i + 1 for i in range(len(f)) if lo <= f[i] <= hi][:6]
        r = int(rng.choice(modes))
        zeta = float(z[r - 1]) * rng.uniform(2.5, 5.0)
        return (st.with_spec(specedit.set_modal_damping(spec, r, zeta)),
                {"effect": "damping", "location": {"mode": r}, "parameters": {"damping_ratio": zeta}})
    if family == "damping_point":
        p = int(rng.choice(free))
        c = ctx.point_damping[p] * _logu(rng, 0.3, 3.0)
        return (replace(st, dashpots=st.dashpots + ((p, c),)),
                {"effect": "damping", "location": {"point": p}, "parameters": {"c_n_s_per_m": c}})
    if family == "friction":
        p = int(rng.choice([q for q in free if q in ctx.velocity_rms] or free))
        sigma = ctx.predicted_velocity_rms(st, p)
        force = ctx.point_damping[p] * sigma * math.sqrt(math.pi / 2) * _logu(rng, 0.5, 2.0)
        c_eq = math.sqrt(2 / math.pi) * force / sigma
        return (replace(st, frictions=st.frictions + ((p, force, c_eq),)),
                {"effect": "friction", "location": {"point": p}, "parameters": {"friction_force_n": force}})
    if family == "loop_delay":
        ch = _channel(rng, acts, ctx)
        t = st.chain.period_s
        if ch == "all":
            # extra phase lag of 0.15-0.5 rad at the top of the band
            d = st.chain.delay_periods * t + rng.uniform(0.15, 0.5) / (2 * math.pi * ctx.band_hz[1])
            chain = replace(st.chain, delay_periods=d / t)
        else:
            # one coil's DAC output 1-3 samples later than the others'
            d = (st.chain.delay_of(ch) + rng.uniform(1.0, 3.0)) * t
            chain = replace(st.chain, channel_delay_periods={**st.chain.channel_delay_periods, ch: d / t})
        return (replace(st, chain=chain),
                {"effect": "loop_delay", "location": {"channel": ch}, "parameters": {"delay_s": d}})
    if family in ("actuator_lag", "sensor_lag"):
        fc = ctx.band_hz[1] * _logu(rng, 1.5, 6.0)
        ch = _channel(rng, acts, ctx)
        attr = "actuator_lag_hz" if family == "actuator_lag" else "sensor_lag_hz"
        if ch == "all":
            chain = replace(st.chain, **{attr: fc})
        else:
            chain = replace(st.chain, **{"channel_" + attr: {**getattr(st.chain, "channel_" + attr), ch: fc}})
        return (replace(st, chain=chain),
                {"effect": family, "location": {"channel": ch}, "parameters": {"corner_hz": fc}})
    if family in ("actuator_gain", "sensor_gain"):
        ch = int(rng.choice(acts)) if (ctx.closed_loop or family == "sensor_gain") else ctx.excitation_point
        g = _two_sided(rng, 1.3, 1.8)
        attr = family
        gains = dict(getattr(st.chain, attr))
        gains[ch] = g
        return (replace(st, chain=replace(st.chain, **{attr: gains})),
                {"effect": family, "location": {"channel": ch}, "parameters": {"gain": g}})
    if family == "saturation":
        s2 = with_command_rms(replace(st, chain=replace(st.chain, amplifier_limit_n=1e30)), ctx.freq_hz,
                              ctx.force_amplitude, excitation_point=ctx.excitation_point, iterations=1)
        # a limit on the channel of the largest command clips that channel only, as a limit on all channels
        # does: the data cannot tell the two apart, so a one-channel limit is drawn on another channel
        top = max(s2.rms_force_n, key=s2.rms_force_n.get)
        ch = _channel(rng, [p for p in acts if p != top], ctx)
        rms = s2.rms_force_n[top] if ch == "all" else s2.rms_force_n[ch]
        lim = rms * rng.uniform(1.0, 1.8)
        chain = (replace(st.chain, amplifier_limit_n=lim) if ch == "all"
                 else replace(st.chain, channel_limit_n={**st.chain.channel_limit_n, ch: lim}))
        st = with_command_rms(replace(st, chain=chain), ctx.freq_hz, ctx.force_amplitude,
                              excitation_point=ctx.excitation_point)
        return (st,
                {"effect": "saturation", "location": {"channel": ch}, "parameters": {"limit_n": lim}})
    if family == "gravity_prestress":
        g = G_SI * _two_sided(rng, 1.3, 1.6)
        k0 = build_fe_model(specedit.without_gravity(spec)).k
        fe = replace(st.fe, k=k0 + (g / G_SI) * (st.fe.k - k0))
        return replace(st, fe=fe), {"effect": "gravity_prestress", "location": {}, "parameters": {"g_m_per_s2": g}}
    raise ValueError(family)


#: An effect is visible when it changes the predicted FRF of some line by this much (log magnitude).
VISIBLE = 0.05


#: Added masses are drawn relative to the modal mass at the point, capped at this many times the structure's mass.
MASS_CAP = 2.0


def _structure_mass(st: LabState) -> float:
    """Sum of the out-of-plane diagonal masses of the FE model [kg] (the structure's moving mass)."""
    rows = [st.fe.dofs.index(p, "w") for p in st.spec.points if (p, "w") in st.fe.dofs]
    return float(np.sum(np.diag(st.fe.m)[rows]))


def _on_plant(st: LabState, plant: str, points: tuple) -> LabState:
    """``st`` with the structure's modes of the plant that records the case (the FE model's for the linear plant)."""
    if plant != "mujoco":
        return st
    from vlab.diagnose.fit.plantfit import plant_modes

    return replace(st, point_modes=plant_modes(st.spec, points))


def _visible(a: LabState, b: LabState, freq_hz, exc: int, meas: tuple, plant: str = "linear") -> bool:
    """Does ``b`` change the predicted FRF of some line of ``a`` by ``VISIBLE`` (log magnitude), on the plant
    that records the case (for the MuJoCo plant: its linearisation, :func:`vlab.diagnose.fit.plantfit.plant_modes`)?"""
    pts = tuple(dict.fromkeys(tuple(meas) + a.actuators))
    h0 = predict_frf(_on_plant(a, plant, pts), freq_hz, excitation_point=exc, output_points=meas)
    h1 = predict_frf(_on_plant(b, plant, pts), freq_hz, excitation_point=exc, output_points=meas)
    return bool(np.max(np.abs(np.log(h1 / h0))) >= VISIBLE)


def _stage(family: str) -> int:
    """Drawing order: spec edits rebuild the FE model (and would drop an FE edit drawn before them), the
    gravity pre-stress edits the FE model, the saturation limit is sized on the final plant's forces."""
    return 0 if family in STRUCT else 1 if family == "gravity_prestress" else 3 if family == "saturation" else 2


def conceal(rng, families: list, st0: LabState, ctx: Context, freq_hz, exc: int, meas: tuple,
            attempts: int = 8, plant: str = "linear") -> tuple[LabState, list, bool]:
    """Draw the effects of ``families`` into ``st0``, each visible in the final plant.

    Effects are drawn in the order of :func:`_stage`. Each effect's size is redrawn (up to ``attempts`` times) until it changes
    some FRF line by ``VISIBLE`` on top of the effects drawn before it, on
    the ``plant`` that records the case (a member-stiffness change on the
    grid's shear-flexible top beam can move the FE model's FRF by 5 % and the
    MuJoCo plant's by less than the noise). With
    two effects the pair is redrawn until the first is also visible next to
    the second: the final plant against the second effect drawn alone on the
    nominal plant from the same random numbers (a large second effect can
    hide a small first one).

    A draw the structure cannot carry (an FE model that is not positive
    definite: an added mass that buckles a member of the hanging grid) is
    drawn again; it counts as one of the attempts.

    Returns
    -------
    (LabState, list of dict, bool)
        The plant, the truths, and whether an effect stayed below ``VISIBLE``
        after ``attempts`` tries (the last draw is kept; the case is flagged
        in the listing and counted in the summary).
    """
    families = sorted(families, key=_stage)
    for _pair in range(attempts):
        state, truths, used, redraw, hidden = st0, [], set(), None, False
        for fam in families:
            drawn = None
            for _attempt in range(attempts):
                before = copy.deepcopy(rng)
                try:
                    cand, t = draw_effect(rng, fam, state, ctx, used)
                except ModelError:  # a draw the structure cannot carry (a mass that buckles the grid): draw again
                    continue
                drawn = (cand, t, before)
                seen = _visible(state, cand, freq_hz, exc, meas, plant)
                if seen:
                    break
            if drawn is None:
                raise ModelError(f"no {fam} effect the structure can carry in {attempts} draws")
            cand, t, before = drawn
            hidden = hidden or not seen
            redraw = (before, fam, set(used))
            state = cand
            used |= {t["location"].get("point")} - {None}
            truths.append(t)
        if len(families) < 2:
            return state, truths, hidden
        second_alone, _ = draw_effect(redraw[0], redraw[1], st0, ctx, redraw[2])
        if _visible(second_alone, state, freq_hz, exc, meas, plant):
            return state, truths, hidden
    return state, truths, True


class _Signals:
    """Excitation lines and amplitudes, to size effects (what the diagnosis sees from the data)."""

    def __init__(self, force, dt, band):
        n_per = int(round(1 / (RES_HZ * dt)))
        X = np.fft.rfft(force[-n_per:])
        f = np.fft.rfftfreq(n_per, dt)
        amp = np.abs(X)
        k = np.flatnonzero((amp > 1e-6 * amp.max()) & (f >= band[0]) & (f <= band[1]))
        self.freq_hz, self.force_amplitude = f[k], 2 * amp[k] / n_per


#: A validation misfit within this factor of what the measured noise alone leaves
#: (``validated.noise_misfit``) counts as "down to the noise" in the summary. A
#: chosen reporting margin, not fitted: the floor is itself estimated from two
#: periods (small effects, at their floor, measured 0.85-0.95x of it).
NOISE_LEVEL = 1.5

MUJOCO_EXCLUDED = ("damping_point", "friction", "gravity_prestress")  # not expressible in the spec


def make_case(i: int, seed: int, plant: str = "linear", structures: tuple[str, ...] = ("bcc", "grid"),
              null_every: int = 0) -> dict:
    """Draw case ``i``: structure, controller, concealed effects (``plant`` limits the families).

    ``null_every`` = K > 0 makes every K-th case (i = K-1, 2K-1, ...) one without any effect and the others
    one or two effects, so that a run of n cases holds floor(n / K) nulls for certain (issue 28: "at least
    a quarter"); 0 draws "no effect" with probability 1/4 (the earlier listings)."""
    rng = np.random.default_rng([seed, i])
    structure = structures[i % len(structures)]
    closed = bool(rng.random() < 0.5)
    controller = CONTROLLERS[structure] if closed else "none"
    u = rng.random()
    if null_every:
        n_eff = 0 if i % null_every == null_every - 1 else (2 if u > 5 / 6 else 1)
    else:
        n_eff = 0 if u < 1 / 4 else (2 if u > 5 / 6 else 1)  # a quarter without any effect, on average
    fams = list(STRUCT) + list(CHAIN_CLOSED if closed else CHAIN_OPEN)
    if structure == "grid":
        fams.append("gravity_prestress")
    if plant == "mujoco":
        fams = [f for f in fams if f not in MUJOCO_EXCLUDED]
    chosen = []
    while len(chosen) < n_eff:
        f = str(rng.choice(fams))
        if f not in chosen and not ({f, *chosen} >= {"damping_point", "friction"}):
            chosen.append(f)
    return {"index": i, "structure": structure, "controller": controller, "families": chosen,
            "rng_seed": [seed, i, 1], "plant": plant}


def _simulate(state, force, exc, meas, plant, seed) -> dict:
    """Velocities ``{point: samples}`` of the test run on ``state`` (picklable, for a second process)."""
    rec, _ = rerun(state, force, excitation_point=exc, measured_points=meas, seed=seed, plant=plant)
    return {p: np.asarray(rec[f"vel{p}"]) for p in meas}


def _record(vel, force, exc, meas, dt, noise, rng, path, case) -> None:
    """Add measurement noise to the run's velocities ``vel`` and write the UFF 58 recording to ``path``."""
    signals = {f"force{exc}": force}
    for p in meas:
        v = vel[p]
        signals[f"vel{p}"] = v + noise * np.std(v) * rng.standard_normal(v.size)
    write_recording(path, Recording.from_signals(dt, signals, metadata={
        "structure": case["structure"], "controller": case["controller"], "seed": 0, "resolution_hz": RES_HZ,
        "plant": RECORDED_PLANT[case.get("plant", "linear")]}), overwrite=True)


def run_case(case: dict, workdir: str, noise: float = 0.01, baseline: bool = False, diagnose_it: bool = True,
             parallel: bool = False) -> dict:
    """Generate the recording of one case (and, with ``baseline``, one of the unmodified plant) and diagnose it
    blind (unless ``diagnose_it`` is false: the recordings and ``case<i>.json``, the truth, are left in ``workdir``).
    ``parallel``: simulate the recording and the baseline in two processes (same results; the diagnosis
    itself is timed alone)."""
    rng = np.random.default_rng(case["rng_seed"])
    st0 = nominal_state(case["structure"], case["controller"])
    test = TESTS[case["structure"]]
    settle = settling_time(st0, test.band_hz)
    period = 1.0 / RES_HZ
    n_periods = max(3, math.ceil(settle / period) + 2)
    dt = st0.chain.period_s
    n = int(round(n_periods * period / dt))
    force = pseudo_random(np.arange(n) * dt, band_hz=test.band_hz, resolution_hz=RES_HZ, rms_n=test.rms_n,
                          seed=int(rng.integers(1 << 30)))
    sig = _Signals(force, dt, test.band_hz)
    exc = st0.spec.instrumentation.excitation
    ctx = context_for(st0, test.band_hz, sig)
    ctx.closed_loop = st0.design is not None
    ctx.excitation_point = exc
    ctx.freq_hz, ctx.force_amplitude = sig.freq_hz, sig.force_amplitude
    meas = tuple(dict.fromkeys(test.measured_points + st0.actuators))
    plant = case.get("plant", "linear")
    truth_state, truths, hidden = conceal(rng, case["families"], st0, ctx, sig.freq_hz, exc, meas, plant=plant)
    t0 = time.perf_counter()
    path = os.path.join(workdir, f"case{case['index']}.uff")
    # the baseline: the same test on the unmodified plant, excited by another record of the same spectrum
    # (other phases) and with other noise: nothing of the recording's realisation is shared (issue 28 item 5)
    runs = [(truth_state, force, exc, meas, plant, case["index"])]
    if baseline:
        force_b = pseudo_random(np.arange(n) * dt, band_hz=test.band_hz, resolution_hz=RES_HZ, rms_n=test.rms_n,
                                seed=int(rng.integers(1 << 30)))
        runs.append((st0, force_b, exc, meas, plant, case["index"] + 10_000))
    if parallel and len(runs) > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(len(runs)) as ex:
            vels = list(ex.map(_simulate, *zip(*runs)))
    else:
        vels = [_simulate(*r) for r in runs]
    _record(vels[0], force, exc, meas, dt, noise, rng, path, case)  # noise drawn in this order, as before
    base_path = None
    if baseline:
        base_path = os.path.join(workdir, f"case{case['index']}_baseline.uff")
        _record(vels[1], runs[1][1], exc, meas, dt, noise, rng, base_path, case)
    t_gen = time.perf_counter() - t0
    if not diagnose_it:
        rec = {**case, "truth": truths, "hidden": hidden, "n_periods": n_periods, "recording": path,
               "baseline": base_path}
        with open(os.path.join(workdir, f"case{case['index']}.json"), "w") as fh:
            json.dump(rec, fh, indent=1)
        return {**rec, "time_generate_s": t_gen, "time_diagnose_s": 0.0, "result": None, "error": "not diagnosed"}
    return diagnose_case({**case, "truth": truths, "hidden": hidden, "n_periods": n_periods, "recording": path,
                          "baseline": base_path}, t_gen)


def diagnose_case(rec: dict, t_gen: float = 0.0) -> dict:
    """Diagnose one generated case blind (``rec``: the case with its ``recording`` and ``baseline`` paths, as
    ``case<i>.json`` of ``--keep`` holds it) and return it with the result, the error and the times."""
    t0 = time.perf_counter()
    try:
        res = diagnose(rec["structure"], rec["recording"], controller=rec["controller"],
                       plant=rec.get("plant", "linear"), baseline=rec["baseline"])
        d = res.as_dict()
        err = None
    except Exception as exc:  # a benchmark records failures instead of stopping
        d, err = None, f"{type(exc).__name__}: {exc}"
    return {**rec, "time_generate_s": t_gen, "time_diagnose_s": time.perf_counter() - t0, "result": d,
            "error": err}


def _same_location(a: dict, b: dict) -> bool:
    return {k: (list(v) if isinstance(v, (list, tuple)) else v) for k, v in a.items()} == \
        {k: (list(v) if isinstance(v, (list, tuple)) else v) for k, v in b.items()}


def score(case: dict) -> dict:
    """Right effect and location, parameter errors, misfit ratios of one case."""
    d = case["result"]
    truths = case["truth"]
    out = {"right": False, "lookalike": False, "false_alarm": False, "param_errors": [], "misfit_ratio": None, "time_ratio": None,
           "noise_ratio": None, "refit_errors": []}
    if d is None:
        return out
    sel = d["selected"]
    if not truths:
        out["false_alarm"] = bool(d["mismatch"])
        out["right"] = not d["mismatch"]
        return out
    matched = []
    for t in truths:
        hit = next((s for s in sel if s["effect"] == t["effect"] and _same_location(s["location"], t["location"])),
                   None)
        matched.append(hit)
    out["right"] = all(h is not None for h in matched) and len(sel) == len(truths)
    # the selection reported with look-alikes the data cannot tell from it (dBIC < 10): is the truth one?
    # (a pair's look-alikes are pairs, "a + b", matched in either order)
    looks = {frozenset(p.replace(" ", "") for p in a.split(" + ")) for a in d.get("alternatives", [])}
    out["lookalike"] = (not out["right"] and len(sel) == len(truths)
                        and frozenset(_label(t).replace(" ", "") for t in truths) in looks)
    for t, h in zip(truths, matched):
        if h is None:
            continue
        for k, v in t["parameters"].items():
            out["param_errors"].append(abs(h["parameters"][k] / v - 1.0))
    v = d["validated"]
    if out["right"] and v.get("parameters"):  # the value the MuJoCo rerun used, refitted on the plant
        for t in truths:
            for k, val in t["parameters"].items():
                out["refit_errors"] += [abs(x / val - 1.0) for n, x in v["parameters"].items()
                                        if n.split(".")[-1] == k]
    if v.get("misfit_after"):
        out["misfit_ratio"] = v["misfit_before"] / v["misfit_after"]
        if v.get("noise_misfit"):  # what is left, in units of what the noise alone leaves
            out["noise_ratio"] = v["misfit_after"] / v["noise_misfit"]
    if v.get("time_error_after"):
        out["time_ratio"] = v["time_error_before"] / v["time_error_after"]
    return out


def _label(t: dict) -> str:
    loc = ",".join(f"{k}={v}" for k, v in t["location"].items())
    return f"{t['effect']}({loc})"


def _line(r: dict, s: dict) -> str:
    d = r["result"]
    if d is None:
        got = r["error"]
    elif not d["mismatch"]:
        got = "no mismatch"
    else:
        got = " + ".join(_label(x) for x in d["selected"]) or "mismatch, unexplained"
    truth = " + ".join(_label(t) for t in r["truth"]) or "none"
    return (f"case {r['index']:3d} {r['structure']:4s} {r['controller']:5s} truth {truth} -> {got}: "
            f"{'OK' if s['right'] else 'WRONG (the right one among its look-alikes)' if s['lookalike'] else 'WRONG'}"
            f" ({r['time_generate_s']:.0f} + {r['time_diagnose_s']:.0f} s)"
            + (" [an effect drawn below visibility]" if r.get("hidden") else ""))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=12)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--noise", type=float, default=0.01, help="measurement noise, fraction of each channel's RMS")
    ap.add_argument("--json", type=str, default=None, help="write all cases and scores to this file")
    ap.add_argument("--only", type=int, nargs="*", default=None, help="run only these case indices")
    ap.add_argument("--plant", choices=("linear", "mujoco"), default="linear",
                    help="plant that records the cases and reruns the validation")
    ap.add_argument("--structures", nargs="+", choices=("bcc", "grid"), default=["bcc", "grid"])
    ap.add_argument("--null-every", type=int, default=0,
                    help="every K-th case without any effect (0: drawn with probability 1/4)")
    ap.add_argument("--baseline", action="store_true",
                    help="also record the unmodified plant and pass it to the diagnosis as its baseline")
    ap.add_argument("--keep", type=str, default=None,
                    help="only generate: write the recordings and each case's truth (case<i>.json) to this folder")
    ap.add_argument("--kept", type=str, default=None,
                    help="diagnose and score the cases --keep left in this folder (all, or those of --only)")
    args = ap.parse_args(argv)
    if args.kept:
        return _run_kept(args)
    cases = [make_case(i, args.seed, args.plant, tuple(args.structures), args.null_every) for i in range(args.cases)]
    if args.only:
        cases = [c for c in cases if c["index"] in args.only]
    t_all = time.perf_counter()
    if args.keep:
        os.makedirs(args.keep, exist_ok=True)
    with (tempfile.TemporaryDirectory() if not args.keep else contextlib.nullcontext(args.keep)) as work:
        diag = [not args.keep] * len(cases)
        if args.jobs > 1:
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(args.jobs) as ex:
                results = []
                for r in ex.map(run_case, cases, [work] * len(cases), [args.noise] * len(cases),
                                [args.baseline] * len(cases), diag):
                    results.append(r)
                    print(_line(r, score(r)), flush=True)
        else:
            results = []
            for c in cases:
                results.append(run_case(c, work, args.noise, args.baseline, not args.keep, parallel=True))
                r = results[-1]
                s = score(r)
                print(_line(r, s), flush=True)
    if args.keep:
        print(f"recordings and truths written to {args.keep}")
        return 0
    return _summarise(results, time.perf_counter() - t_all, args.json)


def _run_kept(args) -> int:
    """``--kept DIR``: diagnose the cases generated earlier with ``--keep DIR`` (generation times not known)."""
    recs = []
    for f in glob.glob(os.path.join(args.kept, "case*.json")):
        if re.fullmatch(r"case\d+\.json", os.path.basename(f)):
            with open(f) as fh:
                rec = json.load(fh)
            # the files as they lie in DIR now (DIR may have been given relative to another folder, or moved)
            rec["recording"] = os.path.join(args.kept, os.path.basename(rec["recording"]))
            if rec.get("baseline"):
                rec["baseline"] = os.path.join(args.kept, os.path.basename(rec["baseline"]))
            recs.append(rec)
    recs = sorted((r for r in recs if not args.only or r["index"] in args.only), key=lambda r: r["index"])
    if not recs:
        raise SystemExit(f"{args.kept}: no case<i>.json left by --keep" + (f" among {args.only}" if args.only else ""))
    t_all = time.perf_counter()
    results = []
    for rec in recs:
        results.append(diagnose_case(rec))
        print(_line(results[-1], score(results[-1])), flush=True)
    return _summarise(results, time.perf_counter() - t_all, args.json)


def _summarise(results: list, wall_s: float, json_path: str | None) -> int:
    """Print the summary of scored cases (and write them with their scores to ``json_path``); ``wall_s``:
    the run's wall time [s]."""
    scores = [score(r) for r in results]
    with_eff = [s for r, s in zip(results, scores) if r["truth"]]
    no_eff = [s for r, s in zip(results, scores) if not r["truth"]]
    perr = [e for s in with_eff if s["right"] for e in s["param_errors"]]
    rerr = [e for s in with_eff if s["right"] for e in s["refit_errors"]]
    right = [s for s in with_eff if s["right"] and s["misfit_ratio"]]
    mr = [s["misfit_ratio"] for s in right]
    # a small effect's misfit cannot fall below what the noise alone leaves: 5x or down to the noise
    at_noise = [s["misfit_ratio"] >= 5 or (s["noise_ratio"] is not None and s["noise_ratio"] <= NOISE_LEVEL)
                for s in right]
    tr = [s["time_ratio"] for s in with_eff if s["right"] and s["time_ratio"]]
    td = [r["time_diagnose_s"] for r in results]
    tg = [r["time_generate_s"] for r in results]
    summary = {
        "cases": len(results), "with_effect": len(with_eff), "no_effect": len(no_eff),
        "right_share": sum(s["right"] for s in with_eff) / max(len(with_eff), 1),
        "right_or_lookalike_share": sum(s["right"] or s["lookalike"] for s in with_eff) / max(len(with_eff), 1),
        "param_error_median": float(np.median(perr)) if perr else None,
        "param_error_max": float(np.max(perr)) if perr else None,
        "param_within_15pct_share": float(np.mean(np.array(perr) <= 0.15)) if perr else None,
        "refit_error_median": float(np.median(rerr)) if rerr else None,
        "refit_error_max": float(np.max(rerr)) if rerr else None, "refit_count": len(rerr),
        "misfit_ratio_median": float(np.median(mr)) if mr else None,
        "misfit_ratio_min": float(np.min(mr)) if mr else None,
        "misfit_ratio_5x_share": float(np.mean(np.array(mr) >= 5)) if mr else None,
        "misfit_5x_or_noise_share": float(np.mean(at_noise)) if at_noise else None,
        "time_error_ratio_median": float(np.median(tr)) if tr else None,
        "false_alarms": sum(s["false_alarm"] for s in no_eff),
        "hidden_effect_cases": [r["index"] for r in results if r.get("hidden")],
        "diagnose_time_s_median": float(np.median(td)), "diagnose_time_s_max": float(np.max(td)),
        "case_time_s_max": float(np.max(np.array(td) + np.array(tg))),
        "errors": [r["error"] for r in results if r["error"]],
        "wall_s": wall_s,
    }
    print()
    print(f"cases: {summary['cases']} ({summary['with_effect']} with concealed effects, "
          f"{summary['no_effect']} without)")
    print(f"right effect and location: {100 * summary['right_share']:.0f} %   (target >= 90 %)")
    print(f"  the right one selected or among the look-alikes reported with the selection (the data cannot tell "
          f"them apart, dBIC < 10): {100 * summary['right_or_lookalike_share']:.0f} %")
    if perr:
        print(f"parameter error: median {100 * summary['param_error_median']:.2f} %, max "
              f"{100 * summary['param_error_max']:.1f} %, within 15 %: {100 * summary['param_within_15pct_share']:.0f} %")
    if rerr:
        print("parameter error of the values the MuJoCo rerun used (the mode-moving ones refitted on the plant's "
              "linearisation, the others at their FE fit; "
              f"{len(rerr)} values): median {100 * summary['refit_error_median']:.2f} %, "
              f"max {100 * summary['refit_error_max']:.2f} %")
    if mr:
        print(f"misfit reduction (validation rerun, FRF log magnitude): median {summary['misfit_ratio_median']:.1f}x, "
              f"min {summary['misfit_ratio_min']:.1f}x, >= 5x in {100 * summary['misfit_ratio_5x_share']:.0f} % of cases; "
              f">= 5x or within {NOISE_LEVEL:g}x of the noise-only misfit in "
              f"{100 * summary['misfit_5x_or_noise_share']:.0f} %")
    if tr:
        print(f"time-domain error reduction: median {summary['time_error_ratio_median']:.1f}x")
    print(f"false alarms on no-effect cases: {summary['false_alarms']} of {summary['no_effect']}")
    print(f"cases with an effect drawn below visibility ({100 * VISIBLE:g} % on every line, 8 tries): "
          f"{summary['hidden_effect_cases'] or 'none'}")
    print(f"time per case: diagnosis median {summary['diagnose_time_s_median']:.0f} s, max "
          f"{summary['diagnose_time_s_max']:.0f} s; with the recording's simulation max {summary['case_time_s_max']:.0f} s"
          + (" (simulation not timed: cases generated earlier, --kept)" if not any(tg) else ""))
    if summary["errors"]:
        print("errors:", summary["errors"])
    if json_path:
        with open(json_path, "w") as fh:
            json.dump({"summary": summary, "cases": results, "scores": scores}, fh, indent=1, default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
