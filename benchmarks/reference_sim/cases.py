"""Case descriptions: the concealed effects a benchmark draws, and the test settings.

A case is a small JSON (or TOML) document::

    {"controller": "mfdrf", "seed": 3, "mode": "compat",
     "excitation": {"kind": "multisine", "rms_n": 0.5, "band_hz": [0.5, 25],
                    "period_s": 10, "periods": 3, "settle_periods": 1},
     "effects": [{"type": "added_mass", "point": 6, "mass_kg": 0.12}]}

Effect types (each a parameter of the reference model, see :func:`apply_effects`):
``added_mass`` (point, mass_kg), ``member_stiffness`` (segment [upper, lower]
points, factor on EI), ``support_spring`` (point, dof "w"|"rx", stiffness in N/m or
N m/rad), ``modal_damping`` (mode, ratio), ``loop_delay`` (delay_periods: the loop's
total computation delay), ``actuator_gain`` (point, factor). No effect = a null
case. This module never imports vlab.
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from .params import BccParams

EFFECT_FIELDS = {
    "added_mass": {"point", "mass_kg"},
    "member_stiffness": {"segment", "factor"},
    "support_spring": {"point", "dof", "stiffness"},
    "modal_damping": {"mode", "ratio"},
    "loop_delay": {"delay_periods"},
    "actuator_gain": {"point", "factor"},
}

DEFAULT_EXCITATION = {"kind": "multisine", "rms_n": 0.5, "band_hz": [0.5, 25.0],
                      "period_s": 10.0, "periods": 3, "settle_periods": 1}


class CaseError(ValueError):
    """A case description with an unknown or malformed field (named)."""


@dataclass(frozen=True)
class Case:
    """A recording to make.

    Attributes
    ----------
    controller : str
        ``"none"`` (open loop) or a controller name for ``vlab design`` (mfdrf, ...).
    design : str or None
        A design JSON (``vlab design ... --json``); None: obtained by the CLI.
    effects : tuple of dict
        Concealed effects (validated).
    excitation : dict
        Excitation settings (:data:`DEFAULT_EXCITATION` keys).
    seed : int
        Seed of the excitation's phases and all noise.
    mode : str
        ``"compat"`` (velocities at the controller rate), ``"lab"`` (accelerations
        at 5 kHz, 16 bit) or ``"both"``.
    """

    controller: str = "none"
    design: str | None = None
    effects: tuple = ()
    excitation: dict = field(default_factory=lambda: dict(DEFAULT_EXCITATION))
    seed: int = 0
    mode: str = "compat"


def _check_effect(i: int, eff) -> dict:
    if not isinstance(eff, dict) or eff.get("type") not in EFFECT_FIELDS:
        raise CaseError(f"effects[{i}]: type must be one of {sorted(EFFECT_FIELDS)}, got {eff!r}")
    need = EFFECT_FIELDS[eff["type"]]
    have = set(eff) - {"type"}
    if have != need:
        raise CaseError(f"effects[{i}] ({eff['type']}): fields {sorted(have)}, expected {sorted(need)}")
    return dict(eff)


def load_case(path: str | Path) -> Case:
    """Read a case description (.json or .toml).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Case

    Raises
    ------
    CaseError
        Unknown keys, effect types, effect fields or mode.
    OSError
        Unreadable file.
    """
    path = Path(path)
    raw = path.read_bytes()
    doc = tomllib.loads(raw.decode()) if path.suffix == ".toml" else json.loads(raw)
    known = {"controller", "design", "effects", "excitation", "seed", "mode", "comment"}
    if set(doc) - known:
        raise CaseError(f"{path}: unknown keys {sorted(set(doc) - known)}")
    exc = dict(DEFAULT_EXCITATION)
    extra = set(doc.get("excitation", {})) - set(exc)
    if extra:
        raise CaseError(f"{path}: unknown excitation keys {sorted(extra)}")
    exc.update(doc.get("excitation", {}))
    if exc["kind"] not in ("multisine", "random"):
        raise CaseError(f"{path}: excitation kind must be multisine or random, got {exc['kind']!r}")
    mode = doc.get("mode", "compat")
    if mode not in ("compat", "lab", "both"):
        raise CaseError(f"{path}: mode must be compat, lab or both, got {mode!r}")
    effects = tuple(_check_effect(i, e) for i, e in enumerate(doc.get("effects", [])))
    design = doc.get("design")
    if design is not None and not Path(design).is_absolute():
        design = str((path.parent / design).resolve())
    return Case(controller=str(doc.get("controller", "none")), design=design,
                effects=effects, excitation=exc, seed=int(doc.get("seed", 0)), mode=mode)


@dataclass(frozen=True)
class Applied:
    """A case's effects sorted by where they act.

    Attributes
    ----------
    params : BccParams
        Structure with the structural effects.
    damping_overrides : dict[int, float]
        Mode (1-based) -> damping ratio.
    delay_periods : float
        Loop computation delay [periods].
    amp_gains : tuple of float
        Amplifier gain per actuator channel (the controller's order).
    """

    params: BccParams
    damping_overrides: dict
    delay_periods: float
    amp_gains: tuple


def apply_effects(p: BccParams, effects, delay_periods: float = 1.35) -> Applied:
    """Turn a case's effects into model and loop parameters.

    Parameters
    ----------
    p : BccParams
        The nominal structure.
    effects : sequence of dict
        As validated by :func:`load_case`.
    delay_periods : float
        The nominal computation delay [periods] (Sec. 5.3: 1.35).

    Returns
    -------
    Applied

    Raises
    ------
    CaseError
        An effect at a point or segment the structure does not have, or a
        non-positive factor, mass or ratio.
    """
    masses, factors, springs, damping = {}, {}, {}, {}
    gains = dict.fromkeys(p.actuators, 1.0)
    delay = delay_periods
    for eff in effects:
        kind = eff["type"]
        if "point" in eff and eff["point"] not in p.heights_m:
            raise CaseError(f"{kind}: unknown point {eff['point']!r}")
        if kind == "added_mass":
            masses[eff["point"]] = masses.get(eff["point"], 0.0) + float(eff["mass_kg"])
        elif kind == "member_stiffness":
            seg = tuple(int(q) for q in eff["segment"])
            if len(seg) != 2 or abs(seg[0] - seg[1]) != 1 or not set(seg) <= set(p.heights_m):
                raise CaseError(f"member_stiffness: segment must be two adjacent points, got {seg}")
            if not eff["factor"] > 0:
                raise CaseError(f"member_stiffness: factor must be > 0, got {eff['factor']}")
            factors[seg] = float(eff["factor"])
        elif kind == "support_spring":
            if eff["dof"] not in ("w", "rx"):
                raise CaseError(f"support_spring: dof must be 'w' or 'rx', got {eff['dof']!r}")
            springs[(eff["point"], eff["dof"])] = float(eff["stiffness"])
        elif kind == "modal_damping":
            if not 0 < eff["ratio"] < 1:
                raise CaseError(f"modal_damping: ratio must be in (0, 1), got {eff['ratio']}")
            damping[int(eff["mode"])] = float(eff["ratio"])
        elif kind == "loop_delay":
            delay = float(eff["delay_periods"])
        elif kind == "actuator_gain":
            if eff["point"] not in gains:
                raise CaseError(f"actuator_gain: point {eff['point']} is not an actuator {p.actuators}")
            gains[eff["point"]] = float(eff["factor"])
    changed = p.with_effects(added_masses_kg=masses, ei_factors=factors, springs=springs)
    return Applied(changed, damping, delay, tuple(gains[q] for q in p.actuators))
