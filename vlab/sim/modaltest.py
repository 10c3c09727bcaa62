"""A virtual modal test on the MuJoCo plant (Sec. 5.4.1).

The dissertation measured the grid's mode shapes with velocity sensors at the
twelve joints and displacement probes under the pendulum plates, "divided by
the distance to the rotational axis of the top beam producing data in the
rotational DOF at that point". This module does the same on the plant: the
settled, linearised MuJoCo model's modes are read at the requested points (w)
and, for rotational DOFs of the bearing points, at the plate sites divided by
their distance below the axis.
"""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from ..spec import StructureSpec
from .builder import build_plant
from .linearize import modes as plant_modes
from .linearize import settle, site_jacobian_w


def virtual_modal_test(
    spec: StructureSpec, dofs: list[tuple[int, str]], n_modes: int
) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and shapes of the plant's first modes at the given DOFs.

    Parameters
    ----------
    spec : StructureSpec
        The structure (its plant is built with the default options).
    dofs : list of (point, dof)
        ``(p, "w")`` for a translation at point p; ``(p, "rx")`` for the rotation
        at a bearing point p with a pendulum plate (site ``pendulum<p>.plate``).
    n_modes : int
        Number of lowest modes.

    Returns
    -------
    freq_hz : ndarray, shape (n_modes,)
        Natural frequencies of the plant [Hz].
    shapes : ndarray, shape (len(dofs), n_modes)
        Real shapes at ``dofs`` [m or rad, arbitrary scale].

    Raises
    ------
    SimulationError
        If a rotational DOF has no plate site, or the plant cannot be built or settled.

    Source: Sec. 5.4.1 (modal test procedure).
    """
    plant = build_plant(spec)
    model = plant.model
    data = settle(model)
    sm = plant_modes(model, list(spec.points), n_modes, data=data)
    rows = []
    for p, d in dofs:
        if d == "w":
            jac = site_jacobian_w(model, data, [f"p{p}"])
        else:
            name = f"pendulum{p}.plate"
            try:
                sid = model.site(name).id
            except KeyError:
                raise SimulationError(f"no plate site {name!r} to measure {d}@{p} as in Sec. 5.4.1") from None
            y = data.site_xpos[model.site(f"p{p}").id, 1] - data.site_xpos[sid, 1]
            if abs(y) < 1e-6:
                raise SimulationError(f"plate site {name!r} lies on the rotation axis: cannot measure {d}@{p}")
            # a plate hanging a distance y below the axis moves w = -y * rx (rotation about +x)
            jac = -site_jacobian_w(model, data, [name]) / y
        rows.append(jac[0])
    shapes = np.array(rows) @ sm.joint_shapes
    return np.asarray(sm.frequencies_hz), shapes
