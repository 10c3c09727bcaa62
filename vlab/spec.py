"""StructureSpec: the one definition of a laboratory structure.

``assets/structures/<name>.toml`` describes a structure once; the FE model
(:mod:`vlab.fe`) and the MuJoCo plant (:mod:`vlab.sim`) are both built from
the :class:`StructureSpec` loaded here. Every physical value in the file is an
inline table ``{ value = ..., unit = "...", source = "..." }``; the source is a
section or table of the dissertation, ``"assumed: <reason>"`` or
``"calibrated: <data>"``. Values are converted to SI on loading.

Coordinates: the structure lies in the plane (x, y), y up; ``w`` is the
out-of-plane (z) translation, ``rx``/``ry`` the rotations about x and y.

Errors: :class:`vlab.errors.SpecError` naming the file and the dotted field.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import units
from .errors import SpecError
from .spec_changes import CHANGE_TABLES, apply_change_tables, damping_of, release_supports

DOF_NAMES = ("w", "rx", "ry")

#: Folder of the shipped structure definitions and published tables.
ASSETS_DIR = Path(__file__).resolve().parent.parent / "assets"
STRUCTURES_DIR = ASSETS_DIR / "structures"
DATA_DIR = ASSETS_DIR / "data"

_KIND_UNITS = {
    "length": {"m", "in", "mm"},
    "force": {"N", "lbf"},
    "mass": {"kg", "lbf*s^2/in", "lbm", "lbf", "N"},  # lbf/N: a weight, divided by g
    "stiffness": {"N/m", "lbf/in"},
    "rot_stiffness": {"N*m/rad", "lbf*in/rad"},
    "rigidity": {"N*m^2", "lbf*in^2"},
    "modulus": {"Pa", "psi"},
    "density": {"kg/m^3", "lbf/in^3"},
    "inertia": {"kg*m^2", "lbf*s^2*in"},
    "shear_force": {"N", "lbf"},
    "ratio": {"1"},
}

#: Plausible range [SI] of each kind of value in a structure definition. The lab's
#: structures (Sec. 2: metre-sized steel and aluminium frames, cables and coils) lie
#: well inside; the bounds are wide enough for validation models (strings of density
#: 1 kg/m^3, EI 1e-7 N m^2) and catch the slips of units or exponents that make a
#: model meaningless (EI x 1e30 gives modes at 0 Hz and 3e15 Hz). Lengths 1 um .. 1 km;
#: moduli 1 kPa .. 10 TPa (diamond: 1.2 TPa); densities 1e-3 .. 1e5 kg/m^3 (osmium:
#: 22 600); masses 1 ug .. 1000 t; rigidities 1e-15 .. 1e10 N m^2 (BCC beam: 26,
#: grid top beam: 8.4e3); springs 1e-9 .. 1e12 N/m or N m/rad; tensions and shear
#: stiffnesses 1 uN .. 100 MN (kGA up to 1e12 N); inertias 1e-15 .. 1e6 kg m^2.
PLAUSIBLE_RANGES: dict[str, tuple[float, float, str]] = {
    "length": (1e-6, 1e3, "m"),
    "force": (1e-6, 1e8, "N"),
    "mass": (1e-9, 1e6, "kg"),
    "stiffness": (1e-9, 1e12, "N/m"),
    "rot_stiffness": (1e-9, 1e12, "N*m/rad"),
    "rigidity": (1e-15, 1e10, "N*m^2"),
    "modulus": (1e3, 1e13, "Pa"),
    "density": (1e-3, 1e5, "kg/m^3"),
    "inertia": (1e-15, 1e6, "kg*m^2"),
    "shear_force": (1e-6, 1e12, "N"),
    "ratio": (0.0, 1.0, "1"),
}

#: Most finite elements per member segment (the shipped structures use 1-4).
MAX_ELEMENTS_PER_SEGMENT = 200

#: Largest coordinate magnitude of a point [m].
MAX_COORDINATE_M = 1000.0


@dataclass(frozen=True)
class Quantity:
    """A value in SI with its provenance.

    Attributes
    ----------
    si : float
        Value in SI units.
    source : str
        Where it comes from ("Table 1", "assumed: ...", "calibrated: ...").
    """

    si: float
    source: str

    @property
    def calibrated(self) -> bool:
        """True when the value was fitted to data (source starts with 'calibrated')."""
        return self.source.lower().startswith("calibrated")


@dataclass(frozen=True)
class Section:
    """A rectangular bar section: geometry and material, SI.

    ``ei`` is the out-of-plane (weak-axis) flexural rigidity, ``ei_inplane`` the
    in-plane one (for the gravity statics), ``gj`` the St-Venant torsional
    rigidity, ``rho_a`` mass per length [kg/m], ``rho_ip`` polar mass moment of
    inertia per length [kg*m], ``ea`` the axial rigidity [N], and
    ``shear_stiffness`` kGA [N] or None for Euler-Bernoulli.

    Attributes
    ----------
    name : str
        Key of the section in the spec's ``[sections]`` table.
    width : Quantity
        Width b [m], the in-plane dimension (e.g. 2 in for the BCC beam, Sec. 2.1).
    thickness : Quantity
        Thickness t [m], the out-of-plane dimension (t <= b).
    ei : Quantity
        Out-of-plane flexural rigidity [N*m^2]: given (e.g. 9060 lb-in^2 for
        the BCC's steel beam, Sec. 2.1) or ``E b t^3 / 12``.
    ei_inplane : float
        In-plane flexural rigidity ``E t b^3 / 12`` [N*m^2].
    gj : Quantity
        St-Venant torsional rigidity [N*m^2]: given or
        ``G b t^3 / 3 (1 - 0.63 t / b)``.
    ea : float
        Axial rigidity ``E b t`` [N].
    rho_a : float
        Mass per unit length ``rho b t`` [kg/m].
    rho_ip : float
        Polar mass moment of inertia per unit length ``rho b t (b^2 + t^2) / 12`` [kg*m].
    shear_stiffness : Quantity or None
        Shear rigidity kGA [N] for a shear-flexible (Timoshenko) member, or
        None for Euler-Bernoulli (Sec. 2.2.1).
    """

    name: str
    width: Quantity
    thickness: Quantity
    ei: Quantity
    ei_inplane: float
    gj: Quantity
    ea: float
    rho_a: float
    rho_ip: float
    shear_stiffness: Quantity | None


@dataclass(frozen=True)
class RigidInsert:
    """A rigid insert of ``length`` [m] at ``point`` on each element end touching it."""

    point: int
    length: Quantity


@dataclass(frozen=True)
class Member:
    """A polyline of beam elements through ``points`` (ids), one section.

    Attributes
    ----------
    id : str
        Member name (unique in the spec).
    points : tuple of int
        Point ids along the member, at least two; each pair of consecutive
        points is one segment.
    section : str
        Name of its :class:`Section` in ``StructureSpec.sections``.
    elements_per_segment : int
        Number of beam elements each segment is cut into (>= 1; BCC: 1, giving
        the eight 10-inch beam elements of Sec. 2.1.1 between points 1-9).
    rigid_inserts : tuple of RigidInsert
        Rigid inserts at points of this member (the BCC clamp's "two one inch
        rigid inserts", Sec. 2.1.1); empty for none.
    """

    id: str
    points: tuple[int, ...]
    section: str
    elements_per_segment: int
    rigid_inserts: tuple[RigidInsert, ...] = ()


@dataclass(frozen=True)
class StringElement:
    """A string in tension from ``point`` to a ground anchor in ``direction``.

    ``tension`` is a :class:`Quantity` or None when the string is a support
    whose tension follows from equilibrium under gravity ("reaction").
    Modelled as a string-in-tension element (Sec. 2.1.1).

    Attributes
    ----------
    id : str
        String name (e.g. ``"bottom_cables"``).
    point : int
        Point id where the string is attached to the structure.
    direction : (float, float)
        Unit vector in the plane (x, y) from ``point`` towards the ground anchor.
    length : Quantity
        Length from the point to the anchor [m].
    tension : Quantity or None
        Tension T [N], or None for a "reaction" string (tension from the
        in-plane gravity statics, :func:`vlab.fe.statics.solve_gravity`).
    rho_a : Quantity
        Mass per unit length [kg/m], from ``count * density * pi d^2 / 4``.
    """

    id: str
    point: int
    direction: tuple[float, float]
    length: Quantity
    tension: Quantity | None
    rho_a: Quantity


@dataclass(frozen=True)
class LumpedMass:
    """A rigid mass at a point: ``mass`` [kg], rotary inertias [kg*m^2].

    Attributes
    ----------
    id : str
        Mass name (e.g. ``"coil5"``).
    point : int
        Point id it sits at.
    mass : Quantity
        Mass [kg] (a weight given in lbf or N is divided by g).
    inertia_rx : Quantity or None
        Rotary inertia about the x axis [kg*m^2], added to the ``rx`` DOF; None = 0.
    inertia_ry : Quantity or None
        Rotary inertia about the y axis [kg*m^2], added to the ``ry`` DOF; None = 0.
    """

    id: str
    point: int
    mass: Quantity
    inertia_rx: Quantity | None = None
    inertia_ry: Quantity | None = None


@dataclass(frozen=True)
class Crosspiece:
    """Symmetric cantilever arms with tip masses clamped at ``point``.

    The FE model represents it as a single-DOF spring-mass (Sec. 2.1.1); the
    MuJoCo plant as two flexible arms.

    Attributes
    ----------
    id : str
        Crosspiece name; also the node of its extra FE DOF.
    point : int
        Point id where it is clamped to the beam (BCC: 20 in above the base, Sec. 2.1).
    arm_length : Quantity
        Length of each of the two arms [m] (BCC: 15 in, the 32-inch
        crosspiece of Sec. 2.1 less the clamp).
    section : str
        Name of the arms' :class:`Section` (EI 2680 lb-in^2, Sec. 2.1).
    tip_mass : Quantity
        Tip mass at the end of each arm [kg].
    clamp_mass : Quantity
        Mass of the clamp [kg] (>= 0), rigid with ``point``.
    """

    id: str
    point: int
    arm_length: Quantity
    section: str
    tip_mass: Quantity
    clamp_mass: Quantity


@dataclass(frozen=True)
class Spring:
    """A grounded spring on one DOF of a point (N/m or N*m/rad).

    E.g. the grid plates' pendulous stiffness W*Y at points 13 and 22 (Sec. 2.2.1).

    Attributes
    ----------
    id : str
        Spring name.
    point : int
        Point id it acts on.
    dof : str
        The DOF: ``"w"``, ``"rx"`` or ``"ry"``.
    stiffness : Quantity
        Stiffness [N/m] on ``w``, [N*m/rad] on a rotation.
    """

    id: str
    point: int
    dof: str
    stiffness: Quantity


@dataclass(frozen=True)
class Support:
    """Out-of-plane DOFs fixed at a point, and whether it is pinned in-plane.

    Attributes
    ----------
    point : int
        Point id.
    fixed : tuple of str
        DOFs removed from the out-of-plane model (``"w"``, ``"rx"``, ``"ry"``).
    inplane : str
        Restraint in the in-plane gravity statics: ``"free"``, ``"pinned"``
        (u, v fixed) or ``"clamped"`` (u, v and the in-plane rotation fixed).
    """

    point: int
    fixed: tuple[str, ...]
    inplane: str  # "free", "pinned" or "clamped" in the in-plane gravity statics


@dataclass(frozen=True)
class Instrumentation:
    """Actuator/sensor point ids, excitation and response points (Sec. 5.4).

    Attributes
    ----------
    actuators : tuple of int
        Points with a force coil, in channel order (BCC: 5, 7, 9 as in
        Table 7; grid: joints 1, 2, 4, 5, 8); each has a collocated velocity sensor.
    sensors : tuple of int
        Points with a velocity sensor.
    excitation : int
        Actuator point that also carries the excitation (BCC: 9; grid: 4; Sec. 5.4.2).
    response : int
        Point whose FRF is shown by default.
    source : str
        Provenance (sections of the dissertation).
    """

    actuators: tuple[int, ...]
    sensors: tuple[int, ...]
    excitation: int
    response: int
    source: str


@dataclass(frozen=True)
class Damping:
    """Open-loop modal damping ratios for the first modes, and a default for the rest.

    Attributes
    ----------
    modal_ratios : tuple of float
        Damping ratios zeta [-] of the first modes, in frequency order, each
        in [0, 1) (experimental values of Tables 1 and 3).
    default_ratio : float
        Damping ratio [-] of every higher mode.
    source : str
        Provenance of the values.
    basis : StructureSpec or None
        The structure whose modes the ratios belong to (None: this structure's own). A physical change
        added to a structure (a mass, a spring, a stiffer member) leaves its damping matrix as it was: the
        spec of the changed structure keeps the unchanged one here, and its modal damping ratios follow
        from that matrix (:func:`vlab.fe.damping.structural_damping`). Not read from a structure file.
    """

    modal_ratios: tuple[float, ...]
    default_ratio: float
    source: str
    basis: "StructureSpec | None" = field(default=None, repr=False)


@dataclass(frozen=True)
class ModelFormDeclared:
    """A model-form uncertainty the structure's author states (``[model_form]``), instead of the one
    derived from a calibration reference (:mod:`vlab.diagnose.model.modelform`).

    Attributes
    ----------
    frequency_rel : tuple of float
        Relative standard uncertainty [1] of the natural frequencies, per mode in frequency order (the last
        value holds for every higher mode), each in [0, 1).
    source : str
        Where the values come from (a calibration against measurements, a published comparison).
    """

    frequency_rel: tuple[float, ...]
    source: str


#: Response quantities a test can compare (Sec. 5.4.2: BCC displacement, Fig. 22; grid velocity, Figs. 23-31).
RESPONSE_QUANTITIES = ("displacement", "velocity")

#: Highest test-band edge allowed [Hz]: below the Nyquist frequency of the 2 kHz laboratory loop (Sec. 5.3)
#: by a factor four, so that the digital controller, hold and RC filter act as modelled.
MAX_TEST_BAND_HZ = 250.0

#: Fields of a ``[design]`` table and their types: the controller-design settings of
#: :class:`vlab.design.ThesisSettings` (weights in the thesis unit system: in, lbf, cs, Sec. 3).
DESIGN_FIELDS: dict[str, type | tuple[type, ...]] = {
    "zeta_min": (int, float), "n_modes": int, "n_f": int, "q_scale": (int, float), "r": (int, float),
    "v1": (int, float), "v2": (int, float), "alpha": (int, float), "default_model": str,
    "r_corrected": (int, float),
}


@dataclass(frozen=True)
class StructureTest:
    """How a structure is tested (Sec. 5.4): band, resolution, levels, points.

    The shipped structures' tests are :data:`vlab.lab.experiment.TESTS`; any
    structure file may carry its own in a ``[test]`` table
    (:func:`vlab.lab.experiment.test_definition` picks one).

    Attributes
    ----------
    band_hz : (float, float)
        Excitation and comparison band (low, high) [Hz].
    resolution_hz : float
        Default FRF frequency resolution [Hz]; one record lasts ``1 / resolution_hz`` [s].
    rms_n : float
        RMS of the random excitation force [N] (the sweep amplitude is
        ``sqrt(2) * rms_n``, the impulse peak ``20 * rms_n``).
    n_modes : int
        Number of closed-loop modes in the band compared with the analysis
        (rows of Tables 10 and 19-21).
    response_point : int
        Point id whose FRF is compared (BCC: point 6; grid: joint 4; Sec. 5.4.2).
    measured_points : tuple of int
        Point ids whose velocities are recorded (with the actuator points added).
    response_quantity : str
        FRF quantity compared: ``"displacement"`` [m/N] (BCC, Fig. 22) or
        ``"velocity"`` [(m/s)/N] (grid, Figs. 23-31).
    """

    band_hz: tuple[float, float]
    resolution_hz: float
    rms_n: float
    n_modes: int
    response_point: int
    measured_points: tuple[int, ...]
    response_quantity: str  # FRF compared: "displacement" (BCC, Fig. 22) or "velocity" (grid, Figs. 23-31)


@dataclass(frozen=True)
class StructureSpec:
    """The whole definition of one structure, SI. Immutable; use :meth:`replace`.

    Attributes
    ----------
    name : str
        Short name (``"bcc"``, ``"grid"``).
    title : str
        Descriptive title.
    path : Path or None
        File it was loaded from (None when built from a dict); named in errors.
    active_dofs : tuple of str
        Out-of-plane DOFs modelled at every node, a subset of
        ``("w", "rx", "ry")`` that contains ``"w"``.
    gravity_direction : (float, float)
        Unit vector of gravity in the plane (x, y); (0, 0) for no gravity.
    points : dict[int, (float, float)]
        Point id -> coordinates (x, y) [m] (numbering of the dissertation).
    sections : dict[str, Section]
        Sections by name.
    members : tuple of Member
        Beam members.
    strings : tuple of StringElement
        Strings in tension to ground.
    masses : tuple of LumpedMass
        Lumped masses and rotary inertias.
    crosspieces : tuple of Crosspiece
        Crosspieces (BCC only).
    springs : tuple of Spring
        Grounded springs.
    supports : tuple of Support
        Supports.
    instrumentation : Instrumentation or None
        Actuator, sensor, excitation and response points.
    damping : Damping or None
        Open-loop modal damping ratios.
    model_form : ModelFormDeclared or None
        The ``[model_form]`` table: a stated model-form uncertainty of the frequencies.
    reference : dict[str, str]
        Name -> file in ``assets/data`` of a published table (e.g.
        ``"frequencies": "table1_bcc_frequencies.csv"``).
    master_dofs : dict[str, tuple of (int, str)]
        Reduction method (``"exact"``, ``"guyan"``) -> master DOFs as
        ``(point, dof)`` pairs (grid: Sec. 3.3).
    mujoco : dict[str, Any]
        The ``[mujoco]`` table as read: options of the MuJoCo plant builder
        (segments, timestep, ...; see :class:`vlab.sim.builder.SimOptions`).
    test : StructureTest or None
        The ``[test]`` table (band, resolution, points of the modal test,
        Sec. 5.4); None = the shipped test of a structure of that name, if any
        (:func:`vlab.lab.experiment.test_definition`).
    design_settings : dict[str, Any]
        The ``[design]`` table: controller-design settings (keys of
        :data:`DESIGN_FIELDS`), checked for type and range;
        :func:`vlab.design.design_settings` fills the rest with defaults.
    raw : dict[str, Any]
        The parsed TOML document (not compared, not shown in ``repr``).
    """

    name: str
    title: str
    path: Path | None
    active_dofs: tuple[str, ...]
    gravity_direction: tuple[float, float]
    points: dict[int, tuple[float, float]]
    sections: dict[str, Section]
    members: tuple[Member, ...]
    strings: tuple[StringElement, ...] = ()
    masses: tuple[LumpedMass, ...] = ()
    crosspieces: tuple[Crosspiece, ...] = ()
    springs: tuple[Spring, ...] = ()
    supports: tuple[Support, ...] = ()
    instrumentation: Instrumentation | None = None
    damping: Damping | None = None
    model_form: ModelFormDeclared | None = None
    reference: dict[str, str] = field(default_factory=dict)
    master_dofs: dict[str, tuple[tuple[int, str], ...]] = field(default_factory=dict)
    mujoco: dict[str, Any] = field(default_factory=dict)
    test: StructureTest | None = None
    design_settings: dict[str, Any] = field(default_factory=dict)
    raw: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def replace(self, **changes: Any) -> "StructureSpec":
        """Return a copy with fields replaced (the spec itself never changes).

        Parameters
        ----------
        **changes
            Field name -> new value, as for :func:`dataclasses.replace`.

        Returns
        -------
        StructureSpec
            The new spec.
        """
        return dataclasses.replace(self, **changes)

    def check_point(self, point: int, where: str) -> int:
        """Return ``point`` if it exists, else raise SpecError naming ``where``."""
        if point not in self.points:
            raise SpecError(
                f"{self._file()}: {where}: unknown point id {point!r}; "
                f"points are {sorted(self.points)}"
            )
        return point

    def calibrated_quantities(self) -> dict[str, Quantity]:
        """All values whose source says 'calibrated', keyed by a dotted path."""
        out: dict[str, Quantity] = {}

        def walk(prefix: str, obj: Any) -> None:
            if isinstance(obj, Quantity):
                if obj.calibrated:
                    out[prefix] = obj
            elif dataclasses.is_dataclass(obj):
                for f in dataclasses.fields(obj):
                    walk(f"{prefix}.{f.name}", getattr(obj, f.name))
            elif isinstance(obj, (tuple, list)):
                for item in obj:
                    walk(f"{prefix}.{getattr(item, 'id', getattr(item, 'name', ''))}", item)
            elif isinstance(obj, dict):
                for k, v in obj.items():
                    walk(f"{prefix}.{k}", v)

        for name in ("sections", "strings", "masses", "crosspieces", "springs"):
            walk(name, getattr(self, name))
        return out

    def _file(self) -> str:
        return str(self.path) if self.path else f"<spec {self.name}>"


# ---------------------------------------------------------------- reading ---


class _Reader:
    """Reads one TOML table with field-path aware errors."""

    def __init__(self, file: str, table: dict[str, Any], path: str):
        self.file, self.table, self.path = file, table, path
        if not isinstance(table, dict):
            self.fail("", f"expected a table, got {type(table).__name__}")
        self._used: set[str] = set()

    def fail(self, key: str, msg: str) -> None:
        where = f"{self.path}.{key}" if key and self.path else (key or self.path)
        raise SpecError(f"{self.file}: field '{where}': {msg}")

    def has(self, key: str) -> bool:
        return key in self.table

    def raw(self, key: str, default: Any = ..., *, types: tuple[type, ...] = ()) -> Any:
        self._used.add(key)
        if key not in self.table:
            if default is ...:
                self.fail(key, "missing")
            return default
        v = self.table[key]
        if types and not isinstance(v, types):
            self.fail(key, f"expected {'/'.join(t.__name__ for t in types)}, got {v!r}")
        return v

    def str(self, key: str, default: Any = ...) -> str:
        return self.raw(key, default, types=(str,))

    def int(self, key: str, default: Any = ...) -> int:
        v = self.raw(key, default, types=(int,))
        if isinstance(v, bool):
            self.fail(key, f"expected an integer, got {v!r}")
        return v

    def sub(self, key: str, default: Any = ...) -> "_Reader | None":
        v = self.raw(key, default, types=(dict,))
        if v is None:
            return None
        return _Reader(self.file, v, f"{self.path}.{key}" if self.path else key)

    def quantity(self, key: str, kind: str, *, positive: bool = True, optional: bool = False) -> Quantity | None:
        if optional and key not in self.table:
            self._used.add(key)
            return None
        q = self.sub(key)
        value = q.raw("value", types=(int, float))
        if isinstance(value, bool) or not math.isfinite(value):
            q.fail("value", f"expected a finite number, got {value!r}")
        unit = q.str("unit")
        source = q.str("source")
        if not source.strip():
            q.fail("source", "empty: every value needs its source (table, section, 'assumed: ...' or 'calibrated: ...')")
        q.done()
        if unit not in _KIND_UNITS[kind]:
            q.fail("unit", f"{unit!r} is not a unit of {kind}; use one of {sorted(_KIND_UNITS[kind])}")
        si = float(value) * units.factor(unit, where=f"{self.file}: field '{q.path}.unit'")
        if kind == "mass" and unit in ("lbf", "N"):
            si = units.weight_to_mass(float(value) * units.factor(unit))
        if positive and si <= 0.0:
            q.fail("value", f"must be positive, got {value!r}")
        if not positive and si < 0.0:
            q.fail("value", f"must not be negative, got {value!r}")
        lo, hi, si_unit = PLAUSIBLE_RANGES[kind]
        if not math.isfinite(si) or si > hi or (si < lo and not (si == 0.0 and not positive)):
            q.fail("value", f"{value!r} {unit} = {si:.4g} {si_unit} is outside the plausible range "
                            f"[{lo:g}, {hi:g}] {si_unit} of a {kind.replace('_', ' ')} in a laboratory structure "
                            "(a unit or exponent slip?)")
        return Quantity(si, source)

    def done(self) -> None:
        extra = set(self.table) - self._used
        if extra:
            self.fail(sorted(extra)[0], f"unknown field (known here: {sorted(self._used)})")


def _section(r: _Reader, name: str) -> Section:
    b = r.quantity("width", "length")
    t = r.quantity("thickness", "length")
    rho = r.quantity("density", "density")
    e = r.quantity("modulus", "modulus")
    g = r.quantity("shear_modulus", "modulus")
    ei = r.quantity("ei", "rigidity", optional=True)
    gj = r.quantity("gj", "rigidity", optional=True)
    kga = r.quantity("shear_stiffness", "shear_force", optional=True)
    r.done()
    bw, tk = b.si, t.si
    if tk > bw:
        r.fail("thickness", "thickness larger than width: the out-of-plane axis is the thin one")
    area = bw * tk
    ei_calc = e.si * bw * tk**3 / 12.0
    gj_calc = g.si * bw * tk**3 / 3.0 * (1.0 - 0.63 * tk / bw)
    if ei is None:
        ei = Quantity(ei_calc, f"E*b*t^3/12 ({e.source})")
    if gj is None:
        gj = Quantity(gj_calc, f"G*b*t^3/3*(1-0.63 t/b) ({g.source})")
    return Section(
        name=name,
        width=b,
        thickness=t,
        ei=ei,
        ei_inplane=e.si * tk * bw**3 / 12.0,
        gj=gj,
        ea=e.si * area,
        rho_a=rho.si * area,
        rho_ip=rho.si * area * (bw**2 + tk**2) / 12.0,
        shear_stiffness=kga,
    )


def _direction(r: _Reader, key: str) -> tuple[float, float]:
    v = r.raw(key, types=(list,))
    if len(v) != 2 or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
        r.fail(key, f"expected [x, y], got {v!r}")
    if not all(math.isfinite(x) for x in v):
        r.fail(key, f"expected finite [x, y], got {v!r}")
    n = math.hypot(*v)
    if n == 0:
        if key == "gravity":
            return (0.0, 0.0)  # no gravity: for validation models
        r.fail(key, "zero vector")
    return (v[0] / n, v[1] / n)


def _dof(r: _Reader, key: str, value: str) -> str:
    if value not in DOF_NAMES:
        r.fail(key, f"unknown DOF {value!r}; use one of {DOF_NAMES}")
    return value


def load_spec(name_or_path: str | Path, *, allow_outside: bool | None = None) -> StructureSpec:
    """Load a structure definition.

    Parameters
    ----------
    name_or_path : str or Path
        ``"bcc"``/``"grid"`` (a file in ``assets/structures``) or a path to a TOML file.
    allow_outside : bool, optional
        Allow ``[reference]`` files outside the structure file's folder and
        the packaged data (:func:`spec_from_dict`).

    Returns
    -------
    StructureSpec
        All values in SI.

    Raises
    ------
    SpecError
        If the file is missing or unreadable, is not UTF-8 (names the byte
        offset and line), is not valid TOML, has a missing, unknown or
        mistyped field, a non-positive stiffness/mass, a value outside
        :data:`PLAUSIBLE_RANGES`, an unknown point id, or a ``[reference]``
        file outside its folders (:func:`spec_from_dict`); the message names the file and field.
    """
    path = Path(name_or_path)
    if path.suffix != ".toml":
        path = STRUCTURES_DIR / f"{name_or_path}.toml"
        if not path.exists():
            known = sorted(p.stem for p in STRUCTURES_DIR.glob("*.toml"))
            raise SpecError(f"unknown structure {str(name_or_path)!r}: not one of {known} nor a path to a "
                            ".toml file (`vlab init KIND PATH` writes one)")
    if not path.exists():
        raise SpecError(f"{path}: file not found")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise SpecError(f"{path}: cannot be read: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise SpecError(f"{path}: not UTF-8 text: byte {raw[exc.start:exc.start + 1]!r} at offset {exc.start} "
                        f"(line {line}); TOML files must be UTF-8") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: not valid TOML: {exc}") from None
    return spec_from_dict(doc, path=path, allow_outside=allow_outside)


def _reference_file(file: str, field_name: str, fname: str, path: Path | None, allow_outside: bool | None) -> str:
    """A ``[reference]`` file name checked: inside the structure file's folder or :data:`DATA_DIR`.

    Returns the name as given when the file is in :data:`DATA_DIR` (read as
    ``DATA_DIR / name``), else its absolute real path. Raises SpecError naming
    the file and field when the name reaches outside both folders (unless
    ``allow_outside``, see :func:`vlab.io.confine.confined_file`), is
    missing, not a regular file or over :data:`vlab.io.confine.MAX_NAMED_BYTES`.
    """
    from .io.confine import confined_file

    folders = ([Path(path).parent] if path is not None else []) + [DATA_DIR]
    real = confined_file(fname, folders, where=f"{file}: field {field_name!r}", allow=allow_outside,
                         error=SpecError)
    data = Path(DATA_DIR).resolve()
    return fname if data in real.parents and (data / fname).resolve() == real else str(real)


def spec_from_dict(doc: dict[str, Any], *, path: Path | None = None,
                   allow_outside: bool | None = None) -> StructureSpec:
    """Build a :class:`StructureSpec` from a parsed TOML document (see :func:`load_spec`).

    The changes a diagnosis found (``vlab update``: ``[[member_stiffness]]``, ``[[joint_flexibility]]``,
    ``[[mode_damping]]``, springs that replace a support, elements marked ``added = true``) are applied
    last, keeping the damping matrix of the structure before them (:mod:`vlab.spec_changes`).

    Parameters
    ----------
    doc : dict
        The document, as ``tomllib.loads`` returns it; physical values as
        ``{ value, unit, source }`` tables, converted to SI here.
    path : Path, optional
        File the document came from: stored in the spec and named in errors
        (``"<dict>"`` when None); its folder is where ``[reference]`` files
        are looked for first (then :data:`DATA_DIR`).
    allow_outside : bool, optional
        Allow ``[reference]`` files outside those two folders (None: the
        environment, :func:`vlab.io.confine.outside_allowed`).

    Returns
    -------
    StructureSpec

    Raises
    ------
    SpecError
        If a field is missing, unknown or mistyped, a unit does not fit its
        quantity, a value is not positive (or negative where zero is allowed)
        or outside :data:`PLAUSIBLE_RANGES`, a coordinate is not finite or beyond
        :data:`MAX_COORDINATE_M`, two consecutive member points coincide,
        ``elements_per_segment`` exceeds :data:`MAX_ELEMENTS_PER_SEGMENT`, a
        point, section or DOF is unknown, a referenced data file is missing,
        reaches outside the structure file's folder and the packaged data,
        is not a regular file or is too large,
        member ids repeat, or a ``[test]`` / ``[design]`` value is out of range
        (a band beyond :data:`MAX_TEST_BAND_HZ`, a resolution leaving fewer than
        4 lines, a response point not recorded, ...); the message names the
        file and the dotted field.
    """
    file = str(path) if path else "<dict>"
    top = _Reader(file, doc, "")
    s = top.sub("structure")
    name = s.str("name")
    title = s.str("title")
    s.str("source")
    active = tuple(_dof(s, "dofs", d) for d in s.raw("dofs", types=(list,)))
    if "w" not in active:
        s.fail("dofs", "the out-of-plane translation 'w' must be active")
    grav = _direction(s, "gravity")
    s.done()

    p = top.sub("points")
    unit = p.str("unit")
    scale = units.factor(unit, where=f"{file}: field 'points.unit'")
    p.str("source")
    coords = p.sub("coordinates")
    points: dict[int, tuple[float, float]] = {}
    for key in list(coords.table):
        xy = coords.raw(key, types=(list,))
        if not key.isdigit():
            coords.fail(key, "point ids must be positive integers")
        if len(xy) != 2 or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in xy):
            coords.fail(key, f"expected [x, y], got {xy!r}")
        xy_m = (xy[0] * scale, xy[1] * scale)
        if not all(math.isfinite(x) and abs(x) <= MAX_COORDINATE_M for x in xy_m):
            coords.fail(key, f"coordinates {xy!r} {unit} must be finite and within {MAX_COORDINATE_M:g} m")
        if int(key) in points:
            coords.fail(key, f"point {int(key)} is given twice")
        points[int(key)] = xy_m
    p.done()

    sections = {}
    sec_tab = top.sub("sections")
    for key in list(sec_tab.table):
        sections[key] = _section(sec_tab.sub(key), key)
    sec_tab.done()

    def point_of(r: _Reader, key: str) -> int:
        pid = r.int(key)
        if pid not in points:
            r.fail(key, f"unknown point id {pid}; points are {sorted(points)}")
        return pid

    members = []
    for i, t in enumerate(top.raw("members", types=(list,))):
        r = _Reader(file, t, f"members[{i}]")
        pts = r.raw("points", types=(list,))
        if len(pts) < 2:
            r.fail("points", "a member needs at least two points")
        for pid in pts:
            if not isinstance(pid, int) or isinstance(pid, bool) or pid not in points:
                r.fail("points", f"unknown point id {pid!r}; points are {sorted(points)}")
        for a, b in zip(pts, pts[1:]):
            if points[a] == points[b]:
                r.fail("points", f"points {a} and {b} coincide: a segment of zero length")
        sec = r.str("section")
        if sec not in sections:
            r.fail("section", f"unknown section {sec!r}; sections are {sorted(sections)}")
        n = r.int("elements_per_segment", 1)
        if not 1 <= n <= MAX_ELEMENTS_PER_SEGMENT:
            r.fail("elements_per_segment", f"must be between 1 and {MAX_ELEMENTS_PER_SEGMENT}, got {n}")
        inserts = []
        for j, ins in enumerate(r.raw("rigid_inserts", [], types=(list,))):
            ri = _Reader(file, ins, f"{r.path}.rigid_inserts[{j}]")
            pid = point_of(ri, "point")
            if pid not in pts:
                ri.fail("point", f"point {pid} is not on this member")
            inserts.append(RigidInsert(pid, ri.quantity("length", "length")))
            ri.done()
        members.append(Member(r.str("id"), tuple(pts), sec, n, tuple(inserts)))
        r.done()

    strings = []
    for i, t in enumerate(top.raw("strings", [], types=(list,))):
        r = _Reader(file, t, f"strings[{i}]")
        tension = None
        if r.has("tension") and r.table["tension"] == "reaction":
            r.raw("tension")
        else:
            tension = r.quantity("tension", "force")
        strings.append(
            StringElement(
                id=r.str("id"),
                point=point_of(r, "point"),
                direction=_direction(r, "direction"),
                length=r.quantity("length", "length"),
                tension=tension,
                rho_a=_mass_per_length(r),
            )
        )
        r.done()

    masses, added = [], set()  # (table, index) of the masses and springs marked `added = true`
    for i, t in enumerate(top.raw("masses", [], types=(list,))):
        r = _Reader(file, t, f"masses[{i}]")
        if r.raw("added", False, types=(bool,)):
            added.add(("masses", i))
        masses.append(
            LumpedMass(
                id=r.str("id"),
                point=point_of(r, "point"),
                mass=r.quantity("mass", "mass"),
                inertia_rx=r.quantity("inertia_rx", "inertia", optional=True),
                inertia_ry=r.quantity("inertia_ry", "inertia", optional=True),
            )
        )
        r.done()

    crosspieces = []
    for i, t in enumerate(top.raw("crosspieces", [], types=(list,))):
        r = _Reader(file, t, f"crosspieces[{i}]")
        sec = r.str("section")
        if sec not in sections:
            r.fail("section", f"unknown section {sec!r}; sections are {sorted(sections)}")
        crosspieces.append(
            Crosspiece(
                id=r.str("id"),
                point=point_of(r, "point"),
                arm_length=r.quantity("arm_length", "length"),
                section=sec,
                tip_mass=r.quantity("tip_mass", "mass"),
                clamp_mass=r.quantity("clamp_mass", "mass", positive=False),
            )
        )
        r.done()

    springs, released = [], []
    for i, t in enumerate(top.raw("springs", [], types=(list,))):
        r = _Reader(file, t, f"springs[{i}]")
        if r.raw("added", False, types=(bool,)):
            added.add(("springs", i))
        dof = _dof(r, "dof", r.str("dof"))
        kind = "stiffness" if dof == "w" else "rot_stiffness"
        springs.append(Spring(r.str("id"), point_of(r, "point"), dof, r.quantity("stiffness", kind)))
        if r.raw("replaces_support", False, types=(bool,)):
            released.append((i, (springs[-1].point, dof)))
        r.done()

    supports = []
    for i, t in enumerate(top.raw("supports", [], types=(list,))):
        r = _Reader(file, t, f"supports[{i}]")
        fixed = tuple(_dof(r, "fixed", d) for d in r.raw("fixed", types=(list,)))
        inplane = r.raw("inplane", "free", types=(bool, str))
        inplane = {True: "pinned", False: "free"}.get(inplane, inplane)
        if inplane not in ("free", "pinned", "clamped"):
            r.fail("inplane", f"expected true/false or 'free', 'pinned', 'clamped', got {inplane!r}")
        supports.append(Support(point_of(r, "point"), fixed, inplane))
        r.done()
    def fail_release(i: int, msg: str) -> None:
        _Reader(file, top.table["springs"][i], f"springs[{i}]").fail("replaces_support", msg)

    built = tuple(supports)
    supports = release_supports(built, released, fail_release)

    instr = None
    ir = top.sub("instrumentation", None)
    if ir is not None:
        acts = _points_list(ir, "actuators", points)
        sens = _points_list(ir, "sensors", points)
        exc = point_of(ir, "excitation")
        if exc not in acts:
            ir.fail("excitation", f"excitation point {exc} must be one of the actuators {list(acts)}")
        instr = Instrumentation(acts, sens, exc, point_of(ir, "response"), ir.str("source"))
        ir.done()

    damping = None
    dr = top.sub("damping", None)
    if dr is not None:
        ratios = dr.raw("modal_ratios", types=(list,))
        for z in ratios:
            if not isinstance(z, (int, float)) or isinstance(z, bool) or not 0.0 <= z < 1.0:
                dr.fail("modal_ratios", f"damping ratios must be in [0, 1), got {z!r}")
        default = dr.raw("default_ratio", types=(int, float))
        if isinstance(default, bool) or not 0.0 <= default < 1.0:
            dr.fail("default_ratio", f"a damping ratio must be in [0, 1), got {default!r}")
        damping = Damping(tuple(float(z) for z in ratios), float(default), dr.str("source"))
        dr.done()

    model_form = None
    mr = top.sub("model_form", None)
    if mr is not None:
        fr = mr.raw("frequency_rel", types=(int, float, list))
        vals = fr if isinstance(fr, list) else [fr]
        if not vals or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v < 1.0
                           for v in vals):
            mr.fail("frequency_rel", f"expected a relative uncertainty in [0, 1) or a list of them, got {fr!r}")
        model_form = ModelFormDeclared(tuple(float(v) for v in vals), mr.str("source"))
        mr.done()

    reference = dict(top.raw("reference", {}, types=(dict,)))
    for key, fname in reference.items():
        if not isinstance(fname, str):
            top.fail(f"reference.{key}", f"expected a file name, got {fname!r}")
        reference[key] = _reference_file(file, f"reference.{key}", fname, path, allow_outside)
    masters: dict[str, tuple[tuple[int, str], ...]] = {}
    rr = top.sub("reduction", None)
    if rr is not None:
        rr.str("source")
        for key in [k for k in rr.table if k != "source"]:
            if key not in ("exact", "guyan"):
                rr.fail(key, "unknown reduction; use 'exact' or 'guyan'")
            labels = []
            for item in rr.raw(key, types=(list,)):
                if (not isinstance(item, list) or len(item) != 2 or not isinstance(item[0], int)
                        or item[1] not in DOF_NAMES):
                    rr.fail(key, f"expected [point, dof] pairs, got {item!r}")
                if item[0] not in points:
                    rr.fail(key, f"unknown point id {item[0]}; points are {sorted(points)}")
                labels.append((item[0], item[1]))
            masters[key] = tuple(labels)
        rr.done()
    mj = dict(top.raw("mujoco", {}, types=(dict,)))
    top.raw("calibration", {}, types=(dict,))
    test = _test_table(top.sub("test", None), instr, points)
    design = _design_table(top.sub("design", None))
    changes = {name: top.raw(name, [], types=(list,)) for name in CHANGE_TABLES}
    top.done()

    ids = [m.id for m in members]
    if len(set(ids)) != len(ids):
        raise SpecError(f"{file}: field 'members': duplicate member ids {ids}")
    spec = StructureSpec(
        name=name,
        title=title,
        path=path,
        active_dofs=active,
        gravity_direction=grav,
        points=points,
        sections=sections,
        members=tuple(members),
        strings=tuple(strings),
        masses=tuple(masses),
        crosspieces=tuple(crosspieces),
        springs=tuple(springs),
        supports=tuple(supports),
        instrumentation=instr,
        damping=damping,
        model_form=model_form,
        reference=reference,
        master_dofs=masters,
        mujoco=mj,
        test=test,
        design_settings=design,
        raw=doc,
    )
    base = None
    if added or changes["member_stiffness"] or changes["joint_flexibility"]:  # the structure before the changes
        base = spec.replace(
            masses=tuple(m for i, m in enumerate(masses) if ("masses", i) not in added),
            springs=tuple(sp for i, sp in enumerate(springs) if ("springs", i) not in added),
            supports=release_supports(built, [r for r in released if ("springs", r[0]) not in added], fail_release))
    return damping_of(apply_change_tables(spec, changes, lambda t, where: _Reader(file, t, where)), base)


def _number(r: _Reader, key: str, default: Any = ..., *, low: float = 0.0, low_open: bool = True,
            high: float = math.inf, high_open: bool = False) -> float:
    """A finite real number of table ``r`` within (low, high), as a float; SpecError naming the field."""
    v = r.raw(key, default, types=(int, float))
    if isinstance(v, bool) or not math.isfinite(v):
        r.fail(key, f"expected a finite number, got {v!r}")
    if v < low or (low_open and v == low) or v > high or (high_open and v == high):
        r.fail(key, f"must lie in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}, got {v!r}")
    return float(v)


def _points_list(r: _Reader, key: str, points: dict, default: Any = ...) -> tuple[int, ...]:
    """A list of known, distinct point ids (SpecError naming the field and the bad id)."""
    ids = r.raw(key, default, types=(list, tuple))
    if ids is default:
        return tuple(ids)  # the caller's default (already checked)
    for pid in ids:
        if not isinstance(pid, int) or isinstance(pid, bool) or pid not in points:
            r.fail(key, f"unknown point id {pid!r}; points are {sorted(points)}")
    if len(set(ids)) != len(ids):
        r.fail(key, f"repeated point ids in {list(ids)}")
    return tuple(ids)


def _test_table(r: _Reader | None, instr: Instrumentation | None, points: dict) -> StructureTest | None:
    """The ``[test]`` table (Sec. 5.4): band and resolution [Hz], force RMS [N], modes, points, quantity.

    ``response_point`` defaults to the instrumentation's response point and
    ``measured_points`` to its sensors; the table needs ``[instrumentation]``
    (the excitation point and the actuators come from there).
    """
    if r is None:
        return None
    r.str("source")
    if instr is None:
        r.fail("", "a [test] table needs an [instrumentation] table (actuators, sensors, excitation point)")
    band = r.raw("band_hz", types=(list,))
    if (len(band) != 2 or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
                                  for x in band) or not 0 <= band[0] < band[1] <= MAX_TEST_BAND_HZ):
        r.fail("band_hz", f"expected [low, high] with 0 <= low < high <= {MAX_TEST_BAND_HZ:g} Hz, got {band!r}")
    res = _number(r, "resolution_hz")
    if res > (band[1] - band[0]) / 4:
        r.fail("resolution_hz", f"{res:g} Hz leaves fewer than 4 lines in the band {band!r} Hz")
    rms = _number(r, "rms_n", high=1e4)
    n_modes = r.int("n_modes")
    if n_modes < 1:
        r.fail("n_modes", f"must be >= 1, got {n_modes}")
    resp = r.int("response_point", instr.response)
    if resp not in points:
        r.fail("response_point", f"unknown point id {resp}; points are {sorted(points)}")
    measured = _points_list(r, "measured_points", points, instr.sensors)
    if resp not in set(measured) | set(instr.actuators):
        r.fail("response_point", f"point {resp} is neither measured {list(measured)} nor an actuator "
                                 f"{list(instr.actuators)}: its FRF would not be recorded")
    quantity = r.str("response_quantity", "velocity")
    if quantity not in RESPONSE_QUANTITIES:
        r.fail("response_quantity", f"{quantity!r} is not one of {RESPONSE_QUANTITIES}")
    r.done()
    return StructureTest((float(band[0]), float(band[1])), res, rms, n_modes, resp, measured, quantity)


def _design_table(r: _Reader | None) -> dict[str, Any]:
    """The ``[design]`` table: the keys of :data:`DESIGN_FIELDS`, type- and range-checked (all optional)."""
    if r is None:
        return {}
    r.str("source")
    out: dict[str, Any] = {}
    for key, types in DESIGN_FIELDS.items():
        if not r.has(key):
            continue
        if types is int:
            v = r.int(key)
            if v < 1:
                r.fail(key, f"must be >= 1, got {v}")
        elif types is str:
            v = r.str(key)
            if v not in ("full", "exact", "guyan"):
                r.fail(key, f"{v!r} is not one of full, exact, guyan")
        elif key == "zeta_min":
            v = _number(r, key, high=1.0, high_open=True)
        elif key == "alpha":
            v = _number(r, key, low_open=False)
        else:
            v = _number(r, key)
        out[key] = v
    r.done()
    return out


def _mass_per_length(r: _Reader) -> Quantity:
    """Mass per length of a string from its diameter and density (SI)."""
    d = r.quantity("diameter", "length")
    rho = r.quantity("density", "density")
    count = r.int("count", 1)
    if count < 1:
        r.fail("count", f"must be >= 1, got {count}")
    return Quantity(
        count * rho.si * math.pi * d.si**2 / 4.0,
        f"{count} x pi d^2/4 x density ({d.source}; {rho.source})",
    )


_COLLECTIONS = ("strings", "masses", "crosspieces", "springs")


def structure_identity(spec: StructureSpec) -> str:
    """SHA-256 (hex) of the structure's definition: its parsed document in a canonical form.

    Comments, layout and the order of keys do not count; every value, unit and source does. A spec
    built in code (no document) is identified by its ``repr``. A diagnosis stores it
    (``structure_sha256``) so that ``vlab update`` refuses to apply it to another structure.

    Parameters
    ----------
    spec : StructureSpec

    Returns
    -------
    str
        64 hex digits.
    """
    import hashlib
    import json

    text = json.dumps(spec.raw, sort_keys=True, default=str) if spec.raw else repr(spec)
    return hashlib.sha256(text.encode()).hexdigest()


def with_quantity(spec: StructureSpec, path: str, value_si: float, source: str | None = None) -> StructureSpec:
    """Return a copy of ``spec`` with one quantity changed.

    Parameters
    ----------
    spec : StructureSpec
    path : str
        ``"<collection>.<id>.<field>"`` with collection one of strings, masses,
        crosspieces, springs (e.g. ``"strings.bottom_cables.tension"``), or
        ``"sections.<name>.<field>"`` for ``ei``, ``gj``, ``shear_stiffness``.
    value_si : float
        New value in SI.
    source : str, optional
        New provenance; defaults to the old one.

    Returns
    -------
    StructureSpec
        A new spec; ``spec`` is unchanged.

    Raises
    ------
    SpecError
        If the path names no quantity of the spec.
    """
    parts = path.split(".")
    if len(parts) != 3:
        raise SpecError(f"{spec._file()}: quantity path {path!r} must be '<collection>.<id>.<field>'")
    coll, ident, fld = parts

    def new_q(old: Any) -> Quantity:
        if not isinstance(old, Quantity):
            raise SpecError(f"{spec._file()}: {path!r} is not a quantity")
        return Quantity(float(value_si), source if source is not None else old.source)

    if coll == "sections":
        if ident not in spec.sections:
            raise SpecError(f"{spec._file()}: {path!r}: unknown section {ident!r}")
        sec = spec.sections[ident]
        if fld not in ("ei", "gj", "shear_stiffness"):
            raise SpecError(f"{spec._file()}: {path!r}: only ei, gj, shear_stiffness can be changed")
        old = getattr(sec, fld)
        q = new_q(old) if old is not None else Quantity(float(value_si), source or "modified")
        secs = dict(spec.sections)
        secs[ident] = dataclasses.replace(sec, **{fld: q})
        return spec.replace(sections=secs)
    if coll not in _COLLECTIONS:
        raise SpecError(f"{spec._file()}: {path!r}: unknown collection {coll!r}; use {_COLLECTIONS + ('sections',)}")
    items = list(getattr(spec, coll))
    for i, item in enumerate(items):
        if item.id == ident:
            if not hasattr(item, fld):
                raise SpecError(f"{spec._file()}: {path!r}: {coll} have no field {fld!r}")
            items[i] = dataclasses.replace(item, **{fld: new_q(getattr(item, fld))})
            return spec.replace(**{coll: tuple(items)})
    raise SpecError(f"{spec._file()}: {path!r}: no {coll} with id {ident!r}")
