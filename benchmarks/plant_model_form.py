"""The MuJoCo plant's own discretisation as data: the default plant against a converged one, mode by mode.

The lab's default MuJoCo plant (:func:`vlab.sim.build_plant` with the automatic
options: two to four Gauss hinges per member segment, the lab's 0.5 ms step)
is a discretisation of the structure; its error is one component of the
model-form uncertainty of the plant the diagnosis replays a recording on.
This script measures it against a *converged* plant built from
the same spec with about twice the links and a 25 us step
(:func:`converged_options`):

- links per segment: twice the default plant's links of every member (the
  largest over its segments, :attr:`vlab.sim.BuildInfo.links`, set for all of
  its segments through ``member_segments``) and of every crosspiece arm
  (``crosspiece_segments``);
- step: :data:`CONVERGED_STEP_S` = 25 us (20 steps per 0.5 ms lab sample);
- integrator ``"implicitfast"`` (:data:`CONVERGED_INTEGRATOR`): on the grid's
  forest topology the automatic choice (``"explicit"``) is unstable at 25 us
  (a one-step eigenvalue ``|lambda| = 1.15`` at the 20 kHz Nyquist frequency
  of the linearisation, with or without the doubled links), the implicit
  treatment of the joint damping is stable; on the BCC the automatic choice is
  already ``"implicitfast"``. Other options as the default plant's.

Both plants are settled and linearised with the existing tools
(:func:`vlab.sim.settle`, :func:`vlab.sim.linearize` with the applied modal
damping, :func:`vlab.sim.modes`); the modes are paired by MAC with
:func:`vlab.sim.pair_band` (one assignment maximising the total MAC, the
converged plant as the reference), the shapes taken at every structure point
(sites ``p<ID>``) and at the crosspiece arm tips (sites ``<id>.tipa``,
``<id>.tipb``: the arms' anti-symmetric mode does not move the beam). For every
converged mode up to the top of the structure's test band
(:func:`vlab.experiment.config.test_definition`: BCC 0.5-25 Hz, grid 0.2-10 Hz)
the JSON holds:

``frequency_default_hz``, ``frequency_converged_hz``, ``damping_default``, ``damping_converged``
    The natural frequency [Hz] and damping ratio [1] that each plant's
    *sampled* response shows: ``s = ln(lambda) / dt`` of the one-step
    eigenvalue ``lambda`` (``f = |s| / 2 pi``, ``zeta = -Re s / |s|``), the
    continuous system whose samples every step are the plant's. This is what a
    recording (or a replay) of the plant carries, so it includes the step's
    own frequency warping (``(omega dt)^2 / 24``, 0.02 % at 22.8 Hz and 0.5 ms)
    and the step's bias on the applied (explicit) modal damping
    (``omega dt zeta``); ``lambda`` is recovered exactly from the frequency
    and damping :func:`vlab.sim.modes` reports
    (:func:`vlab.sim.linearize.discrete_to_modal` inverted).
``frequency_rel``
    ``|ln(f_default / f_converged)|`` of the sampled frequencies [1].
``frequency_modal_default_hz``, ``frequency_modal_converged_hz``, ``frequency_rel_modal``, ``damping_modal_*``
    The same from the frequencies :func:`vlab.sim.modes` reports (the one-step
    map inverted for the continuous natural frequency of the hinge chain: no
    step bias) -- the discretisation of the hinge chain alone, the measure of
    the plant cross-check (:func:`vlab.sim.crosscheck`).
``mac``
    MAC of the pair at the compared sites [1].
``default_mode``, ``converged_mode``
    Mode numbers (1-based) in each plant. A converged mode without a default
    partner (MAC below 0.5) is listed apart (``unpaired_converged_modes``), so
    that every row of ``modes`` has all its numbers; so are default modes in
    the band without a converged partner (``unpaired_default_modes``).
``fe_mode``
    The FE model's mode (spec mesh, 1-based) paired with the converged
    plant's mode by the plant cross-check (:func:`vlab.sim.crosscheck`, MAC at
    the points); null for a plant mode the FE model does not have (the BCC
    crosspiece arms' anti-symmetric bending).
``above_band_modes``
    The converged plant's modes above the band paired with the default modes
    the band's pairing left, upward while every mode finds a partner of the
    same shape (:func:`_above_band`; ``frequency_*_hz``, ``frequency_rel``,
    ``mac``, mode numbers): above the band the discretisation grows; it is
    the uncertainty with which the diagnosis identifies an oscillation above
    the band with a mode.

The converged plant is not the limit itself: on the BCC a plant with twice
its links again at 12.5 us differs from it by at most 0.11 % (mode 7, 22.7 Hz;
measured once, not written), about a quarter of ``frequency_rel`` there, as
for an error falling with the square of the link length; the default plant's
error against the limit is then about ``4/3 frequency_rel``.

Output: ``assets/model_form/<structure>.json`` (written atomically; located
as :data:`vlab.spec.ASSETS_DIR` ``/ "model_form"``, next to ``assets/data``,
see :func:`model_form_path`), and a table on stdout.

Usage::

    python benchmarks/plant_model_form.py bcc|grid|all [--out DIR]

Used by: the model-form uncertainty of tier 2 of the diagnosis benchmark
(benchmarks/diagnose_benchmark.py --tier 2). Sources: docs/experiments.md (a
converged BCC plant: more hinges, 25 us step); MAC: Allemang & Brown (1982).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from vlab.fe import modal_analysis  # noqa: E402
from vlab.experiment.config import test_definition  # noqa: E402
from vlab.sim import (Plant, SimOptions, build_plant, crosscheck, fe_reference, linearize, modes,  # noqa: E402
                      pair_band, settle)
from vlab.sim.linearize import site_jacobian_w  # noqa: E402
from vlab.sim.pairing import mac_matrix  # noqa: E402
from vlab.spec import ASSETS_DIR, StructureSpec, load_spec  # noqa: E402

#: Step of the converged plant [s] (a divisor of the lab's 0.5 ms sample: 20 steps per sample).
CONVERGED_STEP_S = 25e-6
#: Links of the converged plant per link of the default plant (members and crosspiece arms).
LINK_FACTOR = 2
#: Integrator of the converged plant (the grid's automatic "explicit" is unstable at 25 us: module notes).
CONVERGED_INTEGRATOR = "implicitfast"
STRUCTURES = ("bcc", "grid")
#: Smallest MAC of two modes of the same shape above the band (Allemang, "The modal assurance criterion --
#: twenty years of use and abuse", Sound and Vibration 37 (2003) 14-23: above 0.9, consistent shapes).
SAME_SHAPE_MAC = 0.9


def model_form_path(structure: str) -> Path:
    """``assets/model_form/<structure>.json`` [path], found the way ``assets/data`` is (:data:`vlab.spec.ASSETS_DIR`)."""
    return ASSETS_DIR / "model_form" / f"{structure}.json"


def converged_option_kwargs(spec: StructureSpec, default: Plant | None = None) -> dict:
    """Keyword arguments of :class:`vlab.sim.SimOptions` of the converged plant of ``spec`` (JSON-ready).

    Parameters
    ----------
    spec : StructureSpec
    default : Plant, optional
        The default plant of ``spec`` (built when omitted): its links per segment are doubled.

    Returns
    -------
    dict
        ``member_segments`` (member id -> links per segment, ``LINK_FACTOR`` x the default's largest),
        ``crosspiece_segments`` (when the spec has crosspieces), ``timestep_s`` (:data:`CONVERGED_STEP_S`),
        ``integrator`` (:data:`CONVERGED_INTEGRATOR`).

    Raises
    ------
    SimulationError
        The default plant cannot be built.
    """
    plant = default if default is not None else build_plant(spec)
    links = plant.info.links
    out: dict = {"member_segments": {m.id: LINK_FACTOR * int(links[m.id]) for m in spec.members if m.id in links}}
    arms = [int(links[c.id]) for c in spec.crosspieces if c.id in links]
    if arms:
        out["crosspiece_segments"] = LINK_FACTOR * max(arms)
    out["timestep_s"] = CONVERGED_STEP_S
    out["integrator"] = CONVERGED_INTEGRATOR
    return out


def converged_options(spec: StructureSpec, default: Plant | None = None) -> SimOptions:
    """The converged plant's :class:`vlab.sim.SimOptions` (:func:`converged_option_kwargs`).

    Raises
    ------
    SimulationError
        The default plant cannot be built.
    """
    return SimOptions(**converged_option_kwargs(spec, default))


def sampled_modal(omega: np.ndarray, zeta: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequency [Hz] and damping ratio [1] of the sampled response, from what :func:`vlab.sim.modes` reports.

    :func:`vlab.sim.linearize.discrete_to_modal` maps the one-step eigenvalue ``lambda`` to ``(omega, zeta)``
    by ``|lambda|^2 = 1 / (1 + h c)``, ``2 Re lambda = 1 + |lambda|^2 - h^2 omega^2 |lambda|^2``
    (``c = 2 zeta omega``); inverted here, and ``s = ln(lambda) / h`` gives ``f = |s| / 2 pi``,
    ``zeta_s = -Re s / |s|``.

    Parameters
    ----------
    omega : ndarray, shape (n,)
        Natural circular frequencies [rad/s].
    zeta : ndarray, shape (n,)
        Damping ratios [1].
    dt : float
        Step [s].

    Returns
    -------
    (ndarray, ndarray), shapes (n,), (n,)
        Frequency [Hz] and damping ratio [1] of the sampled response.
    """
    omega, zeta = np.asarray(omega, dtype=float), np.asarray(zeta, dtype=float)
    rho = 1.0 / (1.0 + 2.0 * zeta * omega * dt)
    re = 0.5 * (1.0 + rho - omega**2 * dt**2 * rho)
    im = np.sqrt(np.clip(rho - re**2, 0.0, None))
    s = np.log(re + 1j * im) / dt
    return np.abs(s) / (2 * math.pi), -s.real / np.abs(s)


def _mac_sites(spec: StructureSpec) -> list[str]:
    """Sites of the MAC: every point's ``p<ID>`` and the crosspiece arm tips."""
    return [f"p{p}" for p in sorted(spec.points)] + [f"{c.id}.{arm}" for c in spec.crosspieces
                                                        for arm in ("tipa", "tipb")]


def plant_modes(plant: Plant, sites: list[str]) -> dict:
    """Modes of ``plant`` from its linearisation around the settled state.

    Returns
    -------
    dict
        ``modal_hz``, ``modal_zeta`` (:func:`vlab.sim.modes`), ``sampled_hz``, ``sampled_zeta``
        (:func:`sampled_modal`), all shape (n,); ``shapes`` (n_sites, n), ``w`` at ``sites`` of the
        mass-normalised joint shapes; ``seconds`` of the settling and linearisation.

    Raises
    ------
    SimulationError
        The plant does not settle or its linearisation is unstable.
    """
    t0 = time.perf_counter()
    data = settle(plant.model)
    sm = modes(plant.model, [int(s[1:]) for s in sites if s.startswith("p") and s[1:].isdigit()], data=data,
               linear=linearize(plant.model, data))
    shapes = site_jacobian_w(plant.model, data, sites) @ sm.joint_shapes
    f_s, z_s = sampled_modal(sm.omega, sm.damping_ratios, plant.timestep_s)
    return {"modal_hz": sm.frequencies_hz, "modal_zeta": sm.damping_ratios, "sampled_hz": f_s,
            "sampled_zeta": z_s, "shapes": shapes, "seconds": time.perf_counter() - t0}


def _plant_record(plant: Plant, kwargs: dict) -> dict:
    """The options of a built plant, JSON-ready: the :class:`SimOptions` keywords and what was built."""
    o = plant.options
    return {"sim_options": kwargs, "links_per_segment": {k: int(v) for k, v in plant.info.links.items()},
            "timestep_s": plant.timestep_s, "integrator": o.integrator, "topology": o.topology,
            "hinge_layout": o.hinge_layout, "torsion_hinges": o.torsion_hinges, "nv": int(plant.model.nv),
            "mass_scaled_joints": len(plant.info.armature), "stiffness_damping_s": o.stiffness_damping_s}


def compare(structure: str) -> dict:
    """The default and the converged plant of ``structure``, mode by mode in its test band (module notes).

    Parameters
    ----------
    structure : str
        ``"bcc"`` or ``"grid"`` (a built-in structure, :func:`vlab.spec.load_spec`).

    Returns
    -------
    dict
        The JSON record (module notes; keys carry units).

    Raises
    ------
    SimulationError
        A plant cannot be built, settled or linearised.
    SpecError
        Unknown structure.
    """
    spec = load_spec(structure)
    band = test_definition(spec).band_hz
    sites = _mac_sites(spec)
    p0 = build_plant(spec)
    m0 = plant_modes(p0, sites)
    kw = converged_option_kwargs(spec, p0)
    p1 = build_plant(spec, SimOptions(**kw))
    m1 = plant_modes(p1, sites)
    n_band = int(np.count_nonzero(m1["sampled_hz"] <= band[1]))
    # the FE model's mode of each converged plant mode (the plant cross-check's MAC pairing at the points)
    fe = fe_reference(spec)
    n_fe = int(np.count_nonzero(modal_analysis(fe.m, fe.k).frequencies_hz <= band[1]))
    fe_of = {q.sim_mode: q.fe_mode for q in crosscheck(p1, n_fe).pairs if q.sim_mode is not None}
    bp = pair_band(m1["modal_hz"], m1["shapes"], m0["modal_hz"], m0["shapes"], n_band)
    rows, unpaired_conv = [], []
    for r in range(n_band):
        j = bp.fe_to_sim[r]
        row = {"mode": r + 1, "converged_mode": r + 1, "default_mode": None if j is None else j + 1,
               "fe_mode": fe_of.get(r + 1),
               "frequency_converged_hz": float(m1["sampled_hz"][r]), "damping_converged": float(m1["sampled_zeta"][r]),
               "frequency_modal_converged_hz": float(m1["modal_hz"][r]),
               "damping_modal_converged": float(m1["modal_zeta"][r]), "mac": float(bp.macs[r])}
        if j is None:  # listed apart: every row of "modes" has all its numbers
            unpaired_conv.append({k: row[k] for k in ("converged_mode", "fe_mode", "frequency_converged_hz", "mac")})
            continue
        row.update({
            "frequency_default_hz": float(m0["sampled_hz"][j]),
            "frequency_rel": float(abs(math.log(m0["sampled_hz"][j] / m1["sampled_hz"][r]))),
            "damping_default": float(m0["sampled_zeta"][j]),
            "frequency_modal_default_hz": float(m0["modal_hz"][j]),
            "frequency_rel_modal": float(abs(math.log(m0["modal_hz"][j] / m1["modal_hz"][r]))),
            "damping_modal_default": float(m0["modal_zeta"][j])})
        rows.append(row)
    unpaired = [{"default_mode": u.sim_mode, "frequency_modal_default_hz": u.sim_hz, "reason": u.reason}
                for u in bp.unpaired if u.sim_hz <= band[1]]
    above = _above_band(m0, m1, n_band, {r["default_mode"] - 1 for r in rows})
    return {
        "structure": structure,
        "command": f"python benchmarks/plant_model_form.py {structure}",
        "description": "the default MuJoCo plant against a converged one (about twice the links per segment, "
                       f"{CONVERGED_STEP_S * 1e6:g} us step): natural frequencies and damping ratios of the "
                       "sampled response (s = ln(lambda)/dt of the one-step eigenvalue) and of vlab.sim.modes "
                       "(modal: the hinge chain's alone), modes paired by MAC (vlab.sim.pair_band)",
        "band_hz": [float(band[0]), float(band[1])],
        "mac_sites": sites,
        "mujoco_version": mujoco.__version__,
        "default_options": _plant_record(p0, {}),
        "converged_options": _plant_record(p1, kw),
        "modes": rows,
        "unpaired_default_modes": unpaired,
        "unpaired_converged_modes": unpaired_conv,
        "frequency_rel_max": max((r["frequency_rel"] for r in rows), default=None),
        "frequency_rel_modal_max": max((r["frequency_rel_modal"] for r in rows), default=None),
        "above_band_modes": above,
    }


def _above_band(m0: dict, m1: dict, n_band: int, taken: set) -> list[dict]:
    """The converged plant's modes above the test band paired with the default plant's modes left over by the
    band's pairing, from the band's top upward while every converged mode finds a partner (the module notes).

    Two modes pair when their shapes agree at the compared sites, MAC >= :data:`SAME_SHAPE_MAC`; among such
    pairs one assignment minimises the total ``|ln(f_default / f_converged)|``
    (:func:`scipy.optimize.linear_sum_assignment`). Shapes alone do not decide above the band: the BCC arms'
    anti-symmetric modes (8.6, 74, 234 Hz) all have the same shape at the arm tips. The list stops at the
    first converged mode without a partner: above it the sites no longer tell the modes apart, and the
    discretisation there is not measured. The band's pairs are kept out of the assignment. Rows as ``modes``
    without ``fe_mode`` and the modal columns."""
    from scipy.optimize import linear_sum_assignment

    top = float(m0["sampled_hz"].max())
    conv = [r for r in range(n_band, m1["sampled_hz"].size) if m1["sampled_hz"][r] <= top]
    free = [j for j in range(m0["sampled_hz"].size) if j not in taken]
    if not conv or not free:
        return []
    mac = mac_matrix(m1["shapes"][:, conv], m0["shapes"][:, free])
    dist = np.abs(np.log(m0["sampled_hz"][free][None, :] / m1["sampled_hz"][conv][:, None]))
    ok = mac >= SAME_SHAPE_MAC
    rows, cols = linear_sum_assignment(np.where(ok, dist, 1e6))
    partner = {int(a): int(b) for a, b in zip(rows, cols) if ok[a, b]}
    out = []
    for a, r in enumerate(conv):
        if a not in partner:
            break
        j = free[partner[a]]
        out.append({"converged_mode": r + 1, "default_mode": j + 1,
                    "frequency_converged_hz": float(m1["sampled_hz"][r]),
                    "frequency_default_hz": float(m0["sampled_hz"][j]),
                    "frequency_rel": float(dist[a, partner[a]]), "mac": float(mac[a, partner[a]])})
    return out


def write_atomic(path: Path, record: dict) -> None:
    """Write ``record`` as JSON to ``path`` atomically (a temporary file in the same folder, then renamed)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; the data file is read by everyone
        with os.fdopen(fd, "w") as fh:
            json.dump(record, fh, indent=1)
            fh.write("\n")
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _fe(row: dict) -> str:
    return f"{row['fe_mode']:2d}" if row["fe_mode"] is not None else " -"


def table(rec: dict) -> str:
    """The record as a plain-text table."""
    d, c = rec["default_options"], rec["converged_options"]
    lines = [f"{rec['structure']}: default plant (links {d['links_per_segment']}, {d['timestep_s'] * 1e3:g} ms, "
             f"{d['integrator']}, nv {d['nv']}) vs converged (links {c['links_per_segment']}, "
             f"{c['timestep_s'] * 1e6:g} us, {c['integrator']}, nv {c['nv']}); band {rec['band_hz']} Hz",
             " mode FE  conv [Hz]  default [Hz]  rel [%]  modal rel [%]  zeta conv  zeta def     MAC"]
    for r in rec["modes"]:
        lines.append(f"{r['mode']:5d} {_fe(r)} {r['frequency_converged_hz']:10.4f} {r['frequency_default_hz']:13.4f} "
                     f"{100 * r['frequency_rel']:8.3f} {100 * r['frequency_rel_modal']:14.3f} "
                     f"{r['damping_converged']:10.5f} {r['damping_default']:9.5f} {r['mac']:7.4f}")
    for u in rec["unpaired_converged_modes"]:
        lines.append(f"  converged mode {u['converged_mode']} ({u['frequency_converged_hz']:.4f} Hz) unpaired "
                     f"(best MAC {u['mac']:.3f})")
    for u in rec["unpaired_default_modes"]:
        lines.append(f"  default mode {u['default_mode']} ({u['frequency_modal_default_hz']:.4f} Hz) unpaired: "
                     f"{u['reason']}")
    if rec.get("above_band_modes"):
        lines.append(" above the band:")
        for r in rec["above_band_modes"]:
            lines.append(f"{r['converged_mode']:5d}    {r['frequency_converged_hz']:10.4f} {r['frequency_default_hz']:13.4f} "
                         f"{100 * r['frequency_rel']:8.3f} {'':42s}{r['mac']:7.4f}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("structure", choices=STRUCTURES + ("all",))
    ap.add_argument("--out", default=None, help="folder to write <structure>.json to (default assets/model_form)")
    a = ap.parse_args(argv)
    for s in STRUCTURES if a.structure == "all" else (a.structure,):
        t0 = time.perf_counter()
        rec = compare(s)
        path = Path(a.out) / f"{s}.json" if a.out else model_form_path(s)
        write_atomic(path, rec)
        print(table(rec))
        print(f"written {path} ({time.perf_counter() - t0:.1f} s)\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
