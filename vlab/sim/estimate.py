"""Time and memory of building a MuJoCo plant, estimated from its plan before it is built.

Building a plant is dominated by dense ``O(n^3)`` linear algebra on its ``n = 2 nv`` states (``nv`` joint
DOFs): the finite-difference linearisation (``mjd_transitionFD``), the eigen-solutions of the modal damping
and of the timestep check, and -- in a cross-check -- the pairing eigen-solutions and the free decay. The
estimate is ``c n^3`` with ``c`` measured on the development machine (:data:`BUILD_S_PER_STATE3`,
:data:`CROSSCHECK_S_PER_STATE3`): a guide to the order of magnitude, shown before a long run and used to
ask for ``--yes``, not a prediction to the second.
"""

from __future__ import annotations

from ..fe.size import dense_bytes

#: Seconds per cubed state of a plant build: measured (calibrated) on the grid at 8 links per element
#: (381 joint DOFs, 762 states) on the development machine (2 cores shared with other work, load 8):
#: 29.4 s; at 16 links per element (1386 states), 79 s (3.0e-8). The slower figure is kept.
BUILD_S_PER_STATE3 = 6.6e-8
#: Seconds per cubed state of a whole ``vlab crosscheck`` (build, pairing with the FE model at both
#: resolutions, free decay of mode 1): 99.7 s for the grid at 8 links per element in the same run as above.
CROSSCHECK_S_PER_STATE3 = 2.25e-7
#: Seconds of a small plant's build or cross-check beside the dense algebra (compilation, imports): the BCC's
#: cross-check (44 states) takes about 1.8 s in all.
BASE_S = 1.5


def plant_estimate(n_joints: int, *, crosscheck: bool = False) -> dict[str, float]:
    """Time and memory of building (or cross-checking) a plant with ``n_joints`` joint DOFs.

    Parameters
    ----------
    n_joints : int
        Joint DOFs of the planned plant (``nv``), >= 0.
    crosscheck : bool
        Estimate a whole ``vlab crosscheck`` rather than the build alone.

    Returns
    -------
    dict of str to float
        ``states`` [1] (``2 nv``), ``time_s`` [s] and ``memory_bytes`` [bytes] (six dense ``n x n`` arrays,
        :func:`vlab.fe.size.dense_bytes`).
    """
    n = 2 * int(n_joints)
    c = CROSSCHECK_S_PER_STATE3 if crosscheck else BUILD_S_PER_STATE3
    return {"states": float(n), "time_s": BASE_S + c * float(n) ** 3, "memory_bytes": dense_bytes(n)}
