"""DOF map: which global index belongs to which (node, DOF name).

Nodes are the structure's point ids (int) or generated labels (str) for
interior nodes of subdivided members and for internal DOFs such as the
crosspiece oscillator. DOF names are ``"w"``, ``"rx"``, ``"ry"``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import ModelError

Node = int | str


@dataclass(frozen=True)
class DofMap:
    """Ordered labels of the free DOFs of a model.

    Attributes
    ----------
    labels : tuple of (node, dof)
        ``labels[i]`` is the node and DOF name of global index ``i``.
    """

    labels: tuple[tuple[Node, str], ...]
    _index: dict[tuple[Node, str], int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_index", {lab: i for i, lab in enumerate(self.labels)})
        if len(self._index) != len(self.labels):
            raise ModelError("duplicate DOF labels in DOF map")

    def __len__(self) -> int:
        return len(self.labels)

    def __contains__(self, label: tuple[Node, str]) -> bool:
        return label in self._index

    def index(self, node: Node, dof: str = "w") -> int:
        """Global index of ``(node, dof)``.

        Raises
        ------
        ModelError
            If the node has no such free DOF (unknown point id, constrained or inactive DOF).
        """
        try:
            return self._index[(node, dof)]
        except KeyError:
            nodes = sorted({n for n, _ in self.labels if isinstance(n, int)})
            raise ModelError(
                f"no free DOF {dof!r} at point {node!r} (known points: {nodes})"
            ) from None

    def indices(self, nodes: list[Node] | tuple[Node, ...], dof: str = "w") -> list[int]:
        """Global indices of ``dof`` at each of ``nodes`` (same order). Raises ModelError."""
        return [self.index(n, dof) for n in nodes]

    def name(self, i: int) -> str:
        """Readable name of global DOF ``i``, e.g. ``'w@7'``."""
        node, dof = self.labels[i]
        return f"{dof}@{node}"
