"""The plan of a MuJoCo plant: its bodies, joints, sites and constraints, before any MjSpec exists.

:func:`vlab.sim.planner.plan_structure` fills a :class:`Plan` from a spec;
:func:`vlab.sim.emit.build_mjspec` emits it into an :class:`mujoco.MjSpec`.
Every position here is in world coordinates (the structure's plane is the
world's x-y plane, ``w`` the world z). A body's inertia is the sum of its
rigid mass items (:class:`Item`: bar pieces, point masses), combined by the
parallel-axis theorem (:func:`combine_items`).

Source: parallel-axis theorem and the inertia of a slender rectangular bar
(e.g. Meriam & Kraige, *Engineering Mechanics: Dynamics*, Appendix B).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SimulationError

#: Rotation axes of the out-of-plane rotations ``rx`` and ``ry`` (world).
AXIS = {"rx": np.array([1.0, 0.0, 0.0]), "ry": np.array([0.0, 1.0, 0.0])}
#: The out-of-plane direction (world z): the axis of ``w``.
Z_AXIS = np.array([0.0, 0.0, 1.0])


@dataclass
class Item:
    """A rigid mass item, world coordinates.

    Attributes
    ----------
    mass : float
        [kg].
    com : ndarray, shape (3,)
        Its centre (world) [m].
    inertia : ndarray, shape (3, 3)
        Inertia about the centre, world axes [kg m^2].
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass
class Joint:
    """A joint of a planned body.

    Attributes
    ----------
    name : str
        The joint's name in the model.
    kind : str
        ``"hinge"`` (about ``axis``) or ``"slide"`` (along it).
    axis : ndarray, shape (3,)
        Unit axis (world).
    pos : ndarray, shape (3,)
        Its position (world) [m].
    stiffness : float
        Spring stiffness [N/m or N*m/rad].
    elastic : bool
        A hinge spring of the discretisation (it gets the hinge damping ``beta k``).
    info : str
        Where it comes from (the model's ``info``).
    armature : float
        Inertia added along the joint only [kg or kg m^2].
    """

    name: str
    kind: str  # "hinge" | "slide"
    axis: np.ndarray
    pos: np.ndarray  # world
    stiffness: float = 0.0
    elastic: bool = False  # a hinge spring of the discretisation (gets beta damping)
    info: str = ""
    armature: float = 0.0  # inertia added along the joint only [kg or kg m^2]


@dataclass
class Visual:
    """A geometry drawn for a body (no contact, no mass).

    Attributes
    ----------
    kind : str
        ``"box"`` or ``"sphere"``.
    pos : ndarray, shape (3,)
        Its centre (world) [m].
    size : tuple of float
        Half sizes of a box, radius of a sphere [m].
    angle : float
        Rotation about z [rad].
    rgba : tuple of float
        Colour.
    """

    kind: str  # "box" | "sphere"
    pos: np.ndarray
    size: tuple[float, ...]
    angle: float = 0.0  # rotation about z [rad]
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.65, 1.0)


@dataclass
class Body:
    """A planned body.

    Attributes
    ----------
    name : str
        The body's name in the model.
    origin : ndarray, shape (3,)
        World position of its frame (axes = world axes) [m].
    parent : str or None
        Its parent body (None: the world), planned before it.
    info : str
        Where it comes from (the model's ``info``).
    joints : list of Joint
    items : list of Item
        Its mass items (:func:`combine_items` gives its inertia).
    sites : list of (str, ndarray, str)
        Name, world position [m] and info of each site.
    visuals : list of Visual
    """

    name: str
    origin: np.ndarray  # world position of the body frame (axes = world axes)
    parent: str | None  # None = world
    info: str
    joints: list[Joint] = field(default_factory=list)
    items: list[Item] = field(default_factory=list)
    sites: list[tuple[str, np.ndarray, str]] = field(default_factory=list)
    visuals: list[Visual] = field(default_factory=list)


@dataclass
class Plan:
    """What :func:`vlab.sim.emit.build_mjspec` emits (see :mod:`vlab.sim.planner` on the topologies).

    Attributes
    ----------
    bodies : dict of str to Body
        Every body, parent before child.
    junction : dict of int to str
        Point id -> the body of its junction.
    world_sites : list of (str, ndarray, str)
        Sites on the world: name, position [m], info.
    strings : list of tuple
        ``(name, world site, body site, k [N/m], tension [N], info)`` of each string.
    welds, connects : list of tuple
        ``(name, site1, site2, info)`` of each weld / connect equality.
    prestress : list of tuple
        ``(name, site, refsite, wrench (6,) [N, N m], info)`` of each constant in-plane load.
    n_loops : int
        Independent loops of the structure.
    closures : list of tuple
        Linear closures of the forest topology: ``(name, site on the stub, site on
        the junction, DOFs to equate, info)``.
    topology : str
        ``"tree"`` or ``"forest"``.
    """

    bodies: dict[str, Body]
    junction: dict[int, str]  # point -> body name
    world_sites: list[tuple[str, np.ndarray, str]]
    strings: list[tuple[str, str, str, float, float, str]]  # name, world site, body site, k, tension, info
    welds: list[tuple[str, str, str, str]]  # name, site1, site2, info
    connects: list[tuple[str, str, str, str]]  # name, site1, site2 (world), info
    prestress: list[tuple[str, str, str, np.ndarray, str]]  # name, site, refsite, wrench (6), info
    n_loops: int
    #: linear closures (forest topology): name, site on the stub, site on the junction, DOFs to equate, info
    closures: list[tuple[str, str, str, tuple[str, ...], str]] = field(default_factory=list)
    topology: str = "tree"


def p3(xy: tuple[float, float]) -> np.ndarray:
    """The world position of a point of the plane.

    Parameters
    ----------
    xy : tuple of float
        In-plane coordinates ``(x, y)`` [m].

    Returns
    -------
    ndarray, shape (3,)
        ``(x, y, 0)`` [m].
    """
    return np.array([xy[0], xy[1], 0.0])


def rod(p0: np.ndarray, p1: np.ndarray, rho_a: float, rho_ip: float, width: float, thick: float) -> Item:
    """Mass item of a straight bar piece from ``p0`` to ``p1``.

    Parameters
    ----------
    p0, p1 : ndarray, shape (3,)
        Its ends (world) [m], distinct.
    rho_a : float
        Mass per length [kg/m].
    rho_ip : float
        Rotary inertia per length about the bar's axis [kg m].
    width : float
        Section width in the plane [m].
    thick : float
        Section thickness out of the plane [m].

    Returns
    -------
    Item
        Mass ``rho_a l``, centre at the middle, inertia ``rho_ip l`` about the
        axis and ``m (l^2 + t^2) / 12``, ``m (l^2 + b^2) / 12`` about the
        section's axes (slender-bar inertia).
    """
    d = p1 - p0
    length = float(np.linalg.norm(d))
    e = d / length
    n = np.array([-e[1], e[0], 0.0])
    m = rho_a * length
    local = np.diag([rho_ip * length, m * (length**2 + thick**2) / 12.0, m * (length**2 + width**2) / 12.0])
    r = np.column_stack([e, n, Z_AXIS])
    return Item(m, 0.5 * (p0 + p1), r @ local @ r.T)


def point_mass(p: np.ndarray, mass: float, irx: float = 0.0, iry: float = 0.0) -> Item:
    """Mass item of a lumped mass at ``p``.

    Parameters
    ----------
    p : ndarray, shape (3,)
        Its position (world) [m].
    mass : float
        Mass [kg].
    irx, iry : float
        Rotary inertias about the world x and y axes [kg m^2] (about z their sum).

    Returns
    -------
    Item
    """
    return Item(mass, p.copy(), np.diag([irx, iry, irx + iry]))


def combine_items(items: list[Item], origin: np.ndarray, name: str) -> tuple[float, np.ndarray, np.ndarray]:
    """Total mass, centre relative to ``origin`` and inertia about the centre of a list of items.

    Parameters
    ----------
    items : list of Item
        The body's mass items (world coordinates).
    origin : ndarray, shape (3,)
        The body frame's world origin [m].
    name : str
        The body's name, for the error.

    Returns
    -------
    mass : float
        [kg].
    com : ndarray, shape (3,)
        Centre of mass relative to ``origin`` [m].
    inertia : ndarray, shape (3, 3)
        Inertia about the centre [kg m^2] (parallel-axis theorem), kept
        strictly positive definite by a floor of ``1e-12 + 1e-9 trace``.

    Raises
    ------
    SimulationError
        A body without mass.
    """
    mass = sum(it.mass for it in items)
    if not mass > 0.0:
        raise SimulationError(f"body {name!r} has no mass: every moving body needs inertia")
    com = sum(it.mass * it.com for it in items) / mass
    inertia = np.zeros((3, 3))
    for it in items:
        r = it.com - com
        inertia += it.inertia + it.mass * (np.dot(r, r) * np.eye(3) - np.outer(r, r))
    # keep strictly positive definite (a point mass alone has zero inertia)
    floor = 1e-12 + 1e-9 * max(np.trace(inertia), 0.0)
    inertia += floor * np.eye(3)
    return mass, com - origin, inertia
