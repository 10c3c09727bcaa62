"""Model updating: the structure file with the physics a diagnosis found, written as ordinary entries.

A diagnosis (``vlab diagnose``, its ``diagnosis.json``) names and fits the physics the model lacks. Here its
selected effects become entries of the structure file: the original text is kept as written (comments
included) and the entries are appended, each commented and with the source
``"vlab diagnose <recording>: fitted, 95 % interval [lo, hi] <unit>"``:

============================  ==============================================================
effect (location)             entry appended
============================  ==============================================================
``added_mass`` (point[s])     ``[[masses]]`` at each point, ``added = true``
``support_stiffness``         ``[[springs]]`` at each point, ``added = true``; ``replaces_support =
                              true`` where a support fixed that DOF (a support of finite stiffness)
``joint_flexibility``         ``[[joint_flexibility]]`` (:mod:`vlab.spec.changes`)
``member_stiffness``          ``[[member_stiffness]]`` (the member, or one segment)
``damping`` (mode)            ``[[mode_damping]]``
``actuator_gain`` (channel)   ``[[hardware.actuator_gain]]``: the coil's force per command (in the plant:
                              the FE input matrix and the MuJoCo coil's ``gainprm``)
``sensor_gain`` (channel)     ``[[hardware.sensor_gain]]`` (the hardware chain)
``loop_delay`` (channel)      ``[[hardware.loop_delay]]``, the delay [s] (the hardware chain)
``actuator_lag``,             ``[[hardware.actuator_lag]]``, ``[[hardware.sensor_lag]]``, the corner [Hz]
``sensor_lag`` (channel)      (the hardware chain)
============================  ==============================================================

The ``[hardware]`` entries (:mod:`vlab.spec.hardware`) combine as the diagnosis applied its effects: a gain
multiplies the file's own gain of that channel, a delay or a corner replaces it.

The written file is read back (:func:`vlab.spec.spec_from_dict`) and checked against the structure the
diagnosis itself evaluated (the original changed by :mod:`vlab.diagnose.effects.specedit`): the same
natural frequencies and damping matrix (relative difference below :data:`CHECK_RTOL`), and the same
per-channel hardware settings (:func:`check_hardware`). A physical change
keeps the damping matrix of the structure before it, in the file as in the diagnosis
(:mod:`vlab.spec.changes`).

Refused, with the reason: a diagnosis with nothing selected, one whose best effect is outside the library
(``outside_library``), one made for another structure (its ``structure_sha256``,
:func:`vlab.spec.structure_identity`), and effects a structure file cannot express (damping at a point,
friction, gravity pre-stress, an amplifier's saturation: they belong to the lab's settings, not to the
structure file).

:func:`verify` closes the loop: the controller designed on the original and on the updated structure, each
run on the same plant and compared with its own prediction as in Table 10 (average peak level error) and
Sec. 5.4 (closed-loop damping ratios predicted and measured).
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import DataFileError, ModelError, SpecError
from .lab.blocks import PC1000_DELAY_PERIODS
from .spec import StructureSpec, load_spec, spec_from_dict, structure_identity

#: Relative difference of the natural frequencies allowed between the written file and the diagnosis's own
#: edit of the structure (the written values carry 7 significant digits).
CHECK_RTOL = 1e-5

#: Significant digits of a written value.
DIGITS = 7

#: Effects a structure file can hold, with the unit of their parameter.
WRITABLE = {"added_mass": "kg", "support_stiffness": None, "joint_flexibility": "N*m/rad",
            "member_stiffness": "N*m^2", "damping": "1", "actuator_gain": "1", "sensor_gain": "1",
            "loop_delay": "s", "actuator_lag": "Hz", "sensor_lag": "Hz"}

#: The effects written into the structure file's ``[hardware]`` table (:mod:`vlab.spec.hardware`).
CHAIN_EFFECTS = ("actuator_gain", "sensor_gain", "loop_delay", "actuator_lag", "sensor_lag")


@dataclass(frozen=True)
class UpdateResult:
    """A structure file updated with a diagnosis.

    Attributes
    ----------
    spec : StructureSpec
        The updated structure, as read back from ``text``.
    text : str
        The structure file: the original text and the appended entries.
    entries : tuple of dict
        One per written entry: ``effect``, ``location``, ``parameters`` (name with its unit -> SI value, as
        in ``diagnosis.json``), ``ci95`` (name -> [lo, hi]), ``unit`` (the unit written into the file),
        ``table`` (the TOML table appended to).
    recording : str
        Name of the recording the diagnosis analysed.
    path : Path or None
        Where ``text`` was written (None: not written).
    frequencies_hz : dict
        ``original`` and ``updated``: natural frequencies [Hz] of the first modes of the FE models.
    """

    spec: StructureSpec
    text: str
    entries: tuple
    recording: str
    path: Path | None = None
    frequencies_hz: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        """The JSON object of ``vlab update --json``: ``structure``, ``recording``, ``out``, ``entries``,
        ``frequencies_original_hz``, ``frequencies_updated_hz``."""
        return {"structure": self.spec.name, "recording": self.recording,
                "out": None if self.path is None else str(self.path), "entries": list(self.entries),
                "frequencies_original_hz": list(self.frequencies_hz.get("original", [])),
                "frequencies_updated_hz": list(self.frequencies_hz.get("updated", []))}


def read_diagnosis(path: str | Path) -> tuple[dict, Path]:
    """The diagnosis object of ``path``: a ``vlab diagnose`` output folder or its ``diagnosis.json``.

    Returns
    -------
    (dict, Path)
        The parsed JSON and the file it came from.

    Raises
    ------
    DataFileError
        No such file, not JSON, or not a diagnosis (no ``selected`` list).
    """
    p = Path(path)
    f = p / "diagnosis.json" if p.is_dir() else p
    if not f.is_file():
        raise DataFileError(f"--diagnosis {path}: no diagnosis.json there (give the folder `vlab diagnose --out` "
                            "wrote, or its diagnosis.json)")
    try:
        d = json.loads(f.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DataFileError(f"{f}: not a JSON file ({exc})") from None
    if not isinstance(d, dict) or not isinstance(d.get("selected"), list):
        raise DataFileError(f"{f}: not a vlab diagnosis (no 'selected' list)")
    return d, f


def check_diagnosis(d: dict, spec: StructureSpec, file: Path | str) -> list[dict]:
    """The selected effects of diagnosis ``d``, refused when they cannot update ``spec``.

    Parameters
    ----------
    d : dict
        The ``diagnosis.json`` object (:meth:`vlab.diagnose.report.result.DiagnosisResult.as_dict`).
    spec : StructureSpec
        The structure to update.
    file : Path or str
        The diagnosis file, named in errors.

    Returns
    -------
    list of dict
        The ``selected`` entries (``effect``, ``location``, ``parameters``, ``ci95``).

    Raises
    ------
    DataFileError
        A diagnosis made for another structure (its ``structure_sha256``, or without one its ``structure``
        name, differs), with the best effect outside the library, or with nothing selected (the message
        says why: no mismatch, too small to name).
    ModelError
        A selected effect that a structure file cannot express.
    """
    ident = d.get("structure_sha256")
    if ident is not None and ident != structure_identity(spec):
        raise DataFileError(f"{file}: made for another structure ({d.get('structure')!r}, identity {ident[:12]}...) "
                            f"than {spec._file()} (identity {structure_identity(spec)[:12]}...): diagnose "
                            "this structure file, or update the file that was diagnosed")
    if ident is None and d.get("structure") != spec.name:
        raise DataFileError(f"{file}: made for the structure {d.get('structure')!r}, not {spec.name!r}")
    if d.get("outside_library"):
        raise DataFileError(f"{file}: the mismatch is outside vlab's library of effects (outside_library): no "
                            "fitted effect explains it, so there is nothing to write into the structure")
    sel = d["selected"]
    if not sel:
        why = ("no mismatch was found" if not d.get("mismatch") else
               "the change is too small to name" if d.get("too_small_to_name") else "no effect was selected")
        raise DataFileError(f"{file}: nothing selected ({why}): there is nothing to write into the structure")
    for e in sel:
        eff, loc = e.get("effect"), e.get("location") or {}
        if eff not in WRITABLE or (eff == "damping" and "mode" not in loc) or (eff in CHAIN_EFFECTS
                                                                              and "channel" not in loc):
            where = ", ".join(f"{k} {v}" for k, v in loc.items())
            raise ModelError(f"{file}: the selected effect {eff} ({where}) cannot be written into a structure file: "
                             f"a structure file holds {', '.join(sorted(WRITABLE))} (damping of a mode; the "
                             "chain's effects of a channel or of all); an amplifier's saturation is an option "
                             "of the lab, not of the structure")
    return sel


def _num(x: float) -> str:
    """``x`` as a TOML float with :data:`DIGITS` significant digits."""
    v = float(f"{x:.{DIGITS}g}")
    if not math.isfinite(v):
        raise ModelError(f"cannot write the non-finite value {x!r}")
    return repr(v)


def _source(recording: str, lo: float, hi: float, unit: str) -> str:
    u = "" if unit == "1" else f" {unit}"
    return f"vlab diagnose {recording}: fitted, 95 % interval [{lo:.4g}, {hi:.4g}]{u}"


def _q(value: float, unit: str, source: str) -> str:
    return f'{{ value = {_num(value)}, unit = "{unit}", source = "{source}" }}'


def _one_param(e: dict) -> tuple[str, float, list[float]]:
    ((name, value),) = e["parameters"].items()
    lo, hi = e.get("ci95", {}).get(name, [float("nan"), float("nan")])
    return name, float(value), [float(lo), float(hi)]


def _points(loc: dict) -> list[int]:
    return [int(loc["point"])] if loc.get("point") is not None else [int(p) for p in loc["points"]]


def _blocks(spec: StructureSpec, e: dict, recording: str) -> list[tuple[str, str, dict]]:
    """The entries of one selected effect: ``(table, TOML text, entry dict)``."""
    eff, loc = e["effect"], e["location"]
    name, x, ci = _one_param(e)
    unit = WRITABLE[eff] or ("N/m" if loc.get("dof", "w") == "w" else "N*m/rad")
    src = _source(recording, ci[0], ci[1], unit)
    info = {"effect": eff, "location": loc, "parameters": {name: x}, "ci95": {name: ci}, "unit": unit}
    out = []
    if eff == "added_mass":
        ids = {m.id for m in spec.masses}
        for p in _points(loc):
            ident = _fresh(ids, f"added_mass_{p}")
            out.append(("masses", f'[[masses]]\nid = "{ident}"\npoint = {p}\nadded = true\n'
                        f'mass = {_q(x, unit, src)}\n', info))
    elif eff == "support_stiffness":
        dof, ids = loc.get("dof", "w"), {s.id for s in spec.springs}
        for p in _points(loc):
            ident = _fresh(ids, f"support_stiffness_{p}_{dof}")
            fixed = any(s.point == p and dof in s.fixed for s in spec.supports)
            out.append(("springs", f'[[springs]]\nid = "{ident}"\npoint = {p}\ndof = "{dof}"\nadded = true\n'
                        f'stiffness = {_q(x, unit, src)}\n' + ("replaces_support = true\n" if fixed else ""), info))
    elif eff == "joint_flexibility":
        out.append(("joint_flexibility", f'[[joint_flexibility]]\npoint = {int(loc["point"])}\n'
                    f'rotational_stiffness = {_q(x, unit, src)}\n', info))
    elif eff == "member_stiffness":
        seg = f'segment = [{", ".join(str(int(p)) for p in loc["segment"])}]\n' if loc.get("segment") else ""
        out.append(("member_stiffness", f'[[member_stiffness]]\nmember = "{loc["member"]}"\n{seg}'
                    f'ei = {_q(x, unit, src)}\n', info))
    elif eff in CHAIN_EFFECTS:
        out.append(_hardware_block(eff, loc, x, unit, src, info))
    else:  # damping of a mode
        out.append(("mode_damping", f'[[mode_damping]]\nmode = {int(loc["mode"])}\nratio = {_num(x)}\n'
                    f'source = "{src}"\n', info))
    return out


def _hardware_block(eff: str, loc: dict, x: float, unit: str, src: str, info: dict) -> tuple[str, str, dict]:
    """The ``[[hardware.<effect>]]`` entry of one chain effect (:mod:`vlab.spec.hardware`)."""
    ch = loc["channel"]
    channel = '"all"' if ch == "all" else str(int(ch))
    head = f'[[hardware.{eff}]]\nchannel = {channel}\n'
    if eff.endswith("gain"):
        body = f'gain = {_num(x)}\nsource = "{src}"\n'
    else:
        body = f'{"delay" if eff == "loop_delay" else "corner"} = {_q(x, unit, src)}\n'
    return f"hardware.{eff}", head + body, info


def _fresh(ids: set, base: str) -> str:
    name, i = base, 1
    while name in ids:
        i += 1
        name = f"{base}_{i}"
    ids.add(name)
    return name


def _comment(e: dict, recording: str) -> str:
    name, x, ci = _one_param(e)
    where = ", ".join(f"{k} {v}" for k, v in e["location"].items())
    fe = (e.get("fe_fit") or {}).get(name)
    refit = "" if fe is None else f" (refitted on the MuJoCo plant; the FE model's fit: {fe:.6g})"
    plant = (e.get("plant_fit") or {}).get(name)
    if plant is not None:
        refit = f" (fitted on the structure's own model; fitted through the MuJoCo plant's replay: {plant:.6g})"
    return f"# {e['effect']} ({where}): {name} = {x:.6g}, 95 % interval [{ci[0]:.4g}, {ci[1]:.4g}]{refit}\n"


def updated_text(original: str, spec: StructureSpec, selected: list[dict], recording: str,
                 look_alikes=()) -> tuple[str, list]:
    """The structure file ``original`` with the selected effects appended as commented entries.

    Parameters
    ----------
    original : str
        The structure file's text, kept as written.
    spec : StructureSpec
        The structure it defines (ids already used).
    selected : list of dict
        ``diagnosis.json``'s ``selected`` entries (:func:`check_diagnosis`).
    recording : str
        Name of the diagnosed recording (in every entry's source).
    look_alikes : sequence of str
        The diagnosis's ``alternatives``: effects the data could not tell from the selection, named in a
        comment (the entries are the selection's; a user who knows the structure may choose another).

    Returns
    -------
    (str, list of dict)
        The new text, and one dict per written entry (:attr:`UpdateResult.entries`).
    """
    head = (f"\n\n# ---- added by `vlab update` from the diagnosis of {recording} (vlab diagnose) ----\n"
            "# Each entry below is physics the diagnosis found missing from the model above, at its fitted value.\n")
    if look_alikes:
        head += ("# The data could not tell it from: " + "; ".join(look_alikes)
                 + " (look-alikes: they fit these data as well; see the diagnosis).\n")
    parts, entries = [head], []
    for e in selected:
        parts.append("\n" + _comment(e, recording))
        for i, (table, text, info) in enumerate(_blocks(spec, e, recording)):
            parts.append(("" if i == 0 else "\n") + text)
            entries.append({**info, "table": table})
    return original.rstrip("\n") + "".join(parts), entries


def intended_spec(spec: StructureSpec, selected: list[dict]) -> StructureSpec:
    """``spec`` changed by the selected effects as the diagnosis evaluated them
    (:mod:`vlab.diagnose.effects.specedit`): the reference the written file is checked against.

    Raises
    ------
    SpecError
        A location the structure does not have.
    """
    from .diagnose.effects import specedit

    out = spec
    for e in selected:
        eff, loc = e["effect"], e["location"]
        _, x, _ = _one_param(e)
        if eff == "added_mass":
            for p in _points(loc):
                out = specedit.add_mass(out, p, x)
        elif eff == "support_stiffness":
            for p in _points(loc):
                out = specedit.add_spring(out, p, loc.get("dof", "w"), x)
        elif eff == "joint_flexibility":
            out = specedit.soften_joint(out, int(loc["point"]), x)
        elif eff in CHAIN_EFFECTS:
            continue  # the structure is unchanged: intended_hardware
        elif eff == "member_stiffness":
            segs = ([tuple(loc["segment"])] if loc.get("segment")
                    else specedit.member_segment_points(out, loc["member"]))
            ei0 = spec.sections[next(m.section for m in spec.members if m.id == loc["member"])].ei.si
            out = specedit.scale_segments(out, {s: x / ei0 for s in segs})
        else:
            out = specedit.set_modal_damping(out, int(loc["mode"]), x)
    return out


def check_hardware(written: StructureSpec, original: StructureSpec, selected: list[dict], file: str) -> None:
    """Compare the ``[hardware]`` settings read back from the written file with the original's changed by the
    selected chain effects as the diagnosis applied them (:func:`vlab.spec.hardware.with_entries`: a gain
    multiplies the channel's gain, a delay or a lag's corner replaces it; ``"all"``: every channel).

    Parameters
    ----------
    written, original : StructureSpec
        Read back from the written text; the structure before the update.
    selected : list of dict
        ``diagnosis.json``'s ``selected`` entries.
    file : str
        Named in errors.

    Raises
    ------
    ModelError
        A setting that differs by more than :data:`CHECK_RTOL` (relative), naming ``file`` and the setting.
    """
    from .spec.hardware import Hardware, SETTING_ATTRIBUTES, with_entries

    acts = tuple(original.instrumentation.actuators) if original.instrumentation else ()
    want = with_entries(original.hardware, acts, [(e["effect"], e["location"]["channel"], _one_param(e)[1])
                                                  for e in selected if e["effect"] in CHAIN_EFFECTS])
    hw = written.hardware or Hardware()
    for name in SETTING_ATTRIBUTES.values():
        got, exp = getattr(hw, name), getattr(want, name)
        if set(got) != set(exp) or any(abs(got[p] - v) > CHECK_RTOL * abs(v) for p, v in exp.items()):
            raise ModelError(f"{file}: the written [hardware] {name} {got} differs from the diagnosis's {exp}")


def _frequencies_hz(spec: StructureSpec, n: int) -> np.ndarray:
    """The first ``n`` natural frequencies [Hz] of the FE model of ``spec``, shape (<= n,)."""
    from .fe import build_fe_model
    from .fe.modal import modal_analysis

    fe = build_fe_model(spec)
    return np.asarray(modal_analysis(fe.m, fe.k, n_modes=min(n, fe.m.shape[0])).frequencies_hz, dtype=float)


def check_written(written: StructureSpec, intended: StructureSpec, file: str, n_modes: int = 8) -> dict:
    """Compare the structure read back from the written file with the diagnosis's own edit.

    Compared: the first ``n_modes`` natural frequencies and the damping matrices (:func:`vlab.fe.damping.
    structural_damping`, relative to the largest entry) of the two FE models, within :data:`CHECK_RTOL`.

    Parameters
    ----------
    written : StructureSpec
        Read back from the written text.
    intended : StructureSpec
        The diagnosis's own edit (:func:`intended_spec`).
    file : str
        Named in errors.
    n_modes : int
        Modes compared.

    Returns
    -------
    dict
        ``updated``: the written structure's first ``n_modes`` natural frequencies [Hz].

    Raises
    ------
    ModelError
        Frequencies or damping matrices that differ (names ``file``): the written entries do not hold what
        the diagnosis found.
    """
    from .fe import build_fe_model
    from .fe.damping import structural_damping

    fw, fi = _frequencies_hz(written, n_modes), _frequencies_hz(intended, n_modes)
    if fw.shape != fi.shape or not np.all(np.abs(fw / fi - 1) < CHECK_RTOL):
        raise ModelError(f"{file}: the written structure's frequencies {np.round(fw, 5).tolist()} Hz differ from "
                         f"the diagnosis's {np.round(fi, 5).tolist()} Hz")
    cw, ci = structural_damping(build_fe_model(written)), structural_damping(build_fe_model(intended))
    scale = max(float(np.max(np.abs(ci))), 1e-300)
    if cw.shape != ci.shape or float(np.max(np.abs(cw - ci))) > CHECK_RTOL * scale:
        raise ModelError(f"{file}: the written structure's damping differs from the diagnosis's (modal ratios "
                         f"{list(written.damping.modal_ratios) if written.damping else None} vs "
                         f"{list(intended.damping.modal_ratios) if intended.damping else None})")
    return {"updated": fw.tolist()}


def update(structure: str | Path | StructureSpec, diagnosis: str | Path, *, out: str | Path | None = None,
           overwrite: bool = False) -> UpdateResult:
    """Write the structure file ``structure`` updated with what ``diagnosis`` found (``vlab update``).

    Parameters
    ----------
    structure : str, Path or StructureSpec
        The diagnosed structure: a shipped name, a ``.toml`` path or a spec loaded from one (its file's text
        is kept as written).
    diagnosis : str or Path
        The folder ``vlab diagnose --out`` wrote, or its ``diagnosis.json``.
    out : str or Path, optional
        The updated structure file to write (atomically; never over an existing file without
        ``overwrite``). None: nothing written.
    overwrite : bool
        Replace an existing ``out``.

    Returns
    -------
    UpdateResult
        The updated spec as read back from the text, the text, the entries written.

    Raises
    ------
    DataFileError
        A missing or unreadable diagnosis; one refused by :func:`check_diagnosis`.
    ModelError
        An effect a structure file cannot express; a written file that does not hold what the diagnosis
        found (:func:`check_written`).
    SpecError
        A structure without a file, or a location it does not have.
    OutputError
        ``out`` exists without ``overwrite``, or cannot be written.
    """
    from .io.atomic import atomic_file, check_output_file

    spec = structure if isinstance(structure, StructureSpec) else load_spec(structure)
    if spec.path is None:
        raise SpecError(f"structure {spec.name!r}: built in code, it has no file to update; give a .toml file")
    target = None if out is None else check_output_file(out, overwrite=overwrite, option="--out", suffix=".toml")
    d, file = read_diagnosis(diagnosis)
    selected = check_diagnosis(d, spec, file)
    src = Path(str((d.get("data") or {}).get("source") or "recording"))
    recording = f"{src.parent.name}/{src.name}" if src.parent.name else src.name  # e.g. mass6/recording.uff
    text, entries = updated_text(spec.path.read_text(encoding="utf-8"), spec, selected, recording,
                                 [str(a) for a in d.get("alternatives") or []])
    where = str(target or "the updated structure")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"{spec._file()}: the entries cannot be appended to this file ({exc}): write them by "
                         "hand from `vlab update --json`") from None
    written = spec_from_dict(doc, path=target.absolute() if target is not None else spec.path)
    freqs = check_written(written, intended_spec(spec, selected), where)
    check_hardware(written, spec, selected, where)
    freqs["original"] = _frequencies_hz(spec, len(freqs["updated"])).tolist()
    if target is not None:
        with atomic_file(target, overwrite=overwrite) as tmp:
            Path(tmp).write_text(text, encoding="utf-8")
    return UpdateResult(written, text, tuple(entries), recording, target, freqs)


def verify(original: str | Path | StructureSpec, updated: str | Path | StructureSpec, mjcf: str | Path, *,
           controller: str = "mfdrf", seed: int = 0, duration_s: float | None = None,
           delay_periods: float = PC1000_DELAY_PERIODS, noise_m_s: float = 1e-6, progress=None,
           lab_chain=None) -> dict:
    """Design on the original and on the updated structure, run both against the same plant, compare.

    Each design is predicted with its own model's analysis (the sampled-data loop, with its file's
    ``[hardware]`` settings) and run on the MJCF plant ``mjcf`` with the same excitation and seed; the chain
    of each run is the thesis chain with its file's settings, or ``lab_chain`` (a chain effect concealed
    from both models) where it sets its own; the comparison is Table 10's:
    the average peak level error ``mean |1 - r|`` (``r`` the analytical / experimental peak level ratio)
    and the closed-loop damping ratios predicted and measured.

    Parameters
    ----------
    original, updated : str, Path or StructureSpec
        The structure before and after ``vlab update`` (they must share points, coils and sensors with the
        plant: :func:`vlab.sim.contract.check_plant_contract`).
    mjcf : str or Path
        The plant both designs run on (e.g. the changed structure exported with ``vlab export-mjcf``).
    controller : {"mfdrf", "lqdrf", "lqdrf-diag", "lqg"}
        The controller designed on each model.
    seed : int
        Seed of the excitation, noise and design.
    duration_s : float, optional
        Run length [s]; None: the structure's default.
    delay_periods : float
        Computation delay [sampling periods] (Sec. 5.3).
    noise_m_s : float
        Velocity-sensor noise standard deviation [m/s].
    progress : callable, optional
        ``progress(label, fraction)`` during each run.
    lab_chain : HardwareChain, optional
        The chain both runs really have, where it differs from what the models know (an effect of the chain
        concealed from them; :func:`vlab.experiment.runner.run_experiment`). None: the chain of each
        model (the thesis chain with its structure file's ``[hardware]`` settings).

    Returns
    -------
    dict
        ``plant``, ``controller``, and for ``original`` and ``updated``: ``structure_file``,
        ``average_peak_level_error`` [1], ``modes`` (``mode``, ``frequency_predicted_hz``,
        ``frequency_measured_hz``, ``damping_ratio_predicted``, ``damping_ratio_measured``,
        ``peak_level_ratio``), ``damping_ratio_largest_relative_difference`` [1] (``|measured / predicted
        - 1|`` over the modes), ``warnings``, ``not_meaningful`` (those of the warnings that make the run's
        FRF comparison not meaningful, :func:`vlab.experiment.checks.not_meaningful`: a self-excited oscillation
        or limit cycle, whose response is not the loop's linear response -- the errors above then do not test
        the prediction).

    Raises
    ------
    ModelError
        An unknown controller or open loop (``"none"``: nothing is designed); a plant that does not share
        the structure's coils and sensors.
    SimulationError, MeasurementError
        As :func:`vlab.experiment.runner.run_experiment`.
    """
    from .fe import build_fe_model
    from .experiment.checks import not_meaningful
    from .experiment.config import ExperimentConfig, default_chain
    from .diagnose.instability_cause import oscillation_cause
    from .experiment.runner import run_experiment
    from .models import check_fe_model

    if controller in ("none", "lqr"):
        raise ModelError(f"verify: controller {controller!r} designs nothing to compare; use mfdrf, lqdrf, "
                         "lqdrf-diag or lqg")
    out: dict[str, Any] = {"plant": str(mjcf), "controller": controller}
    for label, s in (("original", original), ("updated", updated)):
        spec = s if isinstance(s, StructureSpec) else load_spec(s)
        cfg = ExperimentConfig(structure=spec.name, controller=controller, duration_s=duration_s, seed=seed,
                               chain=default_chain(controller, delay_periods=delay_periods, noise_m_s=noise_m_s),
                               plant="mujoco", mjcf=Path(mjcf))
        cb = None if progress is None else (lambda x, label=label: progress(label, x))
        r = run_experiment(cfg, check_fe_model(build_fe_model(spec)), progress=cb, lab_chain=lab_chain,
                           explain_oscillation=oscillation_cause)
        out[label] = {
            "structure_file": None if spec.path is None else str(spec.path),
            "average_peak_level_error": float(r.avg_peak_error),
            "modes": [{"mode": m.mode, "frequency_predicted_hz": m.frequency_predicted_hz,
                       "frequency_measured_hz": m.frequency_measured_hz,
                       "damping_ratio_predicted": m.damping_predicted, "damping_ratio_measured": m.damping_measured,
                       "peak_level_ratio": float(m.peak_level_ratio)} for m in r.modes],
            "warnings": list(r.warnings), "not_meaningful": not_meaningful(r.warnings)}
        dev = [abs(m["damping_ratio_measured"] / m["damping_ratio_predicted"] - 1) for m in out[label]["modes"]
               if m["damping_ratio_predicted"] and np.isfinite(m["damping_ratio_measured"])]
        out[label]["damping_ratio_largest_relative_difference"] = max(dev) if dev else None
    return out
