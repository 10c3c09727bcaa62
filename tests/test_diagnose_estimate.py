"""A diagnosis and a detectability study are estimated before their long work, and a long one asks for --yes.

The estimate's model (vlab.diagnose.cost) is checked against its own stated form; the pipeline is checked to
call it once the data are read and before the first simulation, with the library's real size; the command
line to refuse a run beyond the limit (exit 2, naming --yes) without writing its output folder.
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.diagnose import diagnose
from vlab.diagnose.cost import (BASE_S, REFIT_SHARE, SEARCH_S_PER_HYP_DOF125, SIM_S_PER_TICK_DOF, STRUCTURE_SHARE,
                               estimate_diagnosis)
from vlab.diagnose.effects import specedit
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.model.nominal import nominal_design
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model
from vlab.sim.estimate import plant_estimate

from _recordings import record_linear


class Stop(Exception):
    """Raised by a test's confirm callback to stop a run at its estimate."""


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    fe = nominal_fe_model("bcc")
    nominal = LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))
    truth = nominal.with_spec(specedit.add_mass(nominal.spec, 6, 0.12))
    return record_linear(truth, tmp_path_factory.mktemp("rec") / "rec.uff")


def test_estimate_follows_its_stated_model():
    """search = c n_hyp n^1.25, refit a share of it; replay = the plant's build + c ticks nv, once more to
    validate; nothing simulated without a MuJoCo plant."""
    est = estimate_diagnosis(n_fe_dofs=16, n_hypotheses=10, n_ticks=1000, n_channels=3, n_joints=20)
    search = SEARCH_S_PER_HYP_DOF125 * 10 * 16 ** 1.25
    replay = plant_estimate(20)["time_s"] + SIM_S_PER_TICK_DOF * 1000 * 20
    assert est["parts_s"] == pytest.approx({"replay": replay, "search": search, "refit": REFIT_SHARE * search,
                                            "validate": replay, "structure": 0.0})
    assert est["time_s"] == pytest.approx(BASE_S + 2 * replay + (1 + REFIT_SHARE) * search)
    elsewhere = estimate_diagnosis(n_fe_dofs=16, n_hypotheses=10, n_ticks=1000, n_channels=3, n_joints=20,
                                   from_elsewhere=True)
    assert elsewhere["parts_s"]["structure"] == pytest.approx(STRUCTURE_SHARE * search)
    assert elsewhere["time_s"] == pytest.approx(est["time_s"] + STRUCTURE_SHARE * search)
    frf = estimate_diagnosis(n_fe_dofs=16, n_hypotheses=10, n_ticks=0, n_channels=0, n_joints=None)
    assert frf["parts_s"]["replay"] == frf["parts_s"]["refit"] == 0.0
    assert "hypotheses on 16 FE DOFs" in frf["what"] and "ticks" not in frf["what"]


def test_diagnosis_is_estimated_before_the_first_simulation(recording, monkeypatch):
    """The callback sees the library's size and the recording's ticks; what it raises stops the run before the
    replay."""
    import vlab.diagnose.reading as reading

    def no_replay(*_a, **_k):
        raise AssertionError("the replay ran before the estimate was confirmed")

    monkeypatch.setattr(reading, "referred_through_replay", no_replay)
    seen = []

    def confirm(est):
        seen.append(est)
        raise Stop

    with pytest.raises(Stop):
        diagnose("bcc", recording, controller="mfdrf", plant="linear", confirm=confirm)
    (est,) = seen
    assert est["time_s"] > BASE_S and est["memory_bytes"] > 0
    assert "ticks" not in est["what"]  # a linear replay: no MuJoCo plant to build or step
    n_hyp = int(est["what"].split(" hypotheses")[0])
    assert n_hyp > 10


def test_cli_refuses_a_diagnosis_beyond_the_limit_without_yes(recording, tmp_path, monkeypatch):
    import vlab.robust.scheduler as scheduler

    monkeypatch.setattr(scheduler, "CONFIRM_ABOVE_S", 0.0)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["diagnose", "--structure", "bcc", "--recording", recording, "--controller",
                                   "mfdrf", "--plant", "linear", "--out", str(out)])
    assert res.exit_code == 2, res.output
    text = " ".join(res.output.split())
    assert "vlab diagnose: the run would take about" in text and "--yes" in text and "hypotheses" in text
    assert not out.exists()


@pytest.mark.slow
def test_cli_refuses_a_detectability_loop_beyond_the_limit_without_yes(monkeypatch):
    import vlab.robust.scheduler as scheduler

    monkeypatch.setattr(scheduler, "CONFIRM_ABOVE_S", 0.0)
    res = CliRunner().invoke(app, ["detectability", "bcc", "--effect", "added_mass", "--no-naming",
                                   "--model-form", "none"])
    assert res.exit_code == 2, res.output
    text = " ".join(res.output.split())
    assert "vlab detectability: the run would take about" in text and "the first took" in text
    assert "--yes" in text
