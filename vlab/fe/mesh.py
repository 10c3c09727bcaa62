"""Mesh: the spec's members cut into beam elements, shared by statics and dynamics."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ModelError
from ..spec import StructureSpec
from .dofmap import Node


@dataclass(frozen=True)
class Element:
    """One beam element between two nodes.

    ``offsets`` are the rigid-insert lengths [m] at node a and node b; the
    flexible length is ``length - offsets[0] - offsets[1]``.

    Attributes
    ----------
    member : str
        Id of the member it belongs to.
    a, b : Node
        End nodes: a point id (int) or a generated interior label (str).
    section : str
        Name of its section in ``StructureSpec.sections``.
    length : float
        Node-to-node length [m], rigid inserts included.
    direction : (float, float)
        Unit vector of the element axis in the plane (x, y), from ``a`` to ``b``.
    offsets : (float, float)
        Rigid-insert lengths [m] at ``a`` and ``b`` (Sec. 2.1.1).
    """

    member: str
    a: Node
    b: Node
    section: str
    length: float
    direction: tuple[float, float]
    offsets: tuple[float, float]

    @property
    def flexible_length(self) -> float:
        """Length between the rigid inserts [m]."""
        return self.length - self.offsets[0] - self.offsets[1]


@dataclass(frozen=True)
class Mesh:
    """Nodes (point ids and generated interior nodes) and elements.

    Attributes
    ----------
    nodes : dict[Node, (float, float)]
        Node -> coordinates (x, y) [m]; the spec's points first, then the
        interior nodes ``"<member>.<segment>.<k>"``.
    elements : tuple of Element
        All elements, member by member, along each member.
    """

    nodes: dict[Node, tuple[float, float]]
    elements: tuple[Element, ...]


def build_mesh(spec: StructureSpec) -> Mesh:
    """Cut every member of ``spec`` into elements.

    Interior nodes of a segment subdivided into ``n`` elements are named
    ``"<member>.<segment>.<k>"``.

    Parameters
    ----------
    spec : StructureSpec
        Points, members and their rigid inserts.

    Returns
    -------
    Mesh

    Raises
    ------
    ModelError
        If two consecutive member points coincide or rigid inserts leave no
        flexible length.
    """
    nodes: dict[Node, tuple[float, float]] = dict(spec.points)
    elements: list[Element] = []
    for mem in spec.members:
        inserts = {ri.point: ri.length.si for ri in mem.rigid_inserts}
        for seg, (pa, pb) in enumerate(zip(mem.points[:-1], mem.points[1:])):
            (xa, ya), (xb, yb) = spec.points[pa], spec.points[pb]
            length = math.hypot(xb - xa, yb - ya)
            if length == 0.0:
                raise ModelError(f"member {mem.id!r}: points {pa} and {pb} coincide")
            e = ((xb - xa) / length, (yb - ya) / length)
            n = mem.elements_per_segment
            chain: list[Node] = [pa]
            for k in range(1, n):
                label = f"{mem.id}.{seg}.{k}"
                nodes[label] = (xa + (xb - xa) * k / n, ya + (yb - ya) * k / n)
                chain.append(label)
            chain.append(pb)
            for a, b in zip(chain[:-1], chain[1:]):
                off = (inserts.get(a, 0.0) if isinstance(a, int) else 0.0,
                       inserts.get(b, 0.0) if isinstance(b, int) else 0.0)
                el = Element(mem.id, a, b, mem.section, length / n, e, off)
                if el.flexible_length <= 0.0:
                    raise ModelError(
                        f"member {mem.id!r}: rigid inserts {off} leave no flexible length "
                        f"between {a} and {b}"
                    )
                elements.append(el)
    return Mesh(nodes, tuple(elements))
