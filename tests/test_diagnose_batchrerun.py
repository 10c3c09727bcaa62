"""Several MuJoCo reruns as one mujoco.batch (vlab.diagnose.data.batchrerun) against the reruns made one by one.

The reference is :func:`vlab.diagnose.data.replay.rerun` on one ``MjData`` (what
each process of the old path ran). Candidates whose plants differ only in
values (a member's stiffness, a mode's damping, the nominal) share a batch and
must give the same recordings bit for bit, warm-started (plant and controller
state) and from rest; an added mass is a new geom (``ngeom`` differs), so its
rerun falls back to the single path, and the note says so.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from vlab.diagnose.data.batchrerun import batch_key, rerun_together, why_apart  # noqa: E402
from vlab.sim.batch_plant import layout  # noqa: E402
from vlab.diagnose.data.measured import FrfData  # noqa: E402
from vlab.diagnose.data.replay import expectation, mujoco_plant, rerun  # noqa: E402
from vlab.diagnose.data.rerun_jobs import last_reruns_note, reruns  # noqa: E402
from vlab.diagnose.data.warmstart import rerun_window  # noqa: E402
from vlab.diagnose.effects import specedit  # noqa: E402
from vlab.diagnose.model.labmodel import LabState  # noqa: E402
from vlab.diagnose.model.nominal import nominal_design  # noqa: E402
from vlab.errors import ModelError, SimulationError  # noqa: E402
from vlab.lab.excitation import pseudo_random  # noqa: E402
from vlab.experiment.config import TESTS, default_chain  # noqa: E402
from vlab.io.recording import Recording  # noqa: E402
from vlab.diagnose.data.run import DiagnosisRun  # noqa: E402
from vlab.models import nominal_fe_model  # noqa: E402

RES_HZ = 0.5  # 2 s periods
PERIODS = 3
PTS = (5, 6, 7, 9)


class _Problem:
    """What :func:`reruns` reads of a problem: the data (its recorded force and analysed part), the rerun
    window's guard and the run context the reruns are kept in."""

    def __init__(self, data):
        self.data = data
        self.guard_s = None
        self.run = DiagnosisRun()


def _lab(controller: str) -> LabState:
    fe = nominal_fe_model("bcc")
    return LabState(fe.spec, fe, default_chain(controller, noise_m_s=1e-6), nominal_design(fe, controller, 0))


def _data(lab: LabState, periodic: bool = True) -> FrfData:
    dt = lab.chain.period_s
    n_per = int(round(1 / (RES_HZ * dt)))
    t = np.arange(PERIODS * n_per) * dt
    test = TESTS["bcc"]
    force = pseudo_random(t, band_hz=test.band_hz, resolution_hz=RES_HZ, rms_n=test.rms_n, seed=3)
    rec = Recording.from_signals(dt, {"force9": force, **{f"vel{p}": np.zeros(t.size) for p in PTS}})
    lines = np.arange(1, 21) * RES_HZ
    ones = np.ones((lines.size, len(PTS)))
    return FrfData("x", "recording", lines, ones, ones, 9, PTS, recording=rec, analysed_from_s=2 * n_per * dt,
                   periodic=periodic)


def _value_only(lab: LabState) -> list[LabState]:
    spec = lab.spec
    return [lab.with_spec(specedit.scale_member(spec, spec.members[0].id, 1.3)),
            lab.with_spec(specedit.set_modal_damping(spec, 1, 0.03)), lab]


def _single(state: LabState, data: FrfData, seed: int) -> Recording:
    """The rerun made alone, as :func:`reruns` makes them: noise-free (the seed then changes nothing)."""
    state = expectation(state)
    force = np.asarray(data.recording["force9"])
    start, period, stop = rerun_window(data, data.recording.dt_s)
    return rerun(state, force, excitation_point=9, measured_points=PTS, plant="mujoco", seed=seed, start=start,
                 period=period, stop=stop)[0]


def _same(a: Recording, b: Recording) -> bool:
    return (a.metadata == b.metadata and [c.name for c in a.channels] == [c.name for c in b.channels]
            and np.array_equal(a.as_array(), b.as_array()))


@pytest.mark.parametrize(("controller", "periodic"), [("lqg", True), ("mfdrf", True), ("mfdrf", False)])
def test_value_only_candidates_are_one_batch_bit_for_bit(controller, periodic):
    """A member 30 % stiffer, mode 1 at 3 % damping and the nominal: one batch, each recording equal to its
    single rerun bit for bit -- warm-started one period before the analysed one (LQG: the controller's 12
    states are warm-started too) and from rest (a test not analysed period by period)."""
    lab = _lab(controller)
    data = _data(lab, periodic)
    states = _value_only(lab)
    p = _Problem(data)
    got = reruns(p, [(st, None) for st in states], "mujoco", seed=4)
    assert last_reruns_note(p) == "3 MuJoCo reruns as one mujoco.batch"
    for st, r in zip(states, got):
        ref = _single(st, data, 4)
        assert float(ref.metadata["start_s"]) == (2.0 if periodic else 0.0)
        assert _same(ref, r)


def test_rerun_together_draws_the_single_reruns_sensor_noise():
    """With the sensor noise on (``reruns`` turns it off, a rerun being the expected response), one batch draws
    each simulation's noise as the single loop does: bit for bit the single noisy reruns."""
    lab = _lab("mfdrf")
    data = _data(lab)
    states = _value_only(lab)
    force = np.asarray(data.recording["force9"])
    start, period, stop = rerun_window(data, data.recording.dt_s)
    got = rerun_together(states, [mujoco_plant(st, PTS) for st in states], force, excitation_point=9,
                         measured_points=PTS, seed=4, start=start, period=period, stop=stop, nthread=1)
    for st, r in zip(states, got):
        ref = rerun(st, force, excitation_point=9, measured_points=PTS, plant="mujoco", seed=4, start=start,
                    period=period, stop=stop)[0]
        assert _same(ref, r)
    quiet = reruns(_Problem(data), [(states[0], None)], "mujoco", seed=4, workers=1)[0]
    assert not _same(got[0], quiet)  # the noise was there to draw, and reruns leave it out


def test_a_pair_goes_to_processes_by_default():
    """Two reruns: processes unless asked (BATCH_MIN_RERUNS = 3, measured: a pair is no faster as a batch)."""
    lab = _lab("mfdrf")
    p = _Problem(_data(lab))
    reruns(p, [(st, None) for st in _value_only(lab)[:2]], "mujoco", seed=4)
    assert last_reruns_note(p) == "2 mujoco reruns in 2 processes"


def test_a_new_geom_falls_back_to_the_single_path():
    """An added mass is a geom of its own: its model's MjData differs in size, so the pair (nominal, mass)
    cannot share a batch -- both are rerun the single way, with the same recordings, and the note says why."""
    lab = _lab("mfdrf")
    data = _data(lab)
    mass = lab.with_spec(specedit.add_mass(lab.spec, 6, 0.12))
    p0, p1 = (mujoco_plant(st, PTS) for st in (lab, mass))
    k0, k1 = batch_key(lab, p0, PTS), batch_key(mass, p1, PTS)
    n0 = p0.model.ngeom
    assert p1.model.ngeom == n0 + 1
    apart = f"model sizes differ (ngeom {n0} vs {n0 + 1})"
    assert why_apart(k0, k1) == apart
    p = _Problem(data)
    got = reruns(p, [(lab, "nominal"), (mass, "mass")], "mujoco", seed=4, workers=1, batch=True)
    assert last_reruns_note(p) == f"2 mujoco reruns one after another ({apart})"
    for st, r in zip((lab, mass), got):
        assert _same(_single(st, data, 4), r)
    # a stiffer member beside them shares the nominal's batch; the mass is rerun alone
    stiff = _value_only(lab)[0]
    p = _Problem(data)
    got = reruns(p, [(lab, None), (mass, None), (stiff, None)], "mujoco", seed=4, workers=1)
    assert last_reruns_note(p) == f"2 MuJoCo reruns as one mujoco.batch; 1 mujoco rerun alone ({apart})"
    assert _same(_single(stiff, data, 4), got[2]) and _same(_single(mass, data, 4), got[1])


def test_rerun_together_refuses_what_cannot_share_a_batch():
    lab = _lab("mfdrf")
    mass = lab.with_spec(specedit.add_mass(lab.spec, 6, 0.12))
    force = np.zeros(100)
    with pytest.raises(ModelError, match=r"model sizes differ \(ngeom \d+ vs \d+\)"):
        rerun_together([lab, mass], [mujoco_plant(st, PTS) for st in (lab, mass)], force, excitation_point=9,
                       measured_points=PTS)
    with pytest.raises(ModelError, match="2 states and 1 plants"):
        rerun_together([lab, lab], [mujoco_plant(lab, PTS)], force, excitation_point=9, measured_points=PTS)
    model = mujoco_plant(lab, PTS).model
    assert ("ngeom", model.ngeom) in layout(model) and ("nv", model.nv) in layout(model)


def test_batch_plant_set_state_checks_shapes():
    from vlab.sim.batch_plant import MujocoBatchPlant

    plant = mujoco_plant(_lab("mfdrf"), PTS)
    bp = MujocoBatchPlant(plant, 2, nthread=1)
    with pytest.raises(SimulationError, match="set_state"):
        bp.set_state(np.zeros((2, 3)), np.zeros((2, plant.model.nv)))
    with pytest.raises(SimulationError, match="non-finite"):
        bp.set_state(np.full((2, plant.model.nq), np.nan), np.zeros((2, plant.model.nv)))


def test_run_batch_checks_initial_states():
    from vlab.lab.batch import run_batch
    from vlab.lab.engine import ControllerEngine
    from vlab.sim.batch_plant import MujocoBatchPlant

    lab = _lab("lqg")
    d = lab.design
    eng = ControllerEngine(d.f11, d.f12, d.f21, d.f22, period_s=lab.chain.period_s)
    bp = MujocoBatchPlant(mujoco_plant(lab, PTS), 2, nthread=1)
    kw = dict(feedback_points=lab.actuators, measured_points=PTS, excitation_point=9, excitation=np.zeros(4),
              duration_s=4 * lab.chain.period_s, chain=lab.chain)
    with pytest.raises(ModelError, match="initial_states"):
        run_batch(bp, eng, initial_states=np.zeros((2, eng.n_states + 1)), **kw)
    with pytest.raises(ModelError, match="initial_states"):
        run_batch(bp, None, initial_states=np.zeros((2, 0)), **kw)
