"""Recording and Channel (vlab.io.recording)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from vlab.errors import MeasurementError
from vlab.io.recording import Channel, Recording, channel_name, parse_channel_name


def _rec():
    return Recording.from_signals(
        0.5e-3, {"force4": np.arange(5.0), "vel1": np.ones(5), "vel12": np.zeros(5)},
        metadata={"structure": "grid", "seed": 1})


def test_from_signals_parses_names():
    rec = _rec()
    assert rec.names == ("force4", "vel1", "vel12")
    c = rec.channel("vel12")
    assert (c.quantity, c.point_id, c.unit, c.direction) == ("velocity", 12, "m/s", 3)
    assert rec.channel("force4").unit == "N"
    assert rec.find(4, "force").name == "force4"
    assert rec.n_samples == 5 and rec.n_channels == 3 and len(rec) == 3
    assert rec.duration_s == pytest.approx(2.5e-3)
    assert rec.sample_rate_hz == pytest.approx(2000.0)
    np.testing.assert_allclose(rec.time_s, np.arange(5) * 0.5e-3)
    assert rec.as_array(["vel1", "force4"]).shape == (5, 2)
    assert "vel1" in rec and "vel2" not in rec
    assert parse_channel_name("disp6") == ("displacement", 6)
    assert channel_name("acceleration", 3) == "acc3"


def test_recording_is_immutable():
    rec = _rec()
    with pytest.raises(ValueError):
        rec["force4"][0] = 1.0
    with pytest.raises(TypeError):
        rec.metadata["seed"] = 2
    with pytest.raises(AttributeError):
        rec.dt_s = 1.0
    src = np.ones(3)
    ch = Channel(name="vel1", point_id=1, quantity="velocity", samples=src)
    src[0] = 5.0
    assert ch.samples[0] == 1.0


def test_pickles_with_its_read_only_metadata():
    """A recording goes to worker processes (vlab.diagnose's parallel refits) whole."""
    rec = _rec().with_metadata(seed=3)
    back = pickle.loads(pickle.dumps(rec))
    assert back == rec and back.metadata["seed"] == 3
    with pytest.raises(TypeError):
        back.metadata["seed"] = 2


def test_copies_and_equality():
    rec = _rec()
    assert rec == _rec()
    sub = rec.select(["vel1"])
    assert sub.names == ("vel1",) and sub.metadata == rec.metadata
    more = rec.with_metadata(controller="MFDRF")
    assert more.metadata["controller"] == "MFDRF" and "controller" not in rec.metadata
    assert more != rec


def test_errors_name_the_channel():
    with pytest.raises(MeasurementError, match="channel 'vel1' has 4 samples"):
        Recording.from_signals(1e-3, {"force4": np.zeros(5), "vel1": np.zeros(4)})
    with pytest.raises(MeasurementError, match="channel 'vel1': 1 non-finite"):
        Recording.from_signals(1e-3, {"vel1": [0.0, np.nan]})
    with pytest.raises(MeasurementError, match="does not follow"):
        Recording.from_signals(1e-3, {"sensorA": [0.0]})
    with pytest.raises(MeasurementError, match="dt_s"):
        Recording.from_signals(0.0, {"vel1": [0.0]})
    with pytest.raises(MeasurementError, match="no channel 'vel9'"):
        _rec().channel("vel9")
    with pytest.raises(MeasurementError, match="duplicate"):
        c = Channel(name="vel1", point_id=1, quantity="velocity", samples=[0.0])
        Recording(1e-3, (c, c))
    ok = Recording.from_signals(1e-3, {"sensorA": [0.0]}, point_ids={"sensorA": 3},
                                quantities={"sensorA": "velocity"})
    assert ok.channel("sensorA").point_id == 3


@pytest.mark.parametrize("freq_hz", [1.9, 4.8, 20.0])
@pytest.mark.parametrize("bits", [12, 16])
def test_a_quantised_slow_signal_is_not_clipping_but_its_clipped_copy_is(freq_hz, bits):
    """A real ADC's 12- or 16-bit codes hold a slow sine's extreme for many samples (24 at 1.9 Hz, 0.2 of full
    scale, 2 kHz, 12 bits); that is not a flat top. The same signal clipped at 80 % of its peak is."""
    from vlab.io.recording import find_clipping

    t = np.arange(0.0, 20.0, 1 / 2000.0)
    x = 0.1 * np.sin(2 * np.pi * freq_hz * t) + 1e-5 * np.random.default_rng(0).standard_normal(t.size)
    q = 1.0 / 2 ** bits  # +-0.5 full scale
    xq = np.round(x / q) * q
    assert find_clipping(xq) is None
    assert find_clipping(np.clip(xq, -0.08, 0.08)) is not None
