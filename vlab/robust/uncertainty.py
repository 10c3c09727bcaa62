"""Model uncertainty of the robustness study: distributions, their defaults and sources, one draw per sample.

A study perturbs the structure (through its spec, so the FE model and the
MuJoCo plant follow) and the hardware chain. Parameter groups, each drawn
independently for every item it covers (every section, string, mass):

==================  =====================================================  ==========  =========================
group               what it scales                                          default     source
==================  =====================================================  ==========  =========================
member_ei           each section's bending stiffness EI                    U(+-5 %)    assumed (Sec. 2.1: EI
                                                                                        measured statically and
                                                                                        dynamically)
member_mass         each section's mass per length (and rotary inertia)    U(+-3 %)    assumed (handbook
                                                                                        densities, spec files)
cable_tension       each string with a given tension (BCC bottom cables)   U(+-10 %)   assumed (calibrated,
                                                                                        set by hand in the lab)
tip_mass            crosspiece tip and clamp masses, end fittings, joint   U(+-10 %)   assumed (calibrated
                    hardware and plates (every lumped mass but the coils)              lumped masses, Table 1)
coil_mass           each voice-coil mass                                   U(+-10 %)   assumed (calibrated)
support_stiffness   each support spring (the grid's pendulum supports)     U(+-10 %)   assumed
delay_periods       the PC-1000 computation delay, one per sample          U(+-0.2)    assumed around the
                    (absolute, periods; one DAC for all channels)                      measured 1.35 periods
                                                                                       (Sec. 5.3)
actuator_gain       each coil's force constant                             U(+-5 %)    assumed (calibrated
                                                                                       channels)
sensor_gain         each velocity sensor's sensitivity                     U(+-5 %)    assumed (calibrated
                                                                                       channels)
==================  =====================================================  ==========  =========================

A TOML file replaces any of these::

    [parameters.member_ei]
    kind = "normal"        # "uniform" (spread = half-width) or "normal" (spread = standard deviation)
    spread = 0.03          # relative (absolute periods for delay_periods); 0 switches the group off
    source = "my estimate"

The delay group was called ``delay_samples`` before; a file that names it so is read the same way.

Sample ``i`` of a study with seed ``s`` draws from
``numpy.random.default_rng([s, i])``: its values do not depend on how the
samples are split into chunks or on which machine they run.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFileError
from ..lab.blocks import PC1000_DELAY_PERIODS
from ..spec import StructureSpec, with_quantity

KINDS = ("uniform", "normal")


@dataclass(frozen=True)
class Uncertainty:
    """One parameter group's distribution.

    Attributes
    ----------
    group : str
        One of :data:`GROUPS`.
    kind : str
        ``"uniform"`` (``spread`` = half-width) or ``"normal"`` (``spread`` = standard deviation).
    spread : float
        Relative (a factor ``1 + x``), or absolute periods for ``delay_periods``; >= 0.
    source : str
        Where the value comes from.
    """

    group: str
    kind: str
    spread: float
    source: str

    def draw(self, rng: np.random.Generator, size: int) -> np.ndarray:
        """``size`` deviations ``x`` (relative or absolute, see :attr:`spread`), shape (size,).

        Parameters
        ----------
        rng : numpy.random.Generator
        size : int
        """
        if self.kind == "uniform":
            return rng.uniform(-self.spread, self.spread, size)
        return rng.normal(0.0, self.spread, size)


DEFAULTS: tuple[Uncertainty, ...] = (
    Uncertainty("member_ei", "uniform", 0.05, "assumed (Sec. 2.1: EI measured statically and dynamically)"),
    Uncertainty("member_mass", "uniform", 0.03, "assumed (handbook densities in the structure files)"),
    Uncertainty("cable_tension", "uniform", 0.10, "assumed (calibrated tension, set by hand in the lab)"),
    Uncertainty("tip_mass", "uniform", 0.10, "assumed (calibrated lumped masses, Table 1 + Table 8)"),
    Uncertainty("coil_mass", "uniform", 0.10, "assumed (calibrated coil masses, Table 1 + Table 8)"),
    Uncertainty("support_stiffness", "uniform", 0.10, "assumed"),
    Uncertainty("delay_periods", "uniform", 0.2, "assumed around the measured 1.35 periods (Sec. 5.3)"),
    Uncertainty("actuator_gain", "uniform", 0.05, "assumed (calibrated coil force constants)"),
    Uncertainty("sensor_gain", "uniform", 0.05, "assumed (calibrated sensor sensitivities)"),
)
#: Parameter groups, in draw order.
GROUPS = tuple(u.group for u in DEFAULTS)
#: Sources of the default spreads for a structure of one's own (the dissertation's tables do not apply).
_OWN_SOURCES = {"delay_periods": "assumed around the default hardware chain's 1.35 periods"}


def defaults_for(dissertation: bool) -> tuple[Uncertainty, ...]:
    """The default distributions: :data:`DEFAULTS` for the dissertation's structures; the same spreads with
    sources that name no table of the dissertation for any other structure.

    Parameters
    ----------
    dissertation : bool
        The study's structure is the BCC or the grid.

    Returns
    -------
    tuple of Uncertainty
    """
    if dissertation:
        return DEFAULTS
    return tuple(dataclasses.replace(u, source=_OWN_SOURCES.get(
        u.group, "assumed (vlab's default spread; the structure file states no tolerance)")) for u in DEFAULTS)
#: How each group reads in a sentence.
GROUP_WORDS = {"member_ei": "EI", "member_mass": "section mass", "cable_tension": "cable tension",
               "tip_mass": "lumped masses", "coil_mass": "coil masses", "support_stiffness": "support springs",
               "delay_periods": "delay", "actuator_gain": "actuator gains", "sensor_gain": "sensor gains"}
#: Former names of groups, still read from uncertainty files: the delay in sample periods.
GROUP_ALIASES = {"delay_samples": "delay_periods"}


def describe(uncertainties=DEFAULTS, nominal_delay_periods: float = PC1000_DELAY_PERIODS) -> str:
    """The spreads in one line, e.g. ``"EI ±5 %, section mass ±3 %, ..., delay 1.15-1.55 periods, ..."``.

    Parameters
    ----------
    uncertainties : sequence of Uncertainty
    nominal_delay_periods : float
        The delay the ``delay_periods`` spread is added to [periods] (Sec. 5.3: 1.35).

    Returns
    -------
    str
        Uniform spreads as ``±x %`` (the delay as its range), normal ones as ``sd x %``.
    """
    parts = []
    for u in uncertainties:
        name = GROUP_WORDS.get(u.group, u.group)
        if u.group == "delay_periods":
            lo, hi = nominal_delay_periods - u.spread, nominal_delay_periods + u.spread
            parts.append(f"{name} {lo:.2f}-{hi:.2f} periods" if u.kind == "uniform"
                         else f"{name} {nominal_delay_periods:g} periods sd {u.spread:g}")
        else:
            parts.append(f"{name} {'±' if u.kind == 'uniform' else 'sd '}{100 * u.spread:g} %")
    return ", ".join(parts)


def load_uncertainties(path: str | Path, defaults: tuple[Uncertainty, ...] = DEFAULTS) -> tuple[Uncertainty, ...]:
    """The defaults with the groups of a TOML file replaced (module notes).

    Parameters
    ----------
    path : str or Path
        The TOML file.
    defaults : tuple of Uncertainty
        The groups the file does not name (:func:`defaults_for`).

    Returns
    -------
    tuple of Uncertainty
        One per group of :data:`GROUPS`.

    Raises
    ------
    DataFileError
        Naming the file and the field: unreadable TOML, an unknown group or
        key, an unknown kind, a negative or non-finite spread.
    """
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise DataFileError(f"{p}: cannot read the uncertainty file: {exc}") from None
    params = data.get("parameters")
    if not isinstance(params, dict) or set(data) - {"parameters"}:
        raise DataFileError(f"{p}: expected only [parameters.<group>] tables (groups: {', '.join(GROUPS)})")
    out = {u.group: u for u in defaults}
    given: set[str] = set()
    for name, entry in params.items():
        where = f"{p}: parameters.{name}"
        group = GROUP_ALIASES.get(name, name)
        if group not in out:
            raise DataFileError(f"{where}: unknown group; use one of {', '.join(GROUPS)}")
        if group in given:
            raise DataFileError(f"{where}: group {group!r} given twice (under its former name too)")
        given.add(group)
        if not isinstance(entry, dict) or set(entry) - {"kind", "spread", "source"}:
            raise DataFileError(f"{where}: expected keys kind, spread, source; got {entry!r}")
        kind = entry.get("kind", out[group].kind)
        if kind not in KINDS:
            raise DataFileError(f"{where}.kind = {kind!r}: use one of {', '.join(KINDS)}")
        spread = entry.get("spread", out[group].spread)
        if isinstance(spread, bool) or not isinstance(spread, (int, float)) or not math.isfinite(spread) \
                or spread < 0:
            raise DataFileError(f"{where}.spread = {spread!r}: must be a finite number >= 0")
        out[group] = Uncertainty(group, kind, float(spread), str(entry.get("source", f"{p}")))
    return tuple(out[g] for g in GROUPS)


def _targets(spec: StructureSpec) -> dict[str, list[str]]:
    """Spec paths each group scales, in spec order."""
    coil = [f"masses.{m.id}.mass" for m in spec.masses if m.id.startswith("coil")]
    other = [f"masses.{m.id}.mass" for m in spec.masses if not m.id.startswith("coil")]
    tips = [f"crosspieces.{c.id}.{f}" for c in spec.crosspieces for f in ("tip_mass", "clamp_mass")]
    return {
        "member_ei": [f"sections.{s}.ei" for s in spec.sections],
        "member_mass": [f"sections.{s}.mass" for s in spec.sections],
        "cable_tension": [f"strings.{s.id}.tension" for s in spec.strings if s.tension is not None],
        "tip_mass": tips + other,
        "coil_mass": coil,
        "support_stiffness": [f"springs.{s.id}.stiffness" for s in spec.springs],
    }


@dataclass(frozen=True)
class Sample:
    """One draw: spec scale factors and the chain's delay and channel gains.

    Attributes
    ----------
    index : int
    factors : dict of str to float
        Spec path -> factor [-] (``sections.<name>.mass`` scales ``rho_a`` and ``rho_ip``).
    delay_periods : float
        Computation delay [periods].
    actuator_gain, sensor_gain : ndarray, shape (n_act,)
        Channel gains [-].
    """

    index: int
    factors: dict
    delay_periods: float
    actuator_gain: np.ndarray
    sensor_gain: np.ndarray


def draw_sample(spec: StructureSpec, uncertainties, *, seed: int, index: int, n_act: int,
                nominal_delay_periods: float) -> Sample:
    """Sample ``index`` of a study (``default_rng([seed, index])``; groups in :data:`GROUPS` order).

    Parameters
    ----------
    spec : StructureSpec
        The nominal structure (its sections, strings, masses, crosspieces, springs are drawn).
    uncertainties : sequence of Uncertainty
        Distributions; a group left out is not perturbed.
    seed, index : int
        Study seed and sample number.
    n_act : int
        Number of actuator/sensor channels (gains drawn per channel).
    nominal_delay_periods : float
        Delay the ``delay_periods`` deviation is added to [periods].

    Returns
    -------
    Sample

    Raises
    ------
    DataFileError
        A delay drawn negative (spread too large for the nominal delay).
    """
    rng = np.random.default_rng([int(seed), int(index)])
    by_group = {GROUP_ALIASES.get(u.group, u.group): u for u in uncertainties}
    targets = _targets(spec)
    factors = {}
    delay = nominal_delay_periods
    gains = {}
    for g in GROUPS:
        u = by_group.get(g)
        if g in targets:
            x = u.draw(rng, len(targets[g])) if u is not None else np.zeros(len(targets[g]))
            factors.update({p: 1.0 + float(v) for p, v in zip(targets[g], x)})
        elif g == "delay_periods":
            delay = nominal_delay_periods + (float(u.draw(rng, 1)[0]) if u is not None else 0.0)
        else:
            gains[g] = 1.0 + (u.draw(rng, n_act) if u is not None else np.zeros(n_act))
    if delay < 0:
        raise DataFileError(f"delay_periods: a sample drew a negative delay ({delay:g} periods); reduce its spread")
    return Sample(int(index), factors, delay, gains["actuator_gain"], gains["sensor_gain"])


def apply_sample(spec: StructureSpec, sample: Sample) -> StructureSpec:
    """The spec with the sample's factors applied (a new spec).

    Raises
    ------
    SpecError
        A factor path the spec does not have.
    """
    out = spec
    for path, f in sample.factors.items():
        coll, ident, fld = path.split(".")
        if coll == "sections" and fld == "mass":
            sec = out.sections[ident]
            secs = dict(out.sections)
            secs[ident] = dataclasses.replace(sec, rho_a=sec.rho_a * f, rho_ip=sec.rho_ip * f)
            out = out.replace(sections=secs)
            continue
        coll_items = {"sections": None, "strings": out.strings, "masses": out.masses,
                      "crosspieces": out.crosspieces, "springs": out.springs}[coll]
        if coll == "sections":
            old = getattr(out.sections[ident], fld).si
        else:
            old = getattr(next(x for x in coll_items if x.id == ident), fld).si
        out = with_quantity(out, path, old * f)
    return out
