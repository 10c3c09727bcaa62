"""The size limit of the dense models vlab builds from a structure's mesh.

The FE model (:mod:`vlab.fe.assembly`) and the in-plane gravity statics (:mod:`vlab.fe.statics`) are dense:
their matrices and solutions hold about six ``n x n`` float64 arrays (48 n^2 bytes). A mesh whose model
would not fit a small machine is refused before any of it is built, naming the sizes.
"""

from __future__ import annotations

from ..errors import ResourceError
from ..spec import StructureSpec

#: Most degrees of freedom of a dense model. 6000 degrees of freedom need 1.7 GB (48 n^2 bytes), the memory
#: of a small machine, and a dense eigen-solution of that size takes minutes on two cores. A chosen limit.
MAX_DOFS = 6000


def dense_bytes(n_dofs: int) -> float:
    """Memory of a dense model with ``n_dofs`` degrees of freedom: six float64 ``n x n`` arrays [bytes]."""
    return 48.0 * n_dofs * n_dofs


def check_dense_size(name: str, n_dofs: int, counts: str, *, what: str, hint: str) -> None:
    """Refuse a dense model of ``n_dofs`` degrees of freedom beyond :data:`MAX_DOFS`, before it is built.

    Parameters
    ----------
    name : str
        The structure's name, first in the message.
    n_dofs : int
        Dimension of the model's dense matrices.
    counts : str
        How ``n_dofs`` arises, e.g. ``"1933 bodies, 2565 joint DOFs x 2 states"``.
    what : str
        The model, e.g. ``"the MuJoCo plant's linearisation"``.
    hint : str
        What makes it smaller.

    Raises
    ------
    ResourceError
        Naming the sizes, the memory the dense model would need and ``hint``.
    """
    if n_dofs > MAX_DOFS:
        raise ResourceError(
            f"{name}: {what} would have about {n_dofs} degrees of freedom ({counts}), more than {MAX_DOFS}: "
            f"its dense matrices and solution need about {dense_bytes(n_dofs) / 1e9:.1f} GB; {hint}")


def check_model_size(spec: StructureSpec, n_nodes: int, *, dofs_per_node: int | None = None,
                     what: str = "the FE model") -> None:
    """Refuse a mesh whose dense model would exceed :data:`MAX_DOFS` degrees of freedom.

    Parameters
    ----------
    spec : StructureSpec
        The structure (its name; its active out-of-plane DOFs per node by default).
    n_nodes : int
        Nodes of its mesh (points and interior nodes).
    dofs_per_node : int, optional
        Degrees of freedom per node of the model checked (default: the spec's active DOFs; the in-plane
        statics has 3).
    what : str
        The model's name in the message, e.g. ``"the in-plane gravity statics"``.

    Raises
    ------
    ResourceError
        Naming the node and DOF counts and the memory the dense model would need.
    """
    per_node = len(spec.active_dofs) if dofs_per_node is None else int(dofs_per_node)
    check_dense_size(spec.name, n_nodes * per_node, f"{n_nodes} nodes x {per_node} DOFs", what=what,
                     hint="use fewer points or a smaller elements_per_segment")
