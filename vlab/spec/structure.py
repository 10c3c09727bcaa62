"""The dataclasses of a structure definition: :class:`vlab.spec.StructureSpec` and its parts, SI inside.

A :class:`vlab.spec.StructureSpec` is read from ``assets/structures/<name>.toml`` by
:func:`vlab.spec.load_spec`; the FE model (:mod:`vlab.fe`) and the MuJoCo
plant (:mod:`vlab.sim`) are both built from it. Every physical value is a
:class:`vlab.spec.Quantity`: its SI value and its source (a section or table of the
dissertation, ``"assumed: <reason>"`` or ``"calibrated: <data>"``).

Coordinates: the structure lies in the plane (x, y), y up; ``w`` is the
out-of-plane (z) translation, ``rx``/``ry`` the rotations about x and y.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import SpecError

DOF_NAMES = ("w", "rx", "ry")

#: Folder of the shipped structure definitions and published tables.
ASSETS_DIR = Path(__file__).resolve().parent.parent.parent / "assets"
STRUCTURES_DIR = ASSETS_DIR / "structures"
DATA_DIR = ASSETS_DIR / "data"


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
        Name of its :class:`vlab.spec.Section` in ``StructureSpec.sections``.
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

    ``tension`` is a :class:`vlab.spec.Quantity` or None when the string is a support
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
        Name of the arms' :class:`vlab.spec.Section` (EI 2680 lb-in^2, Sec. 2.1).
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




@dataclass(frozen=True)
class StructureTest:
    """How a structure is tested (Sec. 5.4): band, resolution, levels, points.

    The shipped structures' tests are :data:`vlab.experiment.config.TESTS`; any
    structure file may carry its own in a ``[test]`` table
    (:func:`vlab.experiment.config.test_definition` picks one).

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
        (segments, timestep, ...; see :class:`vlab.sim.options.SimOptions`).
    test : StructureTest or None
        The ``[test]`` table (band, resolution, points of the modal test,
        Sec. 5.4); None = the shipped test of a structure of that name, if any
        (:func:`vlab.experiment.config.test_definition`).
    design_settings : dict[str, Any]
        The ``[design]`` table: controller-design settings (keys of
        :data:`vlab.spec.DESIGN_FIELDS`), checked for type and range;
        :func:`vlab.design.design_settings` fills the rest with defaults.
    hardware : Hardware or None
        The ``[hardware]`` table: per-channel actuator and sensor gains, delays and lags
        (:mod:`vlab.spec.hardware`); None = the ideal channels.
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
    hardware: Any = None
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
