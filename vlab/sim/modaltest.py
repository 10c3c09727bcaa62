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
from ..fe import FEModel
from ..spec import StructureSpec
from .builder import build_plant
from .linearize import modes as plant_modes
from .linearize import settle, site_jacobian_w
from .pairing import BAND_MARGIN, pair_band


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


def virtual_measured_modes(fe: FEModel) -> tuple[np.ndarray, np.ndarray]:
    """Measured modes for the corrected Guyan model when the user gives none (Secs. 3.3, 5.4.1).

    Shapes: :func:`virtual_modal_test` on the MuJoCo plant at the Guyan
    masters, each plant mode paired with an FE mode by MAC at the masters,
    one-to-one over a common band (:func:`vlab.sim.pairing.pair_band`: the
    plant has modes the FE model does not, e.g. the BCC crosspiece arms'
    antisymmetric bending, so order alone would mispair, and FE modes just
    above the measured ones take part so that their partners are not taken). Frequencies: the
    published experimental ones (Table 3 for the grid, Table 1 for the BCC).
    Like the dissertation (eleven of the grid's twelve), one mode fewer than
    masters is used, so the highest reduced frequency shows the correction's
    effect on an unmeasured mode.

    Parameters
    ----------
    fe : FEModel
        The nominal FE model; its spec names the Guyan masters and the
        reference frequency table.

    Returns
    -------
    freq_hz : ndarray, shape (n_m,)
        Published experimental frequencies [Hz] of FE modes 1..n_m.
    shapes : ndarray, shape (n_masters, n_m)
        Plant shapes at the masters [m or rad, arbitrary scale].

    Raises
    ------
    SimulationError
        An FE mode with no plant mode of MAC >= 0.5, or a plant that cannot be
        built, settled or measured.
    ModelError
        Masters the FE model does not have.
    DataFileError
        A missing reference table.
    """
    from ..fe import modal_analysis
    from ..models import master_indices
    from ..reference import column

    idx = master_indices(fe, "guyan")
    labels = [fe.dofs.labels[i] for i in idx]
    f_exp = column(fe.spec.reference["frequencies"], "experimental_hz")
    n_m = min(len(f_exp), len(idx) - 1)
    fem = modal_analysis(fe.m, fe.k)
    # plant modes up to the top of the pairing band (pair_band: (1 + margin)^2 x FE mode n_m), and a few more
    f_band = (1.0 + BAND_MARGIN) ** 2 * float(fem.frequencies_hz[n_m - 1])
    n_plant = n_m + 4
    while True:
        f_plant, plant_shapes = virtual_modal_test(fe.spec, labels, n_plant)
        if f_plant.size < n_plant or f_plant[-1] > f_band:
            break
        n_plant *= 2
    bp = pair_band(fem.frequencies_hz, fem.shapes[idx, :], f_plant, plant_shapes, n_m)
    pairs = bp.fe_to_sim[:n_m]
    missing = [r + 1 for r, j in enumerate(pairs) if j is None]
    if missing:
        raise SimulationError(f"{fe.spec.name}: FE modes {missing} have no plant mode with MAC >= 0.5 at the "
                              "Guyan masters: the virtual modal test cannot stand in for the measured shapes")
    return f_exp[:n_m], plant_shapes[:, list(pairs)]
