"""Time and memory of a diagnosis, estimated after the data are read and before its first simulation.

A diagnosis of time histories costs, in order (:mod:`vlab.diagnose.pipeline`):

- the **replay** of the recorded force on the nominal MuJoCo plant: the plant's build
  (:func:`vlab.sim.estimate.plant_estimate`) and its time simulation, ``ticks * nv *`` :data:`SIM_S_PER_TICK_DOF`
  (a hinge chain's step costs about linearly in its joint DOFs ``nv``);
- the **search** (screen, fit, pairs), only where the mismatch test finds a mismatch: each hypothesis of the
  library is evaluated on the nominal lab's FE model of ``n`` DOFs, ``n_hyp * n**1.25 *``
  :data:`SEARCH_S_PER_HYP_DOF125`;
- the **plant refit** of the best hypotheses on the MuJoCo plant's linearisation, :data:`REFIT_SHARE` of the
  search;
- the **validation**: the modified plant built and the recorded force replayed once more.

The constants are calibrated (measured on the development machine, two cores shared with up to two other
jobs) on two diagnoses of a concealed added mass: the BCC under MFDRF (19 FE DOFs, 22 joint DOFs, a library
of 85 hypotheses: 20 s in all, 11.8 s of search, 5.1 s of plant refit) and the grid (91 FE DOFs, 165 joint
DOFs, 184 hypotheses: 311 s, 167 s of search, 54 s of refit, replay and validation 40 s and 45 s). The
exponent 1.25 of the search is the one that fits both (its constant within 9 %; 1.5 and 1 leave 60 % and 40 %).
The search was timed before the modal sum became one product over the modes (``benchmarks/receptance_speed.py``:
1.9x faster on the grid), so its constant is now an upper bound. The estimate is a guide to the order of
magnitude, shown before the run and used to ask for ``--yes`` beyond a limit, not a prediction to the second.
"""

from __future__ import annotations

from ..fe.size import dense_bytes
from ..sim.estimate import plant_estimate

#: Seconds per controller tick and joint DOF of a MuJoCo replay or rerun (calibrated: the grid's replay of a
#: 150 s record, 300 000 ticks, 165 joint DOFs, 40 s).
SIM_S_PER_TICK_DOF = 8.1e-7
#: Seconds per hypothesis of the library and FE DOF to the power 1.25 of the screen, fit and pair search
#: (calibrated: BCC 11.8 s for 85 hypotheses on 19 DOFs, grid 167 s for 184 on 91 DOFs: 3.5e-3 and 3.2e-3).
SEARCH_S_PER_HYP_DOF125 = 3.5e-3
#: The plant refit's cost as a share of the search's (calibrated: BCC 0.43, grid 0.32; the larger kept).
REFIT_SHARE = 0.45
#: The structure stage's cost (a recording from elsewhere: its value, and a pair's check, fitted again on the
#: structure's converged model) as a share of the search's (calibrated on one BCC case: 3.9 s of 13.8 s for a
#: single effect, 9.0 s with a pair; the single's 0.3 kept: a pair is the rarer choice).
STRUCTURE_SHARE = 0.3
#: Seconds of reading, designing the nominal controller, locating and writing the report.
BASE_S = 3.0
#: Copies of the recording a diagnosis holds at once (the recording, the replay, the validation rerun and the
#: FRF estimates' work arrays).
RECORD_COPIES = 4


def estimate_diagnosis(*, n_fe_dofs: int, n_hypotheses: int, n_ticks: int, n_channels: int,
                       n_joints: int | None, from_elsewhere: bool = False) -> dict:
    """Time and memory of a diagnosis, from its sizes.

    Parameters
    ----------
    n_fe_dofs : int
        DOFs of the nominal lab's FE model (``n``), >= 1.
    n_hypotheses : int
        One-effect hypotheses of the library for this lab (the pairs and the shortlist are in the
        calibration), >= 0.
    n_ticks : int
        Controller ticks of the recording (0 for FRFs or a modal table: nothing is simulated), >= 0.
    n_channels : int
        Channels of the recording (force and responses), >= 0.
    n_joints : int or None
        Joint DOFs of the MuJoCo plant that replays and reruns the recording; None: no MuJoCo plant (a linear
        replay or no replay).
    from_elsewhere : bool
        The recording names no vlab plant and is replayed on the MuJoCo plant: its value is fitted again on
        the structure's own model (:mod:`vlab.diagnose.fit.onstructure`).

    Returns
    -------
    dict
        ``time_s`` [s] (the whole run, a mismatch found), ``memory_bytes`` [bytes], ``parts_s`` (dict of
        ``replay``, ``search``, ``refit``, ``validate``, ``structure`` [s]) and ``what`` (the sizes, in words).

    Source: the constants of this module (calibrated, see there).
    """
    search = SEARCH_S_PER_HYP_DOF125 * n_hypotheses * float(n_fe_dofs) ** 1.25
    memory = RECORD_COPIES * 8.0 * n_ticks * max(n_channels, 1) + dense_bytes(n_fe_dofs)
    replay = 0.0
    what = f"{n_hypotheses} hypotheses on {n_fe_dofs} FE DOFs"
    if n_joints is not None and n_ticks:
        plant = plant_estimate(n_joints)
        replay = plant["time_s"] + SIM_S_PER_TICK_DOF * n_ticks * n_joints
        memory += plant["memory_bytes"]
        what += f", {n_ticks} ticks replayed on a MuJoCo plant of {n_joints} joint DOFs"
    parts = {"replay": replay, "search": search, "refit": REFIT_SHARE * search if n_joints is not None else 0.0,
             "validate": replay, "structure": STRUCTURE_SHARE * search if from_elsewhere and n_joints is not None
             else 0.0}
    return {"time_s": BASE_S + sum(parts.values()), "memory_bytes": memory, "parts_s": parts, "what": what}
