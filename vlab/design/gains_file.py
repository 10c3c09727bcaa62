"""The gains a controller ran with, from a design file: what a diagnosis needs where redesigning would not
give them back (a laboratory's own gains, a design of another version or seed).

The file is the JSON that ``vlab design STRUCTURE --controller mfdrf|lqdrf|lqdrf-diag --json`` writes (or
any JSON with the same keys)::

    {"structure": "bcc", "controller": "mfdrf", "reduction": "full", "period_s": 0.0005,
     "gain_n_s_per_m": [[...], [...], [...]]}

``controller`` and ``gain_n_s_per_m`` (``D`` [N*s/m], ``u = -D y``, the actuators in the structure's
order) are required; ``structure``, ``reduction`` (the design model) and ``period_s`` are used where
given. Only direct rate feedback is read: an LQG's observer is not a gain matrix.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import DataFileError, ModelError
from ..fe import FEModel
from .controller import DRF_CONTROLLERS, ControllerDesign, drf_of_gain

__all__ = ["design_from_file", "read_gains_file"]


def read_gains_file(path: str | Path) -> dict:
    """The fields of a design file (module notes), checked.

    Parameters
    ----------
    path : str or Path
        The JSON design file.

    Returns
    -------
    dict
        ``controller`` (str), ``gain_n_s_per_m`` (ndarray, shape (n_c, n_c) [N*s/m]), ``structure``,
        ``reduction`` (str or None), ``period_s`` (float [s] or None).

    Raises
    ------
    DataFileError
        The file cannot be read or is not JSON; a required field is missing; a field of the wrong type
        or value (names the file and the field); a controller that is not a direct rate feedback.
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DataFileError(f"{path}: not a readable JSON design file ({exc})") from exc
    if not isinstance(doc, dict):
        raise DataFileError(f"{path}: expected a JSON object with 'controller' and 'gain_n_s_per_m'")
    for key in ("controller", "gain_n_s_per_m"):
        if key not in doc:
            raise DataFileError(f"{path}: field {key!r} missing (the JSON of `vlab design --json` has it)")
    controller = doc["controller"]
    if controller not in DRF_CONTROLLERS:
        raise DataFileError(f"{path}: field 'controller': {controller!r} -- only the gains of a direct rate "
                            f"feedback ({', '.join(DRF_CONTROLLERS)}) are read from a file")
    raw = doc["gain_n_s_per_m"]
    rows = raw if isinstance(raw, list) else [raw]
    if any(isinstance(v, bool) for r in rows for v in (r if isinstance(r, list) else [r])):
        raise DataFileError(f"{path}: field 'gain_n_s_per_m': true/false is no gain [N*s/m]")
    try:
        gain = np.asarray(raw, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataFileError(f"{path}: field 'gain_n_s_per_m': not a matrix of numbers ({exc})") from exc
    if gain.ndim != 2 or gain.shape[0] != gain.shape[1] or gain.size == 0 or not np.all(np.isfinite(gain)):
        raise DataFileError(f"{path}: field 'gain_n_s_per_m': expected a finite square matrix [N*s/m], got "
                            f"shape {gain.shape}")
    out = {"controller": controller, "gain_n_s_per_m": gain, "structure": None, "reduction": None,
           "period_s": None}
    for key in ("structure", "reduction"):
        v = doc.get(key)
        if v is not None and not isinstance(v, str):
            raise DataFileError(f"{path}: field {key!r}: expected a name, got {v!r}")
        out[key] = v
    period = doc.get("period_s")
    if period is not None:
        if isinstance(period, bool) or not isinstance(period, (int, float)) or not period > 0:
            raise DataFileError(f"{path}: field 'period_s': expected a positive number of seconds, got {period!r}")
        out["period_s"] = float(period)
    return out


def design_from_file(fe: FEModel, path: str | Path, *, controller: str | None = None,
                     period_s: float | None = None) -> ControllerDesign:
    """The controller of a design file on ``fe`` (:func:`vlab.design.controller.drf_of_gain`).

    Parameters
    ----------
    fe : FEModel
        The structure's FE model; a file naming another structure is refused.
    path : str or Path
    controller : str, optional
        The controller the recording ran (refused when the file names another).
    period_s : float, optional
        The controller's sampling period [s]; default the file's, else the thesis's for the law.

    Raises
    ------
    DataFileError
        As :func:`read_gains_file`; another structure or controller than the file's; a gain that does not
        fit the structure's actuators.
    """
    d = read_gains_file(path)
    if d["structure"] is not None and d["structure"] != fe.spec.name:
        raise DataFileError(f"{path}: the gains of structure {d['structure']!r}, not of {fe.spec.name!r}")
    if controller is not None and controller != d["controller"]:
        raise DataFileError(f"{path}: the gains of {d['controller']!r}, but the recording ran {controller!r}")
    try:
        return drf_of_gain(fe, d["controller"], d["gain_n_s_per_m"], model=d["reduction"],
                           period_s=period_s if period_s is not None else d["period_s"], source=str(path))
    except ModelError as exc:
        raise DataFileError(f"{path}: field 'gain_n_s_per_m': {exc}") from exc
