"""The weights of a ``[design]`` table in SI and in the thesis units, and the matrices Q and V1 they make.

The designs are made in the dissertation's unit system (Sec. 3.1: in, lbf, time unit cs), where
``Q = q_scale I`` weighs the states ``x = [q'; q]`` in in/cs, rad/cs, in, rad, ``R = r I`` the forces in
lbf (Eq. 4.1), ``V1 = v1 I`` is the intensity of a white noise driving every state's equation, ``V2 = v2 I``
that of the noise on the sensors' velocities in in/cs (Eqs. 4.8-4.10), and ``alpha`` is in 1/cs. A
structure file of one's own may give them in SI (``units = "SI"`` in ``[design]``:
:data:`vlab.spec.DESIGN_WEIGHTS_SI`), one value per kind of state since the thesis's scalar weights
become diagonal ones in SI (the states' units differ). With ``s`` the SI value of one thesis unit of a
state (:func:`vlab.design.state_scaling`: 0.0254 / 0.01 m/s, 100 rad/s, 0.0254 m, 1 rad) and ``t = 0.01 s``:

* LQ weights: the integrand ``x^T Q x + u^T R u`` keeps its value, ``q_th = q_SI s^2``,
  ``r_th = r_SI lbf^2`` (the cost integral changes by the factor ``t`` only, which leaves the gain alone);
* noise intensities (a white noise ``w`` of intensity ``V``, ``E[w(t) w(t')] = V delta(t - t')``, has
  ``V`` in [w]^2 times time): ``w`` drives ``x'`` so ``w_SI = s w_th / t`` and ``v1_th = v1_SI t / s^2``;
  the measurement noise is a velocity itself, ``v2_th = v2_SI / ((0.0254 / 0.01)^2 t)``;
* ``alpha_th = alpha_SI t``.

Under these maps the Riccati equations of the LQR and of the alpha-shifted Kalman filter in SI are those
of the thesis units transformed by ``x_SI = diag(s) x_th``, so the SI gains are the same
(``tests/test_design_weights_si.py`` checks it against designs made in SI).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..units import CS_S, INCH_M, LBF_N

#: Kinds of state, in the order of :attr:`vlab.design.ThesisSettings.q_by_state` and ``v1_by_state``: the
#: velocities and displacements of translational DOFs (``w``), then the rates and angles of rotational ones.
STATE_KINDS = ("velocity", "displacement", "rotation_rate", "rotation")

#: SI value of one thesis unit of each kind of state: in/cs, in, rad/cs, rad in m/s, m, rad/s, rad.
_STATE_UNIT_SI = {"velocity": INCH_M / CS_S, "displacement": INCH_M, "rotation_rate": 1.0 / CS_S, "rotation": 1.0}

#: Factor from a ``[design]`` weight in SI (:data:`vlab.spec.DESIGN_WEIGHTS_SI`) to its thesis-unit value
#: (Sec. 3.1): ``thesis = SI * factor``. See the module's text for the derivation.
SI_TO_THESIS: dict[str, float] = {
    **{f"q_{k}": s ** 2 for k, s in _STATE_UNIT_SI.items()},
    **{f"v1_{k}": CS_S / s ** 2 for k, s in _STATE_UNIT_SI.items()},
    "r": LBF_N ** 2, "r_corrected": LBF_N ** 2,
    "v2": 1.0 / ((INCH_M / CS_S) ** 2 * CS_S),
    "alpha": CS_S,
}


def thesis_weights(given: dict[str, Any], units: str | None, base) -> dict[str, Any]:
    """The weights of a ``[design]`` table as fields of :class:`vlab.design.ThesisSettings` (thesis units).

    Parameters
    ----------
    given : dict
        The table's weights as read (:func:`vlab.spec.settings.read_design`), in ``units``.
    units : {"SI", "thesis"} or None
        The table's ``units`` (None: no weight given).
    base : ThesisSettings
        The settings the table overrides: a kind of state the SI table leaves out keeps its weight there.

    Returns
    -------
    dict
        Field -> value: ``q_scale``, ``r``, ``v1``, ``v2``, ``alpha``, ``r_corrected`` as given (thesis);
        from SI ``q_by_state``/``v1_by_state`` (per :data:`STATE_KINDS`, thesis units) where a ``q_*``/``v1_*``
        key is given and the other keys converted by :data:`SI_TO_THESIS`; always ``weights_units``.

    Raises
    ------
    ValueError
        A key that is no weight of ``units`` (:func:`vlab.spec.settings.read_design` refuses it before).
    """
    out: dict[str, Any] = {"weights_units": units}
    if units != "SI":
        if given and units != "thesis":
            raise ValueError(f"weights {sorted(given)} without units")
        return {**out, **given}
    for name in ("q", "v1"):
        keys = [f"{name}_{k}" for k in STATE_KINDS]
        if any(k in given for k in keys):
            old = getattr(base, f"{name}_by_state") or (getattr(base, "q_scale" if name == "q" else "v1"),) * 4
            out[f"{name}_by_state"] = tuple(given[k] * SI_TO_THESIS[k] if k in given else o
                                            for k, o in zip(keys, old))
    for key, value in given.items():
        if key.startswith(("q_", "v1_")):
            continue
        if key not in SI_TO_THESIS:
            raise ValueError(f"{key!r} is no SI weight")
        out[key] = value * SI_TO_THESIS[key]
    return out


def _kinds(labels) -> list[str]:
    """The kind (:data:`STATE_KINDS`) of each state ``[q'; q]`` of a model with DOF ``labels``."""
    n = [("velocity", "displacement") if dof == "w" else ("rotation_rate", "rotation") for _p, dof in labels]
    return [v for v, _d in n] + [d for _v, d in n]


def _diagonal(scale: float, by_state, labels) -> np.ndarray:
    """``scale I``, or the diagonal of ``by_state`` per kind of state, shape (2 n_d, 2 n_d)."""
    if by_state is None:
        return scale * np.eye(2 * len(labels))
    w = dict(zip(STATE_KINDS, by_state))
    return np.diag([w[k] for k in _kinds(labels)])


def state_weight(st, labels) -> np.ndarray:
    """The LQ state weight ``Q`` (Eq. 4.1) of settings ``st`` on a model with DOF ``labels`` (thesis units).

    Parameters
    ----------
    st : ThesisSettings
    labels : sequence of (node, dof), length n_d
        DOF labels; ``"w"`` is a translation, any other dof a rotation.

    Returns
    -------
    ndarray, shape (2 n_d, 2 n_d)
        ``q_scale I``, or diagonal with ``st.q_by_state`` per kind of state (per (in/cs)^2, in^2,
        (rad/cs)^2, rad^2).
    """
    return _diagonal(st.q_scale, st.q_by_state, labels)


def process_noise(st, labels) -> np.ndarray:
    """The Kalman filter's state excitation intensity ``V1`` (Eq. 4.9) of ``st`` on DOF ``labels`` (thesis).

    Parameters
    ----------
    st : ThesisSettings
    labels : sequence of (node, dof), length n_d

    Returns
    -------
    ndarray, shape (2 n_d, 2 n_d)
        ``v1 I``, or diagonal with ``st.v1_by_state`` per kind of state.
    """
    return _diagonal(st.v1, st.v1_by_state, labels)


def weights_si(st) -> dict[str, float | None]:
    """The weights of settings ``st`` in SI, keyed as a ``units = "SI"`` ``[design]`` table writes them.

    Parameters
    ----------
    st : ThesisSettings

    Returns
    -------
    dict
        :data:`vlab.spec.DESIGN_WEIGHTS_SI`'s keys -> value in its SI unit (``r_corrected`` None if unset).
    """
    q = st.q_by_state or (st.q_scale,) * 4
    v1 = st.v1_by_state or (st.v1,) * 4
    out: dict[str, float | None] = {}
    for k, qk, vk in zip(STATE_KINDS, q, v1):
        out[f"q_{k}"] = qk / SI_TO_THESIS[f"q_{k}"]
        out[f"v1_{k}"] = vk / SI_TO_THESIS[f"v1_{k}"]
    for key in ("r", "v2", "alpha"):
        out[key] = getattr(st, key) / SI_TO_THESIS[key]
    out["r_corrected"] = None if st.r_corrected is None else st.r_corrected / SI_TO_THESIS["r_corrected"]
    return out
