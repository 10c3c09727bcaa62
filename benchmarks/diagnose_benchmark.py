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
above), false alarms on the no-effect cases, time per case. Targets:
>= 90 % right, parameter error within 15 %, misfit >= 5x lower,
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

Tier 2 (``--tier 2``): a reality that is not the model.
Tier 1 (the default, all of the above) records on the very plant the
diagnosis replays. In tier 2 the recordings come from a plant the diagnosis
does not use, and the diagnosis is unchanged (it replays the recorded force
on the *default* MuJoCo plant of the nominal spec):

- the plant that records is the *converged* MuJoCo plant (about twice the
  links per segment, 25 us step; its options are read from
  ``assets/model_form/<structure>.json``, written by
  ``benchmarks/plant_model_form.py``, which also lists the default plant's
  discretisation error mode by mode: BCC 0.03-0.37 %, grid 0.01-0.14 %);
- built from the nominal spec *perturbed within its stated model-form
  uncertainty*: every member's (and crosspiece's) bending rigidity ``EI`` and
  every lumped mass (crosspiece tip and clamp masses included) is multiplied
  by a factor ``p_i = exp(e_i)``, ``e_i ~ N(0, s^2)`` independent, drawn per
  case; the factors and the frequency shifts they give are recorded in the
  case (``perturbation``); the controller stays the one designed on the
  nominal model, as in a real lab;
- the effects are concealed on top of that perturbed spec: each one's kind
  and place drawn as in tier 1, its size set to ``q`` times the threshold
  from which the diagnosis detects and names it there, ``q`` log-uniform in
  :data:`THRESHOLD_WINDOW` (2-5x; :func:`threshold_sizer`; held within the
  range the threshold was searched in, and redrawn unless at least
  :data:`MIN_THRESHOLD_RATIO` (2) times it, or where the effect is never
  named in its range) (:func:`vlab.diagnose.detectability.detectability`
  with ``naming=True`` on the nominal test: detection by the diagnosis's own
  profiled test, naming among the library's look-alikes; the sensor noise
  set to the recordings' noise: the loop's 1e-6 m/s and ``--noise`` times the
  largest predicted channel RMS, combined); the ratio is kept in each truth
  (``threshold_ratio``) and printed per case (samples before this window,
  seeds 9191-9797, drew tier 1's sizes and kept those at 2x or more; seed
  9898 drew at 2-5x the first-order detection threshold alone);
- the excitation realisation, the loop's sensor noise and the measurement
  noise come from the tier's own random stream (``tier_seed`` = [seed, i, 2]);
  the seeds are kept in the case (``recording_seeds``) and nowhere else: the
  recording's metadata holds structure, controller, the controller design's
  seed 0 and the resolution, and -- unlike tier 1's -- names no plant (it is
  a recording of a reality, not of a vlab plant), and the diagnosis is called
  as for a recording of the real structure (``plant="auto"``): it replays on
  the default MuJoCo plant of the nominal spec, knows neither the converged
  plant's options nor any seed of the recording, and compares within the
  model's own uncertainty (``model_form="auto"`` turns it off for a
  recording that names the vlab plant which made it);
- null cases (no effect: only the model-form difference) are every third
  case by default (``--null-every 3``; at most 3 is accepted).

The spread ``s`` is derived from the FE model's sensitivities (computed,
not chosen): with ``S_ri = d ln f_r / d ln p_i`` (forward differences,
step 1e-3, on the FE model of the spec, for the modes in the test band),
to first order ``d ln f_r = sum_i S_ri e_i``, whose standard deviation is
``s g_r`` with ``g_r = sqrt(sum_i S_ri^2)``. The stated model-form
uncertainty of the frequencies is the ``calibration`` component ``c`` of
:func:`vlab.diagnose.model.modelform.model_form_uncertainty` (the model's
residual standard error against the published analysis it was calibrated
to); ``s`` is set so that the RMS over the band's modes of ``s g_r`` equals
the RMS of ``c``: ``s = c_rms / sqrt(mean_r g_r^2)``. The discretisation
component is not added: the converged plant supplies the plant's own. BCC:
``c`` = 0.051 %, ``s`` = 0.23 % per factor, per-mode frequency standard
deviations 0.014-0.071 % (first order and FE agree to 1e-6). Grid: ``c`` =
9.7 % and the grid's frequencies are mostly set by gravity and the strings,
which are not perturbed: ``s`` = 0.60 (factors of 0.55-1.8 at one sigma),
beyond the first-order range (the FE shifts differ from the linear
prediction by several per cent) -- the grid's calibration residual is a
model-form error of its own, which EI and mass factors reach only as such
large scatter.

Tier 3 (``--tier 3``, :mod:`diagnose_tier3`): the recordings come from the independent reference
simulator (``benchmarks/reference_sim``, which shares no code with vlab), written as an acquisition system
writes them (5 kHz accelerations at points 1-9 through an anti-alias filter, 16 bit, noise, UFF 58 without
a sidecar), and are diagnosed by ``vlab diagnose`` with the options a user without a sidecar gives; BCC only
(the simulator has no grid); effects of the kinds the simulator conceals at 2-5x vlab's detection threshold
for the loop used, every second case a null case (half of those closed loop); scored as tiers 1 and 2, with
the passengers (effects selected beside the true one) counted.

A compound case (two effects concealed together) is right when both are named and nothing else; otherwise
it is scored as "a part named with the remainder stated" when only true effects are named and the diagnosis
reports a remainder (``remainder`` in diagnosis.json), else as "neither".

What it does not measure: real hardware.

Usage::

    python benchmarks/diagnose_benchmark.py --cases 24 [--seed 0] [--jobs 2] [--json out.json]
    python benchmarks/diagnose_benchmark.py --cases 24 --plant mujoco --structures bcc --baseline
    python benchmarks/diagnose_benchmark.py --cases 24 --plant mujoco --structures bcc --baseline --keep DIR
    python benchmarks/diagnose_benchmark.py --kept DIR [--only 2 5] [--json out.json]
    python benchmarks/diagnose_benchmark.py --tier 2 --structures bcc --cases 12 --seed 7100
    python benchmarks/diagnose_benchmark.py --tier 3 --cases 24 --seed S [--jobs 2] [--keep-recordings DIR] [--baseline]

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
from functools import lru_cache

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from _listing import command_header  # noqa: E402

from vlab.diagnose import diagnose  # noqa: E402
from vlab.diagnose.data.replay import rerun  # noqa: E402
from vlab.diagnose.effects import specedit  # noqa: E402
from vlab.diagnose.model.labmodel import LabState, natural_frequencies, predict_frf, with_command_rms  # noqa: E402
from vlab.diagnose.model.nominal import nominal_design, settling_time  # noqa: E402
from vlab.diagnose.problem.context import Context, context_for  # noqa: E402
from vlab.errors import ModelError  # noqa: E402
from vlab.fe import build_fe_model, modal_analysis  # noqa: E402
from vlab.io.uff import write_recording  # noqa: E402
from vlab.lab.excitation import pseudo_random  # noqa: E402
from vlab.experiment.config import TESTS, default_chain  # noqa: E402
from vlab.io.recording import Recording  # noqa: E402
from vlab.spec import ASSETS_DIR, Quantity, StructureSpec, load_spec  # noqa: E402
from vlab.spec.changes import piece_ends  # noqa: E402
from vlab.units import G_SI  # noqa: E402

RES_HZ = 0.05
CONTROLLERS = {"bcc": "mfdrf", "grid": "lqg"}
#: With ``--closed-nulls``: the controllers the null cases are recorded under, in turn (the dissertation's
#: two DRF designs, Sec. 5: the closed loops whose prediction a false alarm would discredit).
NULL_CONTROLLERS = ("mfdrf", "lqdrf")
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


def draw_effect(rng, family: str, st: LabState, ctx: Context, used: set, size_of=None) -> tuple[LabState, dict]:
    """Conceal one effect of ``family`` in ``st``; returns the plant state and the truth record.

    ``size_of(rng, effect, location, parameter, value)`` (tier 2), when given, replaces the drawn size
    ``value`` of the effect's parameter once its place is chosen (:func:`threshold_sizer`)."""
    spec = st.spec

    def sized(effect: str, loc: dict, name: str, value: float) -> float:
        return value if size_of is None else float(size_of(rng, effect, loc, name, value))

    free = [p for p in sorted(spec.points) if (p, "w") in st.fe.dofs and p not in used]
    acts = [p for p in st.actuators if p not in used]
    if family == "added_mass":
        p = int(rng.choice(free))
        # a point near a support has a huge modal mass (8 t at the grid's top-beam ends): the scale is capped
        # at twice the structure's own mass, so that no draw is a mass no one would hang on it
        m = min(ctx.point_mass[p], MASS_CAP * _structure_mass(st)) * _logu(rng, 0.03, 0.25)
        m = sized("added_mass", {"point": p}, "mass_kg", m)
        return st.with_spec(specedit.add_mass(spec, p, m)), {"effect": "added_mass", "location": {"point": p},
                                                            "parameters": {"mass_kg": m}}
    if family == "support_stiffness":
        p = int(rng.choice(free))
        k = ctx.point_stiffness[p] * _logu(rng, 0.05, 1.0)
        k = sized("support_stiffness", {"point": p, "dof": "w"}, "stiffness_n_per_m", k)
        return (st.with_spec(specedit.add_spring(spec, p, "w", k)),
                {"effect": "support_stiffness", "location": {"point": p, "dof": "w"},
                 "parameters": {"stiffness_n_per_m": k}})
    if family == "joint_flexibility":
        joints = [p for p in sorted(spec.points) if len(specedit.joint_segments(spec, p)) >= 2 and p not in used]
        p = int(rng.choice(joints))
        segs = specedit.joint_segments(spec, p)
        kref = float(np.mean([ei / length for _a, _b, length, ei in segs]))
        k = kref * _logu(rng, 0.3, 3.0)
        k = sized("joint_flexibility", {"point": p}, "rotational_stiffness_n_m_per_rad", k)
        return (st.with_spec(specedit.soften_joint(spec, p, k)),
                {"effect": "joint_flexibility", "location": {"point": p},
                 "parameters": {"rotational_stiffness_n_m_per_rad": k}})
    if family == "member_stiffness":
        m = spec.members[int(rng.integers(len(spec.members)))]
        f = _two_sided(rng, 1.25, 1.8)
        ei0 = spec.sections[m.section].ei.si
        ei = ei0 * f
        if len(m.points) > 2:
            i = int(rng.integers(len(m.points) - 1))
            seg = (m.points[i], m.points[i + 1])
            ei = sized("member_stiffness", {"member": m.id, "segment": list(seg)}, "ei_n_m2", ei)
            f = ei / ei0
            return (st.with_spec(specedit.scale_segments(spec, {seg: f})),
                    {"effect": "member_stiffness", "location": {"member": m.id, "segment": list(seg)},
                     "parameters": {"ei_n_m2": ei}})
        ei = sized("member_stiffness", {"member": m.id}, "ei_n_m2", ei)
        f = ei / ei0
        return (st.with_spec(specedit.scale_member(spec, m.id, f)),
                {"effect": "member_stiffness", "location": {"member": m.id}, "parameters": {"ei_n_m2": ei}})
    if family == "damping_mode":
        f, z, _ = natural_frequencies(st)
        lo, hi = ctx.band_hz
        modes = [i + 1 for i in range(len(f)) if lo <= f[i] <= hi][:6]
        r = int(rng.choice(modes))
        zeta = float(z[r - 1]) * rng.uniform(2.5, 5.0)
        zeta = sized("damping", {"mode": r}, "damping_ratio", zeta)
        return (st.with_spec(specedit.set_modal_damping(spec, r, zeta)),
                {"effect": "damping", "location": {"mode": r}, "parameters": {"damping_ratio": zeta}})
    if family == "damping_point":
        p = int(rng.choice(free))
        c = ctx.point_damping[p] * _logu(rng, 0.3, 3.0)
        c = sized("damping", {"point": p}, "c_n_s_per_m", c)
        return (replace(st, dashpots=st.dashpots + ((p, c),)),
                {"effect": "damping", "location": {"point": p}, "parameters": {"c_n_s_per_m": c}})
    if family == "friction":
        p = int(rng.choice([q for q in free if q in ctx.velocity_rms] or free))
        sigma = ctx.predicted_velocity_rms(st, p)
        force = ctx.point_damping[p] * sigma * math.sqrt(math.pi / 2) * _logu(rng, 0.5, 2.0)
        force = sized("friction", {"point": p}, "friction_force_n", force)
        c_eq = math.sqrt(2 / math.pi) * force / sigma
        return (replace(st, frictions=st.frictions + ((p, force, c_eq),)),
                {"effect": "friction", "location": {"point": p}, "parameters": {"friction_force_n": force}})
    if family == "loop_delay":
        ch = _channel(rng, acts, ctx)
        t = st.chain.period_s
        if ch == "all":
            # extra phase lag of 0.15-0.5 rad at the top of the band
            d = st.chain.delay_periods * t + rng.uniform(0.15, 0.5) / (2 * math.pi * ctx.band_hz[1])
            d = sized("loop_delay", {"channel": ch}, "delay_s", d)
            chain = replace(st.chain, delay_periods=d / t)
        else:
            # one coil's DAC output 1-3 samples later than the others'
            d = (st.chain.delay_of(ch) + rng.uniform(1.0, 3.0)) * t
            d = sized("loop_delay", {"channel": ch}, "delay_s", d)
            chain = replace(st.chain, channel_delay_periods={**st.chain.channel_delay_periods, ch: d / t})
        return (replace(st, chain=chain),
                {"effect": "loop_delay", "location": {"channel": ch}, "parameters": {"delay_s": d}})
    if family in ("actuator_lag", "sensor_lag"):
        fc = ctx.band_hz[1] * _logu(rng, 1.5, 6.0)
        ch = _channel(rng, acts, ctx)
        fc = sized(family, {"channel": ch}, "corner_hz", fc)
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
        g = sized(family, {"channel": ch}, "gain", g)
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
        lim = sized("saturation", {"channel": ch}, "limit_n", lim)
        chain = (replace(st.chain, amplifier_limit_n=lim) if ch == "all"
                 else replace(st.chain, channel_limit_n={**st.chain.channel_limit_n, ch: lim}))
        st = with_command_rms(replace(st, chain=chain), ctx.freq_hz, ctx.force_amplitude,
                              excitation_point=ctx.excitation_point)
        return (st,
                {"effect": "saturation", "location": {"channel": ch}, "parameters": {"limit_n": lim}})
    if family == "gravity_prestress":
        g = G_SI * _two_sided(rng, 1.3, 1.6)
        g = sized("gravity_prestress", {}, "g_m_per_s2", g)
        k0 = build_fe_model(specedit.without_gravity(spec)).k
        fe = replace(st.fe, k=k0 + (g / G_SI) * (st.fe.k - k0))
        return replace(st, fe=fe), {"effect": "gravity_prestress", "location": {}, "parameters": {"g_m_per_s2": g}}
    raise ValueError(family)


# ------------------------------------------------------------------ tier 2 ---

#: Tier 2: effects are drawn at least this many times their detect-and-name threshold.
MIN_THRESHOLD_RATIO = 2.0
#: Tier 2: every K-th case without any effect by default (at least a third of the cases).
TIER2_NULL_EVERY = 3
#: Relative step of the finite-difference sensitivities ``d ln f / d ln p`` of the perturbation.
SENSITIVITY_STEP = 1e-3


def converged_plant_options(structure: str) -> dict:
    """Keywords of :class:`vlab.sim.SimOptions` of the converged plant of ``structure`` (tier 2's recordings).

    Read from ``assets/model_form/<structure>.json`` (``converged_options.sim_options``), the data
    ``python benchmarks/plant_model_form.py <structure>`` writes.

    Raises
    ------
    ModelError
        The file is missing or holds no options (names the file and the command that writes it).
    """
    path = ASSETS_DIR / "model_form" / f"{structure}.json"
    try:
        with open(path) as fh:
            kw = json.load(fh)["converged_options"]["sim_options"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ModelError(f"{path}: no converged plant options ({exc}); write them with "
                         f"`python benchmarks/plant_model_form.py {structure}`") from None
    if not isinstance(kw, dict) or "timestep_s" not in kw:
        raise ModelError(f"{path}: converged_options.sim_options must be a table with timestep_s, got {kw!r}")
    return kw


def perturbation_names(spec: StructureSpec) -> list[str]:
    """The perturbed parameters of a spec: ``ei:<member or crosspiece id>`` (bending rigidity) and
    ``mass:<mass id>``, ``mass:<crosspiece id>.tip``, ``mass:<crosspiece id>.clamp`` (lumped masses)."""
    return ([f"ei:{m.id}" for m in spec.members] + [f"ei:{c.id}" for c in spec.crosspieces]
            + [f"mass:{m.id}" for m in spec.masses]
            + [f"mass:{c.id}.{part}" for c in spec.crosspieces for part in ("tip", "clamp")])


def perturb(spec: StructureSpec, factors: dict) -> StructureSpec:
    """``spec`` with bending rigidities and lumped masses multiplied by ``factors`` (name -> factor > 0).

    Names as :func:`perturbation_names` (missing: 1). Each member and crosspiece gets its own copy of its
    section (``<section>@tier2:<id>``) with ``EI`` scaled (``GJ``, the in-plane and axial rigidities and
    the mass per length unchanged); member and crosspiece ids are kept, so effects drawn on the result
    are located as on the nominal spec. A lumped mass's rotary inertias scale with it.

    Raises
    ------
    ValueError
        A non-positive factor or an unknown name.
    """
    unknown = set(factors) - set(perturbation_names(spec))
    if unknown:
        raise ValueError(f"perturb: unknown parameters {sorted(unknown)}")
    if any(not f > 0 for f in factors.values()):
        raise ValueError(f"perturb: factors must be > 0, got {factors}")
    sections = dict(spec.sections)
    src = "benchmark tier 2: model-form perturbation x{:.6g}"

    def section(name: str, owner: str) -> str:
        f = factors.get(f"ei:{owner}", 1.0)
        if f == 1.0:
            return name
        sec = spec.sections[name]
        new = f"{name}@tier2:{owner}"
        sections[new] = replace(sec, name=new, ei=Quantity(sec.ei.si * f, src.format(f)))
        return new

    def q(x: Quantity | None, f: float) -> Quantity | None:
        return x if x is None or f == 1.0 else Quantity(x.si * f, src.format(f))

    members = tuple(replace(m, section=section(m.section, m.id)) for m in spec.members)
    crosspieces = tuple(replace(c, section=section(c.section, c.id),
                                tip_mass=q(c.tip_mass, factors.get(f"mass:{c.id}.tip", 1.0)),
                                clamp_mass=q(c.clamp_mass, factors.get(f"mass:{c.id}.clamp", 1.0)))
                        for c in spec.crosspieces)
    masses = []
    for lm in spec.masses:
        f = factors.get(f"mass:{lm.id}", 1.0)
        masses.append(replace(lm, mass=q(lm.mass, f), inertia_rx=q(lm.inertia_rx, f), inertia_ry=q(lm.inertia_ry, f)))
    return spec.replace(sections=sections, members=members, crosspieces=crosspieces, masses=tuple(masses))


def _band_frequencies(spec: StructureSpec, n: int) -> np.ndarray:
    fe = build_fe_model(spec)
    return modal_analysis(fe.m, fe.k, n).frequencies_hz


@lru_cache(maxsize=None)
def perturbation_scale(structure: str) -> dict:
    """The spread of tier 2's perturbation factors, from the FE model's sensitivities (module notes, "Tier 2").

    Returns
    -------
    dict
        ``names`` (list of str, :func:`perturbation_names`), ``frequencies_hz`` (the FE modes in the test
        band), ``sensitivity`` (n_modes x n_params, ``d ln f_r / d ln p_i``), ``calibration_rel`` (RMS over
        those modes of :func:`vlab.diagnose.model.modelform.model_form_uncertainty`'s ``calibration``
        component [1]), ``spread_ln`` (the standard deviation of every ``ln p_i`` [1]) and
        ``frequency_sd_rel`` (the first-order standard deviation of each ``ln f_r`` it gives [1]).

    Raises
    ------
    ModelError, SpecError
        The FE model cannot be built.
    """
    from vlab.diagnose.model.modelform import model_form_uncertainty
    from vlab.experiment.config import test_definition

    spec = load_spec(structure)
    fe = build_fe_model(spec)
    f_all = modal_analysis(fe.m, fe.k).frequencies_hz
    n = int(np.count_nonzero(f_all <= test_definition(spec).band_hz[1]))
    f0 = f_all[:n]
    names = perturbation_names(spec)
    sens = np.empty((n, len(names)))
    for i, name in enumerate(names):
        f1 = _band_frequencies(perturb(spec, {name: math.exp(SENSITIVITY_STEP)}), n)
        sens[:, i] = np.log(f1 / f0) / SENSITIVITY_STEP
    cal = np.asarray(model_form_uncertainty(spec, f0).components["calibration"], dtype=float)
    c = float(np.sqrt(np.mean(cal**2)))
    g = np.sqrt(np.sum(sens**2, axis=1))  # sqrt(sum_i S_ri^2): the sd of ln f_r per unit sd of ln p
    s = c / float(np.sqrt(np.mean(g**2)))
    return {"names": names, "frequencies_hz": f0, "sensitivity": sens, "calibration_rel": c, "spread_ln": s,
            "frequency_sd_rel": s * g}


def draw_perturbation(rng, structure: str) -> tuple[StructureSpec, dict]:
    """The nominal spec of ``structure`` perturbed within its stated model-form uncertainty (tier 2).

    Every ``ln p_i`` of :func:`perturbation_names` is drawn from ``N(0, spread_ln^2)``
    (:func:`perturbation_scale`).

    Returns
    -------
    (StructureSpec, dict)
        The perturbed spec, and its record: ``factors`` (name -> factor), ``spread_ln``,
        ``calibration_rel``, ``frequency_shift_first_order`` (``sum_i S_ri ln p_i`` per band mode),
        ``frequency_shift_fe`` (``ln(f / f_nominal)`` of the perturbed FE model, modes by order) and
        ``frequency_sd_rel`` (first-order standard deviation per mode).
    """
    sc = perturbation_scale(structure)
    eps = rng.normal(0.0, sc["spread_ln"], len(sc["names"]))
    factors = {n: float(math.exp(e)) for n, e in zip(sc["names"], eps)}
    spec = perturb(load_spec(structure), factors)
    f0 = sc["frequencies_hz"]
    return spec, {"factors": factors, "spread_ln": sc["spread_ln"], "calibration_rel": sc["calibration_rel"],
                  "frequency_shift_first_order": [float(x) for x in sc["sensitivity"] @ eps],
                  "frequency_shift_fe": [float(x) for x in np.log(_band_frequencies(spec, f0.size) / f0)],
                  "frequency_sd_rel": [float(x) for x in sc["frequency_sd_rel"]]}


@lru_cache(maxsize=None)
def _thresholds(structure: str, controller: str, effect: str, noise_m_s: float) -> tuple:
    """The thresholds at which the diagnosis detects *and names* ``effect`` at every location (the
    smallest size the standard test can detect and name): :func:`vlab.diagnose.detectability.detectability`
    with its naming thresholds, each ``threshold`` replaced by the size from which the effect is named (None
    where it is detected but never named in its range: such a draw is redrawn). The detection test is the
    diagnosis's own, profiled within the model form."""
    from vlab.diagnose.detectability import detectability

    det = detectability(structure, controller, effects=(effect,), noise_m_s=noise_m_s, naming=True)
    return tuple(replace(t, threshold=t.named_at) for t in det.thresholds)


#: Tier 2: effects are drawn at this range of multiples of their detect-and-name threshold (log-uniform; within
#: the 1-5x of that threshold the cases are to be drawn at, and at >= 2x, where the target counts effects).
THRESHOLD_WINDOW = (2.0, 5.0)


def threshold_sizer(thresholds_of):
    """A ``size_of`` for :func:`draw_effect` (tier 2): the effect's parameter set to ``q`` times its detection
    threshold at the drawn place, ``q`` log-uniform in :data:`THRESHOLD_WINDOW` (drawn from the effect's own
    random stream, so that a redraw of the same effect gives the same size), on the side of the drawn value;
    the drawn value is kept where no threshold is known or the effect is not detected in its range, and the
    size is held within the range searched (``bound``).

    Parameters
    ----------
    thresholds_of : callable ``effect -> sequence of Threshold``
    """
    def size_of(rng, effect: str, loc: dict, name: str, value: float) -> float:
        q = math.exp(rng.uniform(math.log(THRESHOLD_WINDOW[0]), math.log(THRESHOLD_WINDOW[1])))
        ths = [t for t in thresholds_of(effect) if _same_location(t.location, loc) and t.parameter == name]
        if not ths:
            return value
        side = [t for t in ths if t.null is None or (value - t.null) * (t.bound - t.null) > 0] or ths
        t = side[0]
        if t.threshold is None:
            return value
        x = t.scaled(q)
        lo, hi = sorted((t.threshold, t.bound))
        return float(min(max(x, lo), hi))

    return size_of


def threshold_ratio(truth: dict, thresholds) -> float | None:
    """How many times its threshold (detect and name, in tier 2) a concealed effect is.

    ``(x - null) / (threshold - null)`` on the side of the drawn value ``x``; for an effect that vanishes
    only in a limit (a rigid joint, no lag, no force limit) ``threshold / x`` or ``x / threshold``, the
    inverse of :meth:`vlab.diagnose.detectability.Threshold.scaled`. 0 where the test does not detect the
    effect even at the end of its range; None where no threshold is known for the effect and location.
    """
    ths = [t for t in thresholds if t.effect == truth["effect"] and _same_location(t.location, truth["location"])]
    ths = [t for t in ths if t.parameter in truth["parameters"]]
    if not ths:
        return None
    x = float(truth["parameters"][ths[0].parameter])
    for t in ths:
        if t.null is None:
            if t.threshold is None:
                return 0.0
            return t.threshold / x if t.bound < t.threshold else x / t.threshold
        if (x - t.null) * (t.bound - t.null) > 0:
            return 0.0 if t.threshold is None else (x - t.null) / (t.threshold - t.null)
    return 0.0


def _simulate_on_plant(state, force, exc, meas, seed, options: dict) -> dict:
    """Velocities ``{point: samples}`` of the test run on the MuJoCo plant built from ``state.spec`` with
    :class:`vlab.sim.SimOptions` ``options`` (tier 2's converged plant): the loop of
    :func:`vlab.diagnose.data.replay.rerun` from rest, on that plant (picklable, for a second process)."""
    from vlab.lab.engine import ControllerEngine
    from vlab.lab.loop import run_loop
    from vlab.sim import MujocoPlant, SimOptions, build_plant

    if state.dashpots or state.frictions:
        raise ModelError("point dashpots and friction cannot be expressed in the spec the MuJoCo plant is built from")
    plant = MujocoPlant(build_plant(state.spec, SimOptions(**options)))
    d = state.design
    engine = None if d is None else ControllerEngine(d.f11, d.f12, d.f21, d.f22, period_s=state.chain.period_s)
    force = np.asarray(force, dtype=float)
    loop = run_loop(plant, engine, feedback_points=state.actuators, measured_points=tuple(meas),
                    excitation_point=exc, excitation=force, duration_s=force.size * state.chain.period_s,
                    chain=state.chain, seed=seed, shape_points=())
    return {p: np.asarray(loop.recording[f"vel{p}"]) for p in meas}


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
            attempts: int = 8, plant: str = "linear", accept=None, size_of=None) -> tuple[LabState, list, bool]:
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

    ``accept`` (tier 2), called with each drawn truth record, must also
    return True for the draw to count as visible (:data:`MIN_THRESHOLD_RATIO`
    times the effect's detect-and-name threshold); it may add to the record.
    ``size_of`` (tier 2, :func:`threshold_sizer`) sizes each effect from its threshold; the
    threshold then stands for visibility (the 5 % line test is not made).

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
                    cand, t = draw_effect(rng, fam, state, ctx, used, size_of)
                except ModelError:  # a draw the structure cannot carry (a mass that buckles the grid): draw again
                    continue
                drawn = (cand, t, before)
                seen = ((size_of is not None or _visible(state, cand, freq_hz, exc, meas, plant))
                        and (accept is None or accept(t)))
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
        if size_of is not None:  # sized from the thresholds, each effect on its own
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
              null_every: int = 0, tier: int = 1, closed_nulls: bool = False) -> dict:
    """Draw case ``i``: structure, controller, concealed effects (``plant`` limits the families).

    ``null_every`` = K > 0 makes every K-th case (i = K-1, 2K-1, ...) one without any effect and the others
    one or two effects, so that a run of n cases holds floor(n / K) nulls for certain (the requirement: at
    least a quarter); 0 draws "no effect" with probability 1/4 (the earlier listings).

    ``tier`` 2 (``plant`` must be ``"mujoco"``) adds ``"tier": 2``, the converged plant's options
    (``plant_options``, :func:`converged_plant_options`) and the seed of the tier's own random stream
    (``tier_seed``: the perturbation, the excitation and the noise; module notes, "Tier 2"); the draws of
    structure, controller and families are those of tier 1.

    ``closed_nulls`` records every null case in closed loop, under :data:`NULL_CONTROLLERS` in turn (the
    other draws are unchanged).

    Raises
    ------
    ValueError
        ``tier`` 2 with a plant other than ``"mujoco"``, or a tier other than 1 or 2.
    ModelError
        Tier 2 without the converged options of the structure (:func:`converged_plant_options`)."""
    if tier not in (1, 2):
        raise ValueError(f"tier must be 1 or 2, got {tier!r}")
    if tier == 2 and plant != "mujoco":
        raise ValueError(f"tier 2 records on the (converged) MuJoCo plant: plant must be 'mujoco', got {plant!r}")
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
    if closed_nulls and not chosen:
        controller = NULL_CONTROLLERS[(i // max(null_every, 1)) % len(NULL_CONTROLLERS)]
    case = {"index": i, "structure": structure, "controller": controller, "families": chosen,
            "rng_seed": [seed, i, 1], "plant": plant}
    if tier == 2:
        case.update({"tier": 2, "plant_options": converged_plant_options(structure), "tier_seed": [seed, i, 2]})
    return case


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
    meta = {"structure": case["structure"], "controller": case["controller"], "seed": 0, "resolution_hz": RES_HZ,
            "plant": RECORDED_PLANT[case.get("plant", "linear")]}
    if case.get("tier", 1) == 2:  # a recording of a reality, not of a vlab plant: no plant named (module notes)
        del meta["plant"]
    write_recording(path, Recording.from_signals(dt, signals, metadata=meta), overwrite=True)


def run_case(case: dict, workdir: str, noise: float = 0.01, baseline: bool = False, diagnose_it: bool = True,
             parallel: bool = False) -> dict:
    """Generate the recording of one case (and, with ``baseline``, one of the unmodified plant) and diagnose it
    blind (unless ``diagnose_it`` is false: the recordings and ``case<i>.json``, the truth, are left in ``workdir``).
    ``parallel``: simulate the recording and the baseline in two processes (same results; the diagnosis
    itself is timed alone).

    Tier 2 (``case["tier"] == 2``, module notes): the plant that records is the converged MuJoCo plant
    (``case["plant_options"]``) of the nominal spec perturbed within its model-form uncertainty
    (:func:`draw_perturbation`, recorded under ``perturbation``) with the effects concealed on top, each at
    least :data:`MIN_THRESHOLD_RATIO` times its detect-and-name threshold (its ``threshold_ratio`` in the truth);
    the excitation, the sensor noise and the measurement noise come from the tier's own stream
    (``tier_seed``; the seeds used are kept under ``recording_seeds``, for the record only: the recording's
    metadata names the plant kind and the controller design's seed 0, as in tier 1); a baseline is the
    perturbed converged plant without the effects."""
    tier = case.get("tier", 1)
    rng = np.random.default_rng(case["rng_seed"])
    trng = np.random.default_rng(case["tier_seed"]) if tier == 2 else None
    st0 = nominal_state(case["structure"], case["controller"])
    test = TESTS[case["structure"]]
    settle = settling_time(st0, test.band_hz)
    period = 1.0 / RES_HZ
    n_periods = max(3, math.ceil(settle / period) + 2)
    dt = st0.chain.period_s
    n = int(round(n_periods * period / dt))
    force_seed = int(rng.integers(1 << 30))
    if tier == 2:  # the tier's own excitation realisation (tier 1's draw above keeps its stream in step)
        force_seed = int(trng.integers(1 << 30))
    force = pseudo_random(np.arange(n) * dt, band_hz=test.band_hz, resolution_hz=RES_HZ, rms_n=test.rms_n,
                          seed=force_seed)
    sig = _Signals(force, dt, test.band_hz)
    exc = st0.spec.instrumentation.excitation
    ctx = context_for(st0, test.band_hz, sig)
    ctx.closed_loop = st0.design is not None
    ctx.excitation_point = exc
    ctx.freq_hz, ctx.force_amplitude = sig.freq_hz, sig.force_amplitude
    meas = tuple(dict.fromkeys(test.measured_points + st0.actuators))
    plant = case.get("plant", "linear")
    real0, extra, accept, size_of = st0, {}, None, None
    noise_seed, noise_rng = case["index"], rng
    if tier == 2:
        spec_p, pert = draw_perturbation(trng, case["structure"])
        real0 = st0.with_spec(spec_p)  # the controller stays the one designed on the nominal model
        noise_seed, noise_rng = int(trng.integers(1, 1 << 30)), trng
        # the thresholds at the recordings' noise: the loop's sensor noise and the measurement noise (a
        # fraction of each channel's RMS; the largest channel's, which errs towards larger thresholds)
        v_rms = max(ctx.predicted_velocity_rms(st0, p) for p in meas)
        det_noise = float(math.hypot(st0.chain.noise_m_s, noise * v_rms))

        def accept(t: dict) -> bool:
            r = threshold_ratio(t, _thresholds(case["structure"], case["controller"], t["effect"], det_noise))
            t["threshold_ratio"] = r
            return r is None or r >= MIN_THRESHOLD_RATIO

        size_of = threshold_sizer(lambda effect: _thresholds(case["structure"], case["controller"], effect,
                                                            det_noise))
        extra = {"perturbation": pert, "threshold_noise_m_s": det_noise,
                 "recording_seeds": {"force": force_seed, "sensor_noise": noise_seed}}
    truth_state, truths, hidden = conceal(rng, case["families"], real0, ctx, sig.freq_hz, exc, meas, plant=plant,
                                          accept=accept, size_of=size_of)
    t0 = time.perf_counter()
    path = os.path.join(workdir, f"case{case['index']}.uff")
    # the baseline: the same test on the unmodified plant, excited by another record of the same spectrum
    # (other phases) and with other noise: nothing of the recording's realisation is shared
    if tier == 2:
        sim = _simulate_on_plant
        runs = [(truth_state, force, exc, meas, noise_seed, case["plant_options"])]
    else:
        sim = _simulate
        runs = [(truth_state, force, exc, meas, plant, case["index"])]
    if baseline:
        force_seed_b = int((rng if tier == 1 else trng).integers(1 << 30))
        force_b = pseudo_random(np.arange(n) * dt, band_hz=test.band_hz, resolution_hz=RES_HZ, rms_n=test.rms_n,
                                seed=force_seed_b)
        if tier == 2:  # the real structure without the effects: the perturbed converged plant
            seed_b = int(trng.integers(1, 1 << 30))
            runs.append((real0, force_b, exc, meas, seed_b, case["plant_options"]))
            extra["recording_seeds"].update({"baseline_force": force_seed_b, "baseline_sensor_noise": seed_b})
        else:
            runs.append((st0, force_b, exc, meas, plant, case["index"] + 10_000))
    if parallel and len(runs) > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(len(runs)) as ex:
            vels = list(ex.map(sim, *zip(*runs)))
    else:
        vels = [sim(*r) for r in runs]
    _record(vels[0], force, exc, meas, dt, noise, noise_rng, path, case)  # noise drawn in this order, as before
    base_path = None
    if baseline:
        base_path = os.path.join(workdir, f"case{case['index']}_baseline.uff")
        _record(vels[1], runs[1][1], exc, meas, dt, noise, noise_rng, base_path, case)
    t_gen = time.perf_counter() - t0
    rec = {**case, "truth": truths, "hidden": hidden, "n_periods": n_periods, "recording": path,
           "baseline": base_path, **extra}
    if not diagnose_it:
        with open(os.path.join(workdir, f"case{case['index']}.json"), "w") as fh:
            json.dump(rec, fh, indent=1)
        return {**rec, "time_generate_s": t_gen, "time_diagnose_s": 0.0, "result": None, "error": "not diagnosed"}
    return diagnose_case(rec, t_gen)


def diagnose_case(rec: dict, t_gen: float = 0.0) -> dict:
    """Diagnose one generated case blind (``rec``: the case with its ``recording`` and ``baseline`` paths, as
    ``case<i>.json`` of ``--keep`` holds it) and return it with the result, the error and the times."""
    t0 = time.perf_counter()
    try:
        # tier 2: as a user diagnoses a recording of the real structure (plant "auto": the default MuJoCo
        # plant, and the model's own uncertainty since no vlab plant is named)
        res = diagnose(rec["structure"], rec["recording"], controller=rec["controller"],
                       plant="auto" if rec.get("tier", 1) == 2 else rec.get("plant", "linear"),
                       baseline=rec["baseline"])
        d = res.as_dict()
        err = None
    except Exception as exc:  # a benchmark records failures instead of stopping
        d, err = None, f"{type(exc).__name__}: {exc}"
    return {**rec, "time_generate_s": t_gen, "time_diagnose_s": time.perf_counter() - t0, "result": d,
            "error": err}


#: Diagnosis time per case on a quiet two-core machine at most [s], per structure (the targets the timing
#: line prints beside the medians).
TIME_TARGET_S = {"bcc": 30.0, "grid": 120.0}


def _print_stage_times(results: list) -> None:
    """Print the diagnosis time per structure (median over the cases with an effect and over the null cases,
    with :data:`TIME_TARGET_S`) and each stage's median cost (``timing_s`` of diagnosis.json) over the cases
    that ran it."""
    done = [r for r in results if r.get("result")]
    for st in sorted({r["structure"] for r in done}):
        mine = [r for r in done if r["structure"] == st]
        eff = [r["time_diagnose_s"] for r in mine if r.get("truth")]
        null = [r["time_diagnose_s"] for r in mine if not r.get("truth")]
        parts = [f"{len(x)} {what} median {np.median(x):.0f} s" for x, what in ((eff, "with an effect"),
                                                                                  (null, "null")) if x]
        print(f"diagnosis time, {st}: " + ", ".join(parts) +
              (f" (target <= {TIME_TARGET_S[st]:g} s on a quiet two-core machine)" if st in TIME_TARGET_S else ""))
    stages: dict = {}
    for r in done:
        for k, v in (r["result"].get("timing_s") or {}).items():
            if k != "total" and isinstance(v, (int, float)):
                stages.setdefault(k, []).append(float(v))
    if stages:
        print("diagnosis stages, median s over the cases that ran them: " +
              ", ".join(f"{k} {np.median(v):.1f} ({len(v)})" for k, v in stages.items()))


def _located(loc: dict) -> dict:
    """A location in the nominal spec's terms: a member piece ``m[a-b]`` of a spec an earlier concealed effect
    split (a compound case's second draw, :func:`vlab.spec.changes.piece_id`) is segment ``[a, b]`` of member
    ``m``, as the diagnosis names it."""
    out = {k: (list(v) if isinstance(v, (list, tuple)) else v) for k, v in loc.items()}
    ends = piece_ends(str(out.get("member", ""))) if "segment" not in out else None
    if ends is not None:
        out.update(member=ends[0], segment=[ends[1], ends[2]])
    return out


def _same_location(a: dict, b: dict) -> bool:
    return _located(a) == _located(b)


def score(case: dict) -> dict:
    """Right effect and location, parameter errors, misfit ratios of one case; ``passengers``: the effects
    selected beside the true ones found (0 where none was found)."""
    d = case["result"]
    truths = case["truth"]
    out = {"right": False, "lookalike": False, "false_alarm": False, "param_errors": [], "misfit_ratio": None, "time_ratio": None,
           "noise_ratio": None, "refit_errors": [], "passengers": 0}
    if d is None:
        if len(truths) > 1:  # a compound that was not diagnosed is neither named nor its remainder stated
            out["compound"] = "neither"
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
    # a passenger: an effect selected beside a true one found (an effect selected instead is just wrong)
    found = [h for h in matched if h is not None]
    out["passengers"] = len(sel) - len(found) if found else 0
    if len(truths) > 1:  # a compound: named in full, or a part named (nothing else) with its remainder stated
        part = bool(found) and len(sel) == len(found) and d.get("remainder") is not None
        out["compound"] = "in full" if out["right"] else "remainder stated" if part else "neither"
    # the selection reported with look-alikes the data cannot tell from it (dBIC < 10, or predictions within the
    # one-parameter limit, vlab.diagnose.fit.separation): is the truth one?
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
    tier2 = ""
    if r.get("tier", 1) >= 2:
        ratios = ", ".join("n/a" if t.get("threshold_ratio") is None else f"{t['threshold_ratio']:.3g}x"
                           for t in r["truth"])
        tier2 = f" [threshold {ratios}" if ratios else ""
        if "perturbation" in r:  # tier 2
            shift = max(abs(x) for x in r["perturbation"]["frequency_shift_fe"])
            tier2 = (f"{tier2}; " if ratios else " [") + f"model-form shift up to {100 * shift:.2g} %]"
        elif ratios:
            tier2 += "]"
    return (f"case {r['index']:3d} {r['structure']:4s} {r['controller']:5s} truth {truth} -> {got}: "
            f"{'OK' if s['right'] else 'WRONG (the right one among its look-alikes)' if s['lookalike'] else 'WRONG'}"
            f" ({r['time_generate_s']:.0f} + {r['time_diagnose_s']:.0f} s)" + tier2
            + (" [an effect drawn below visibility]" if r.get("hidden") else "")
            + (f" [compound: {s['compound']}]" if s.get("compound", "in full") != "in full" else ""))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=12)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--noise", type=float, default=0.01, help="measurement noise, fraction of each channel's RMS")
    ap.add_argument("--json", type=str, default=None, help="write all cases and scores to this file")
    ap.add_argument("--only", type=int, nargs="*", default=None, help="run only these case indices")
    ap.add_argument("--tier", type=int, choices=(1, 2, 3), default=1,
                    help="1: recordings from the plant the diagnosis uses; 2: from the converged MuJoCo plant "
                         "of a spec perturbed within its model-form uncertainty (module notes); 3: from the "
                         "independent reference simulator in lab mode (5 kHz accelerations, 16 bit, no sidecar; "
                         "BCC only: the simulator has no grid; benchmarks/diagnose_tier3.py)")
    ap.add_argument("--plant", choices=("linear", "mujoco"), default=None,
                    help="plant that records the cases and reruns the validation (default linear; tier 2: mujoco)")
    ap.add_argument("--structures", nargs="+", choices=("bcc", "grid"), default=["bcc", "grid"])
    ap.add_argument("--null-every", type=int, default=None,
                    help="every K-th case without any effect (0: drawn with probability 1/4; default 0, "
                         f"tier 2: {TIER2_NULL_EVERY})")
    ap.add_argument("--closed-nulls", action="store_true",
                    help="record every null case in closed loop (MFDRF and LQDRF in turn)")
    ap.add_argument("--baseline", action="store_true",
                    help="also record the unmodified plant and pass it to the diagnosis as its baseline (tier 3: "
                         "another excitation realisation and noise)")
    ap.add_argument("--keep", type=str, default=None,
                    help="only generate: write the recordings and each case's truth (case<i>.json) to this folder")
    ap.add_argument("--kept", type=str, default=None,
                    help="diagnose and score the cases --keep left in this folder (all, or those of --only); "
                         "--tier 3: those --keep-recordings left, with that run's --seed and --cases")
    ap.add_argument("--keep-recordings", type=str, default=None,
                    help="--tier 3: keep each case's recording, truth and diagnosis in this folder")
    args = ap.parse_args(argv)
    print("\n".join(command_header("diagnose_benchmark.py", sys.argv[1:] if argv is None else list(argv))),
          flush=True)
    if args.kept and args.tier != 3:
        return _run_kept(args)
    if args.tier == 3:
        if args.structures != ["bcc"] and "--structures" in (argv if argv is not None else sys.argv):
            ap.error("--tier 3 records with the reference simulator, which models the BCC only: --structures bcc")
        from diagnose_tier3 import NULL_EVERY, run_tier3

        args.null_every = NULL_EVERY if args.null_every is None else args.null_every
        if not 1 <= args.null_every <= 3:
            ap.error(f"--tier 3 needs at least a third of null cases: --null-every 1, 2 or 3, got {args.null_every}")
        if args.kept and (args.keep_recordings or args.baseline):
            ap.error("--kept diagnoses recordings kept earlier: --keep-recordings and --baseline belong to the run "
                     "that records (a kept baseline is used where there is one)")
        results, wall = run_tier3(args.cases, args.seed, args.null_every, args.only, args.jobs, args.keep_recordings,
                                  args.baseline, kept=args.kept)
        return _summarise(results, wall, args.json)
    if args.tier == 2:
        if args.plant == "linear":
            ap.error("--tier 2 records on the converged MuJoCo plant and diagnoses with the default one: "
                     "use --plant mujoco (the default in tier 2)")
        args.plant = "mujoco"
        args.null_every = TIER2_NULL_EVERY if args.null_every is None else args.null_every
        if not 1 <= args.null_every <= 3:
            ap.error(f"--tier 2 needs at least a third of null cases: --null-every 1, 2 or 3, got {args.null_every}")
    args.plant = args.plant or "linear"
    args.null_every = args.null_every or 0
    cases = [make_case(i, args.seed, args.plant, tuple(args.structures), args.null_every, args.tier,
                       args.closed_nulls)
             for i in range(args.cases)]
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
    tier = max((r.get("tier", 1) for r in results), default=1)
    ratios = [t.get("threshold_ratio") for r in results for t in r["truth"]]
    ratios = [x for x in ratios if x is not None]
    summary = {
        "tier": tier, "right_count": sum(s["right"] for s in with_eff),
        "param_within_20pct_share": float(np.mean(np.array(perr) <= 0.20)) if perr else None,
        "threshold_ratio_min": float(min(ratios)) if ratios else None,
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
        "passengers": sum(s.get("passengers", 0) for s in with_eff),
        "compound_cases": sum("compound" in s for s in with_eff),
        "compound_in_full": sum(s.get("compound") == "in full" for s in with_eff),
        "compound_remainder_stated": sum(s.get("compound") == "remainder stated" for s in with_eff),
        "right_param20_count": sum(s["right"] and all(e <= 0.20 for e in s["param_errors"]) for s in with_eff),
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
          f"them apart: dBIC < 10 or predictions within the one-parameter chi-square limit): {100 * summary['right_or_lookalike_share']:.0f} %")
    if perr:
        print(f"parameter error: median {100 * summary['param_error_median']:.2f} %, max "
              f"{100 * summary['param_error_max']:.2f} %, within 15 %: {100 * summary['param_within_15pct_share']:.0f} %")
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
    if summary["compound_cases"]:
        print(f"compound cases: {summary['compound_cases']}; named in full {summary['compound_in_full']}, a part "
              f"named with the remainder stated {summary['compound_remainder_stated']} (target: every one either)")
    print(f"cases with an effect drawn below visibility ({100 * VISIBLE:g} % on every line, 8 tries): "
          f"{summary['hidden_effect_cases'] or 'none'}")
    print(f"time per case: diagnosis median {summary['diagnose_time_s_median']:.0f} s, max "
          f"{summary['diagnose_time_s_max']:.0f} s; with the recording's simulation max {summary['case_time_s_max']:.0f} s"
          + (" (simulation not timed: cases generated earlier, --kept)" if not any(tg) else ""))
    _print_stage_times(results)
    if summary["errors"]:
        print("errors:", summary["errors"])
    # one line: each tier's targets (right effect and location, false alarms, parameter error, time per case)
    pe = (f"median {100 * summary['param_error_median']:.2f} %, max {100 * summary['param_error_max']:.1f} %, "
          f"within 20 %: {100 * summary['param_within_20pct_share']:.0f} %" if perr else "none")
    thr = (f", effects at >= {summary['threshold_ratio_min']:.3g}x their "
           f"{'detect-and-name' if tier == 2 else 'detection'} threshold" if tier >= 2 and ratios else "")
    print(f"tier {tier}: right effect and location {summary['right_count']}/{summary['with_effect']} effect cases"
          f"{thr}; false alarms {summary['false_alarms']}/{summary['no_effect']} null cases; parameter error {pe}; "
          f"time per case median {np.median(np.array(td) + np.array(tg)):.0f} s (diagnosis "
          f"{summary['diagnose_time_s_median']:.0f} s)"
          + ("   (targets: >= 85 % right, 0 false alarms, parameters within 20 %)" if tier == 2 else ""))
    if tier == 3:
        print(f"tier 3: right effect and place with the parameter within 20 %: {summary['right_param20_count']}/"
              f"{summary['with_effect']} ({100 * summary['right_param20_count'] / max(summary['with_effect'], 1):.0f} "
              f"%; target >= 90 %); passengers {summary['passengers']} (target 0); false alarms "
              f"{summary['false_alarms']}/{summary['no_effect']} (target 0)")
    if json_path:
        with open(json_path, "w") as fh:
            json.dump({"summary": summary, "cases": results, "scores": scores}, fh, indent=1, default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
