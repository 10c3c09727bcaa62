"""The Hanging Grid's fitted parameters (:data:`GRID_PARAMETERS`) and how they set a grid document.

The pitch scales the lattice, the half-span places the bearings, the plate
width and height give the plate weight, inertias and pendulum springs
(:func:`plate_properties`), the rest set the top beam's section and the joint
and coil masses (:func:`apply_parameters`). Values in thesis units (in, lbf).
"""

from __future__ import annotations

import copy
from typing import Any

from ..errors import ModelError
from ..units import G_IN

#: Plate eccentricity Y [in] (Fig. 5).
PLATE_Y_IN = 9.05

#: Plate thickness [in] (Sec. 2.2: "Large aluminum plates 11/16 inches thick").
PLATE_T_IN = 11.0 / 16.0
#: Weight density of aluminium [lbf/in^3] (handbook).
ALUMINIUM_LBF_IN3 = 0.098

#: Fitted parameters: (name, lower, upper, unit, log-scaled in the optimiser, meaning).
GRID_PARAMETERS: tuple[tuple[str, float, float, str, bool, str], ...] = (
    ("pitch", 6.0, 16.0, "in", False, "lattice pitch a (joint spacing, horizontal and vertical)"),
    ("half_span", 1.03, 2.5, "1", False, "top-beam half-span (13 to the centre) / 3a (3a: outer hangers 15, 20)"),
    ("plate_width", 6.0, 30.0, "in", False, "plate width b (horizontal, normal to the top-beam axis)"),
    ("plate_height", 2.0 * PLATE_Y_IN, 30.0, "in", False, "plate height h (>= 2Y: the axis lies within the plate)"),
    ("top_ei", 1.0e5, 3.0e7, "lbf*in^2", True, "top-beam out-of-plane EI"),
    ("top_gj", 1.0e4, 1.0e7, "lbf*in^2", True, "top-beam GJ"),
    ("top_kga", 1.0e3, 1.0e7, "lbf", True, "top-beam shear stiffness kGA (discontinuous sandwich)"),
    ("top_thickness", 0.2, 1.5, "in", False, "top-beam equivalent steel thickness (mass 1.13 t lbf/in)"),
    ("joint_mass", 0.02, 0.3, "lbf", False, "hardware weight at each of joints 1-12"),
    ("coil_mass", 0.05, 0.5, "lbf", False, "actuator coil weight at joints 1, 2, 4, 5, 8"),
)


def plate_properties(width_in: float, height_in: float) -> tuple[float, float, float]:
    """Weight and inertias of one rigid plate from its assumed geometry.

    A rectangular aluminium plate, ``11/16`` in thick (Sec. 2.2), of width
    ``b`` and height ``h`` in the vertical plane normal to the top-beam axis,
    with its centre of gravity ``Y = 9.05`` in below the axis (Fig. 5). Normal
    to the axis because the calibrated bearings sit only a few inches outboard
    of the outer hangers: a plate tens of inches wide in the grid's own plane
    would run into the hangers; edge-on it clears them.

    Parameters
    ----------
    width_in, height_in : float
        ``b`` (horizontal, normal to the grid) and ``h`` [in].

    Returns
    -------
    weight_lbf : float
        ``W = rho t b h`` [lbf].
    inertia_rx : float
        About the top-beam axis (in the plate's plane),
        ``W/g ((b^2 + h^2)/12 + Y^2)`` [lbf*s^2*in].
    inertia_ry : float
        About the vertical through the bearing, ``W/g b^2/12`` [lbf*s^2*in].
    """
    w = ALUMINIUM_LBF_IN3 * PLATE_T_IN * width_in * height_in
    m = w / G_IN
    return w, m * ((width_in**2 + height_in**2) / 12.0 + PLATE_Y_IN**2), m * width_in**2 / 12.0


CALIBRATED = "calibrated: Table 3 analytical + Table 5 Guyan (python -m vlab.grid_fit)"


def _q(doc_q: dict[str, Any], value: float, source: str | None = None) -> dict[str, Any]:
    out = dict(doc_q)
    out["value"] = float(value)
    if source is not None:
        out["source"] = source
    return out


def current_parameters(doc: dict[str, Any]) -> dict[str, float]:
    """Read the fitted parameters (thesis units) from a grid TOML document.

    Parameters
    ----------
    doc : dict
        Parsed ``grid.toml`` (``StructureSpec.raw``).

    Returns
    -------
    dict
        ``{name: value}`` for every entry of :data:`GRID_PARAMETERS`.

    Raises
    ------
    ModelError
        If the document lacks a field the parameters live in.
    """
    try:
        masses = {m["id"]: m for m in doc["masses"]}
        top = doc["sections"]["top_beam"]
        return {
            "pitch": doc["calibration"]["pitch"]["value"],
            "half_span": doc["calibration"]["half_span"]["value"],
            "plate_width": doc["calibration"]["plate_width"]["value"],
            "plate_height": doc["calibration"]["plate_height"]["value"],
            "top_ei": top["ei"]["value"],
            "top_gj": top["gj"]["value"],
            "top_kga": top["shear_stiffness"]["value"],
            "top_thickness": top["thickness"]["value"],
            "joint_mass": masses["joint1"]["mass"]["value"],
            "coil_mass": masses["coil1"]["mass"]["value"],
        }
    except KeyError as exc:
        raise ModelError(f"grid document lacks field {exc} needed by the calibration") from None


def apply_parameters(doc: dict[str, Any], values: dict[str, float]) -> dict[str, Any]:
    """Return a copy of a grid TOML document with parameters set (thesis units).

    The pitch scales the coordinates of the lattice and of the top-beam points
    15-20; the bearings 13 and 22 sit at ``x = -/+ 3 a half_span`` with 14 and
    21 midway to 15 and 20. The plate width and height set the plate masses,
    the pendulum springs ``W*Y`` (Sec. 2.2.1) and the plate inertias
    (:func:`plate_properties`).

    Parameters
    ----------
    doc : dict
        Parsed ``grid.toml``; not modified.
    values : dict
        Some or all of the names of :data:`GRID_PARAMETERS`.

    Returns
    -------
    dict
        A new document (deep copy).

    Raises
    ------
    ModelError
        For an unknown parameter name.
    """
    known = {p[0] for p in GRID_PARAMETERS}
    unknown = set(values) - known
    if unknown:
        raise ModelError(f"unknown grid parameter(s) {sorted(unknown)}; known: {sorted(known)}")
    new = copy.deepcopy(doc)
    cur = current_parameters(doc)
    v = {**cur, **values}
    scale = v["pitch"] / cur["pitch"]
    coords = new["points"]["coordinates"]
    for key, (x, y) in list(coords.items()):
        coords[key] = [x * scale, y * scale]
    a = v["pitch"]
    x15, x20 = coords["15"][0], coords["20"][0]
    coords["13"] = [-3.0 * a * v["half_span"], 0.0]
    coords["22"] = [3.0 * a * v["half_span"], 0.0]
    coords["14"] = [0.5 * (coords["13"][0] + x15), 0.0]
    coords["21"] = [0.5 * (coords["22"][0] + x20), 0.0]
    cal = new["calibration"]
    for name in ("pitch", "half_span", "plate_width", "plate_height"):
        cal[name] = _q(cal[name], v[name])
    top = new["sections"]["top_beam"]
    for name, fld in (("top_ei", "ei"), ("top_gj", "gj"), ("top_kga", "shear_stiffness"),
                      ("top_thickness", "thickness")):
        top[fld] = _q(top[fld], v[name])
    w, i_rx, i_ry = plate_properties(v["plate_width"], v["plate_height"])
    for m in new["masses"]:
        if m["id"].startswith("joint"):
            m["mass"] = _q(m["mass"], v["joint_mass"])
        elif m["id"].startswith("coil"):
            m["mass"] = _q(m["mass"], v["coil_mass"])
        elif m["id"].startswith("plate"):
            m["mass"] = _q(m["mass"], w)
            m["inertia_rx"] = _q(m["inertia_rx"], i_rx)
            m["inertia_ry"] = _q(m["inertia_ry"], i_ry)
    for s in new["springs"]:
        if s["id"].startswith("pendulum"):
            s["stiffness"] = _q(s["stiffness"], w * PLATE_Y_IN)
    return new


