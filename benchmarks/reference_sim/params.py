"""The Beam Cross-Cable's physical parameters, read from ``assets/structures/bcc.toml``.

Every number comes from the structure file (its own ``{value, unit, source}``
entries, read here with :mod:`tomllib`) and is converted to SI by
:mod:`benchmarks.reference_sim.units`. The interpretation of each entry follows the
dissertation's Sec. 2.1 and 2.1.1 and is stated in :class:`BccParams`.
This module never imports vlab.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from .units import G_STANDARD, UnitError, entry_value, to_si

DEFAULT_TOML = Path(__file__).resolve().parents[2] / "assets" / "structures" / "bcc.toml"
"""The shipped BCC structure file."""


@dataclass(frozen=True)
class BccParams:
    """Physical description of the BCC (Sec. 2.1), SI units.

    Attributes
    ----------
    heights_m : dict[int, float]
        Height of each grid point above point 9 [m] (points 1-9, point 9 = base).
    beam_ei_nm2 : float
        Bending stiffness of the steel beam [N m^2] (Sec. 2.1, measured).
    beam_mu_kg_m : float
        Mass per length of the beam [kg/m] (width x thickness x density).
    insert_point : int
        Point of the clamp; a rigid insert of ``insert_length_m`` on each side of it.
    insert_length_m : float
        Length of each of the two rigid inserts [m] (Sec. 2.1.1).
    point_masses_kg : dict[int, float]
        Lumped masses on the beam axis (coils, cable fittings) [kg], summed per point.
    clamp_mass_kg : float
        Lumped mass of the clamp at ``insert_point`` [kg].
    arm_length_m, arm_ei_nm2, arm_mu_kg_m, arm_width_m, arm_thickness_m : float
        One crosspiece arm: free length [m], bending stiffness [N m^2], mass per
        length [kg/m], width [m] (along the beam axis) and thickness [m].
    arm_count : int
        Number of arms (2: the crosspiece is symmetric).
    tip_mass_kg : float
        Tip mass of each arm [kg].
    bottom_tension_n : float
        Tension of the bottom cables together [N] (the file's value).
    top_length_m, bottom_length_m : float
        Free lengths of the top and bottom cables [m].
    top_mu_kg_m, bottom_mu_kg_m : float
        Mass per length of the cables of each end together [kg/m].
    gravity_m_s2 : float
        Magnitude of gravity [m/s^2], acting along -y (the beam hangs).
    damping_ratios : tuple of float
        Measured modal damping ratios of modes 1..n (Table 1).
    default_damping_ratio : float
        Damping ratio of the modes beyond ``damping_ratios``.
    actuators : tuple of int
        Actuator/collocated-velocity-sensor points in Table 7 order (5, 7, 9).
    excitation : int
        The excitation point (9, Sec. 5.4.2).
    response : int
        The response point of the control tests (6, Sec. 5.4.2).
    added_masses_kg : dict[int, float]
        Concealed added masses on the beam axis [kg].
    ei_factors : dict[tuple[int, int], float]
        Concealed factor on the beam's EI per segment (upper point, lower point).
    springs : dict[tuple[int, str], float]
        Concealed grounded springs: (point, "w") [N/m] or (point, "rx") [N m/rad].
    """

    heights_m: dict
    beam_ei_nm2: float
    beam_mu_kg_m: float
    insert_point: int
    insert_length_m: float
    point_masses_kg: dict
    clamp_mass_kg: float
    arm_length_m: float
    arm_ei_nm2: float
    arm_mu_kg_m: float
    arm_width_m: float
    arm_thickness_m: float
    arm_count: int
    tip_mass_kg: float
    bottom_tension_n: float
    top_length_m: float
    bottom_length_m: float
    top_mu_kg_m: float
    bottom_mu_kg_m: float
    gravity_m_s2: float
    damping_ratios: tuple
    default_damping_ratio: float
    actuators: tuple
    excitation: int
    response: int
    added_masses_kg: dict = field(default_factory=dict)
    ei_factors: dict = field(default_factory=dict)
    springs: dict = field(default_factory=dict)

    def with_effects(self, *, added_masses_kg=None, ei_factors=None, springs=None):
        """A copy with concealed structural effects (see :mod:`.cases`)."""
        return replace(
            self,
            added_masses_kg=dict(added_masses_kg or {}),
            ei_factors=dict(ei_factors or {}),
            springs=dict(springs or {}),
        )

    def total_weight_n(self) -> float:
        """Weight of everything the top cables hold, less the bottom tension [N]."""
        beam_len = max(self.heights_m.values()) - min(self.heights_m.values())
        masses = (
            sum(self.point_masses_kg.values())
            + sum(self.added_masses_kg.values())
            + self.crosspiece_mass_kg()
            + self.beam_mu_kg_m * beam_len
        )
        return masses * self.gravity_m_s2

    def crosspiece_mass_kg(self) -> float:
        """Clamp, arms and tip masses together [kg]."""
        arms = self.arm_count * (self.arm_mu_kg_m * self.arm_length_m + self.tip_mass_kg)
        return self.clamp_mass_kg + arms


def _section(doc, name):
    try:
        sec = doc["sections"][name]
    except KeyError as exc:
        raise UnitError(f"bcc.toml: no section {name!r}") from exc
    where = f"sections.{name}"
    width = to_si(sec["width"], "length", where + ".width")
    thick = to_si(sec["thickness"], "length", where + ".thickness")
    rho = to_si(sec["density"], "weight_density_as_density", where + ".density")
    ei = to_si(sec["ei"], "flexural_rigidity", where + ".ei")
    return width, thick, rho, ei


def _strings(doc, rho_default):
    out = {}
    for s in doc["strings"]:
        where = f"strings.{s['id']}"
        dia = to_si(s["diameter"], "length", where + ".diameter")
        rho = to_si(s.get("density", rho_default), "weight_density_as_density", where)
        mu = s.get("count", 1) * rho * math.pi * dia**2 / 4.0
        length = to_si(s["length"], "length", where + ".length")
        tension = None if s["tension"] == "reaction" else to_si(s["tension"], "force", where)
        out[s["point"]] = (length, mu, tension)
    return out


def load_bcc(path: str | Path = DEFAULT_TOML) -> BccParams:
    """Read the BCC's parameters from its structure file.

    Parameters
    ----------
    path : str or Path
        A structure file in the format of ``assets/structures/bcc.toml``.

    Returns
    -------
    BccParams
        SI units. Cable tension: the stated value is the bottom pair's tension
        together; the top pair carries it plus the weight (the file's
        ``tension = "reaction"``). Masses given as weights (lbf) are converted with
        standard gravity.

    Raises
    ------
    UnitError
        A missing entry or an unknown unit (named).
    OSError
        The file cannot be read.
    """
    with open(path, "rb") as fh:
        doc = tomllib.load(fh)
    scale = to_si({"value": 1.0, "unit": doc["points"]["unit"]}, "length", "points.unit")
    heights = {int(k): v[1] * scale for k, v in doc["points"]["coordinates"].items()}
    beam = next(m for m in doc["members"] if m["id"] == "beam")
    b_w, b_t, b_rho, b_ei = _section(doc, beam["section"])
    ins = beam["rigid_inserts"][0]
    cross = doc["crosspieces"][0]
    a_w, a_t, a_rho, a_ei = _section(doc, cross["section"])
    masses = {}
    for m in doc["masses"]:
        kg = to_si(m["mass"], "weight_as_mass", f"masses.{m['id']}")
        masses[m["point"]] = masses.get(m["point"], 0.0) + kg
    strings = _strings(doc, {"value": 0.283, "unit": "lbf/in^3"})
    top_point, bottom_point = beam["points"][0], beam["points"][-1]
    damping = doc["damping"]
    inst = doc["instrumentation"]
    return BccParams(
        heights_m=heights,
        beam_ei_nm2=b_ei,
        beam_mu_kg_m=b_rho * b_w * b_t,
        insert_point=int(ins["point"]),
        insert_length_m=to_si(ins["length"], "length", "members.beam.rigid_inserts"),
        point_masses_kg=masses,
        clamp_mass_kg=to_si(cross["clamp_mass"], "weight_as_mass", "crosspieces.clamp_mass"),
        arm_length_m=to_si(cross["arm_length"], "length", "crosspieces.arm_length"),
        arm_ei_nm2=a_ei,
        arm_mu_kg_m=a_rho * a_w * a_t,
        arm_width_m=a_w,
        arm_thickness_m=a_t,
        arm_count=2,
        tip_mass_kg=to_si(cross["tip_mass"], "weight_as_mass", "crosspieces.tip_mass"),
        bottom_tension_n=strings[bottom_point][2],
        top_length_m=strings[top_point][0],
        bottom_length_m=strings[bottom_point][0],
        top_mu_kg_m=strings[top_point][1],
        bottom_mu_kg_m=strings[bottom_point][1],
        gravity_m_s2=G_STANDARD * math.hypot(*doc["structure"]["gravity"]),
        damping_ratios=tuple(float(z) for z in damping["modal_ratios"]),
        default_damping_ratio=entry_value(damping["default_ratio"], "damping.default_ratio"),
        actuators=tuple(int(p) for p in inst["actuators"]),
        excitation=int(inst["excitation"]),
        response=int(inst["response"]),
    )
