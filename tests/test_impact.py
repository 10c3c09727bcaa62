"""Impact and burst excitation: H1 over one record per event, against closed forms and in the diagnosis.

The closed form is a two-mode system's receptance, whose response to a train of hammer pulses is computed
exactly (scipy.signal.lsim of its state space); H1 over the records must give it back on every line, the
coherence near 1, and records too short for the response to decay are refused naming the channel. In the
diagnosis, a concealed mass on the linear lab, excited by pulses through the lab's excitation channel with the
MFDRF loop closed, is named with the transient estimator chosen by the force.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from vlab.errors import MeasurementError
from vlab.measure.impact import event_starts, is_transient, transient_h1

DT = 1e-3
W = 2 * np.pi * np.array([3.0, 11.0])     # two modes [rad/s]
ZETA = np.array([0.05, 0.03])
PHI = np.array([[1.0, 0.6], [0.8, -1.1]])  # rows: the force's point, the response's point


def _system():
    """State space of the two modes: force at point 0, velocity at point 1."""
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.diag(W**2), -np.diag(2 * ZETA * W)]])
    b = np.concatenate([np.zeros(2), PHI[0]])[:, None]
    c = np.concatenate([np.zeros(2), PHI[1]])[None, :]
    return scipy.signal.StateSpace(a, b, c, np.zeros((1, 1)))


def _exact(f_hz):
    w = 2 * np.pi * np.asarray(f_hz)
    return sum(1j * w * PHI[0, r] * PHI[1, r] / (W[r] ** 2 - w**2 + 2j * ZETA[r] * W[r] * w) for r in range(2))


def _pulses(n_events: int, record_s: float, rng, width_s: float = 4e-3) -> np.ndarray:
    """Half-sine hammer pulses of random height, 1.1 to 1.3 records apart."""
    n_rec = int(round(record_s / DT))
    gaps = rng.integers(int(1.1 * n_rec), int(1.3 * n_rec), size=n_events)
    x = np.zeros(int(gaps.sum()) + n_rec)
    k = np.arange(int(round(width_s / DT)) + 1)
    pulse = np.sin(np.pi * k / k[-1])
    for at in np.cumsum(gaps) - gaps[0] + n_rec // 20:
        x[at:at + k.size] += rng.uniform(50, 100) * pulse
    return x


def test_h1_over_impacts_gives_the_receptance_back():
    rng = np.random.default_rng(4)
    x = _pulses(5, 8.0, rng)
    t = np.arange(x.size) * DT
    _, y, _ = scipy.signal.lsim(_system(), x, t, interp=False)
    noise = 1e-4 * np.std(y)
    y = y + noise * rng.standard_normal(y.size)
    assert is_transient(x)
    e = transient_h1(x + 0.01 * rng.standard_normal(x.size), y[:, None], dt_s=DT, resolution_hz=1 / 8.0)
    assert len(e.starts) == 5 and e.n_record == 8000
    band = (e.freq_hz > 0.5) & (e.freq_hz < 40)
    # lsim with interp=False holds the input over each step: the exact FRF of that system at the lines is the
    # continuous one times the hold's (1 - e^{-jwT}) / (jwT) and its half-step delay
    w = 2 * np.pi * e.freq_hz[band]
    hold = (1 - np.exp(-1j * w * DT)) / (1j * w * DT)
    exact = _exact(e.freq_hz[band]) * hold
    err = np.abs(e.h[band, 0] - exact)
    peak = np.max(np.abs(exact))
    assert np.max(err) < 2e-3 * peak  # the antiresonance near 25.5 Hz included, in absolute terms
    strong = np.abs(exact) > 0.1 * peak
    assert np.max(err[strong] / np.abs(exact[strong])) < 5e-3
    assert np.min(e.coherence[band, 0][strong]) > 0.999


def test_records_too_short_to_decay_are_refused():
    rng = np.random.default_rng(5)
    x = _pulses(6, 1.0, rng)  # mode 1 decays with tau = 1 / (zeta w) = 1.06 s: 1-s records cut it
    _, y, _ = scipy.signal.lsim(_system(), x, np.arange(x.size) * DT, interp=False)
    with pytest.raises(MeasurementError, match=r"channel acc9: the response has not decayed by the end of its 1-s"):
        transient_h1(x, y[:, None], dt_s=DT, resolution_hz=1.0, names=("acc9",))


def test_a_double_hit_is_refused():
    rng = np.random.default_rng(7)
    x = _pulses(3, 8.0, rng)
    at = event_starts(x, 8000)[1] + 3000
    x[at:at + 3] = 80.0  # a second hit 3 s into the second record
    with pytest.raises(MeasurementError, match=r"two events .*double hit"):
        transient_h1(x, x[:, None], dt_s=DT, resolution_hz=1 / 8.0)


def test_a_random_force_is_not_transient_and_one_event_is_not_enough():
    rng = np.random.default_rng(6)
    noise = rng.standard_normal(20000)
    assert not is_transient(noise)
    with pytest.raises(MeasurementError, match="not an impact or burst excitation"):
        transient_h1(noise, noise[:, None], dt_s=DT, resolution_hz=1.0)
    one = _pulses(1, 8.0, rng)
    assert len(event_starts(one, 8000)) == 1
    with pytest.raises(MeasurementError, match="need at least two"):
        transient_h1(one, one[:, None], dt_s=DT, resolution_hz=1 / 8.0)


def _impact_recording(state, path, rng, *, record_s: float = 10.0, n_events: int = 4) -> str:
    """Hammer pulses (3 ms half-sines, 5-10 N) through the lab's excitation channel at point 9, 1.05-1.2
    records apart, on the linear lab ``state``; 1e-6 m/s of sensor noise."""
    from vlab.diagnose.data.replay import rerun
    from vlab.io.recording import Recording
    from vlab.io.uff import write_recording

    dt = state.chain.period_s
    n_rec = int(round(record_s / dt))
    gaps = rng.integers(int(1.05 * n_rec), int(1.2 * n_rec), size=n_events)
    x = np.zeros(int(gaps.sum()) + n_rec)
    pulse = np.sin(np.pi * np.arange(7) / 6)
    for at in np.cumsum(gaps) - gaps[0] + n_rec // 20:
        x[at:at + 7] += rng.uniform(5, 10) * pulse
    meas = (5, 6, 7, 9)
    rec, _ = rerun(state, x, excitation_point=9, measured_points=meas)
    sig = {"force9": x[x.size - rec.n_samples:]}
    for p in meas:
        v = np.asarray(rec[f"vel{p}"])
        sig[f"vel{p}"] = v + 1e-6 * rng.standard_normal(v.size)
    meta = {"structure": "bcc", "controller": state.design.controller, "seed": 0, "resolution_hz": 1 / record_s,
            "plant": "linear FE model"}
    write_recording(path, Recording.from_signals(dt, sig, metadata=meta), overwrite=True)
    return str(path)


@pytest.fixture(scope="module")
def lab():
    from vlab.diagnose.model.labmodel import LabState
    from vlab.diagnose.model.nominal import nominal_design
    from vlab.lab.loop import HardwareChain
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    return LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))


@pytest.mark.slow
def test_an_impact_test_of_a_concealed_mass_is_diagnosed(lab, tmp_path):
    """MFDRF loop closed, 0.12 kg at point 6: the transient estimator is chosen by the force, the mass named."""
    from vlab.diagnose import diagnose
    from vlab.diagnose.effects import specedit

    truth = lab.with_spec(specedit.add_mass(lab.spec, 6, 0.12))
    path = _impact_recording(truth, tmp_path / "impact.uff", np.random.default_rng(2))
    d = diagnose("bcc", path, validate_run=False).as_dict()
    assert any(n.startswith("transient excitation (impact or burst): H1 over 4 records of 10 s") for n in d["notes"])
    (sel,) = d["selected"]
    assert sel["effect"] == "added_mass" and sel["location"] == {"point": 6}
    assert sel["parameters"]["mass_kg"] == pytest.approx(0.12, rel=0.01)


@pytest.mark.slow
def test_an_impact_test_of_the_nominal_structure_is_no_mismatch(lab, tmp_path):
    from vlab.diagnose import diagnose

    path = _impact_recording(lab, tmp_path / "null.uff", np.random.default_rng(3))
    d = diagnose("bcc", path, validate_run=False).as_dict()
    assert not d["mismatch"] and not d["selected"]


def test_the_estimator_option_is_checked(lab, tmp_path):
    from typer.testing import CliRunner

    from vlab.cli import app

    path = _impact_recording(lab, tmp_path / "null.uff", np.random.default_rng(3), n_events=2)
    res = CliRunner().invoke(app, ["diagnose", "--structure", "bcc", "--recording", path, "--estimator", "welch"])
    assert res.exit_code == 2 and "--estimator 'welch' is not one of auto, periodic, h1, transient" in res.output
    res = CliRunner().invoke(app, ["diagnose", "--structure", "bcc", "--recording", path, "--estimator", "periodic",
                                   "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "not a periodic excitation" in " ".join(res.output.split())
