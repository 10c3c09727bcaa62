"""The shape uncertainty implied by the frequency uncertainty (vlab.diagnose.model.shapemixing).

Checked against the exact eigenvectors of a perturbed two-mode system (numpy's eigh, not first-order
theory) and against the structure's own model form on the BCC.
"""

from __future__ import annotations

import numpy as np
import pytest

from vlab.diagnose.model.labmodel import PointModes
from vlab.diagnose.model.shapemixing import MAX_MIXING, mixing_shape_uncertainty


def _modes(omega, shapes) -> PointModes:
    n = len(omega)
    return PointModes(omega=np.asarray(omega, dtype=float), zeta=np.full(n, 0.01), shapes=np.asarray(shapes, float),
                      points=tuple(range(1, np.shape(shapes)[0] + 1)), source="test")


@pytest.mark.parametrize("f1, f2, sigma", [(8.797, 9.498, 5.1e-4), (1.0, 3.0, 1e-3), (10.0, 10.5, 2e-4)])
def test_two_modes_mix_as_the_exact_eigenvectors_of_the_bounding_perturbation(f1, f2, sigma):
    """Mass-normalised two-mode system K = diag(w1^2, w2^2), shapes the identity at two points. The
    perturbation of one sign that moves both frequencies by one standard uncertainty and couples them as
    much as it can, E = e e^T with e_i = w_i sqrt(2 sigma), rotates the eigenvectors by the angle that the
    function returns as mode 1's (and mode 2's) shape uncertainty, to first order in sigma."""
    w = 2 * np.pi * np.array([f1, f2])
    e = w * np.sqrt(2 * sigma)
    _, vec = np.linalg.eigh(np.diag(w**2) + np.outer(e, e))
    angle = abs(np.arctan2(vec[1, 0], vec[0, 0]))  # mode 1's turn towards mode 2
    angle = min(angle, np.pi - angle)
    s = mixing_shape_uncertainty(_modes(w, np.eye(2)), np.array([sigma, sigma]))
    assert s[0] == pytest.approx(angle, rel=0.05)
    assert s[1] == pytest.approx(s[0], rel=1e-12)  # equal RMS shapes: the pair mixes symmetrically


def test_separated_modes_mix_less_and_exact_frequencies_not_at_all():
    w = 2 * np.pi * np.array([1.0, 1.1, 10.0])
    s = mixing_shape_uncertainty(_modes(w, np.eye(3)), np.array([1e-3, 1e-3, 1e-3]))
    assert s[0] > 10 * s[2] > 0
    s0 = mixing_shape_uncertainty(_modes(w, np.eye(3)), np.array([1e-3, 0.0, np.nan]))
    assert s0[1] == 0 and s0[2] == 0 and s0[0] == 0  # mode 1 has no uncertain partner


def test_repeated_frequencies_are_capped_and_bad_input_is_refused():
    w = 2 * np.pi * np.array([5.0, 5.0])
    assert mixing_shape_uncertainty(_modes(w, np.eye(2)), np.array([1e-3, 1e-3]))[0] == pytest.approx(MAX_MIXING)
    with pytest.raises(ValueError, match="2 modes"):
        mixing_shape_uncertainty(_modes(w, np.eye(2)), np.array([1e-3]))
    with pytest.raises(ValueError, match="negative"):
        mixing_shape_uncertainty(_modes(w, np.eye(2)), np.array([1e-3, -1e-3]))


def test_the_structures_own_model_form_carries_the_close_pairs_shapes():
    """The BCC's FE model form (compared with the FE model itself): shape parameters appear, and the close
    pair at 8.8/9.5 Hz carries the largest shape uncertainty, about 1 % for its 0.05 % calibration residual."""
    from vlab.diagnose.detectability import frf_model_form_of, nominal_test

    _spec, lab, data, _ctx = nominal_test("bcc", "none")
    _mf, mff = frf_model_form_of(lab, data, "linear")
    phi = {lab_: s for lab_, s in zip(mff.labels, mff.sigma) if lab_.startswith("phi")}
    assert phi, "no shape parameter on the structure's own model"
    by_mode = {}
    for label, s in phi.items():
        by_mode[int(label[3:].split("@")[0])] = s
    assert max(by_mode, key=by_mode.get) in (3, 4)
    assert 0.004 < max(by_mode.values()) < 0.03


def test_per_point_the_mixing_is_the_partners_shape_there_and_its_rms_is_the_modes_value():
    """Two modes at 9 and 10 Hz, shapes [[1, 2], [1, 0]] at two points (rms 1 and sqrt(2)): mode 1 moves by
    c_12 phi_2(p) at point p, so s_1(p) = c_12 |phi_2(p)| / rms_1 -- 2 c_12 at the first point, 0 at the second
    -- and the root-mean-square of s_1(p) over the points is the per-mode s_1."""
    w = 2 * np.pi * np.array([9.0, 10.0])
    sigma = np.array([5e-4, 5e-4])
    shapes = np.array([[1.0, 2.0], [1.0, 0.0]])
    c12 = 2 * w[0] * w[1] * 5e-4 / (w[1] ** 2 - w[0] ** 2)
    at = mixing_shape_uncertainty(_modes(w, shapes), sigma, per_point=True)
    assert at.shape == (2, 2)
    assert at[0, 0] == pytest.approx(2 * c12) and at[1, 0] == 0.0
    assert at[0, 1] == pytest.approx(c12 / np.sqrt(2)) and at[1, 1] == pytest.approx(c12 / np.sqrt(2))
    s = mixing_shape_uncertainty(_modes(w, shapes), sigma)
    assert s == pytest.approx(np.sqrt(np.mean(at**2, axis=0)))


def test_a_per_point_shape_uncertainty_with_the_wrong_rows_is_refused():
    """frf_model_form takes a shape uncertainty per mode (the same at every point) or one row per point; a
    per-point array of another row count is an error naming both counts, not silently wrapped."""
    from vlab.diagnose.detectability import nominal_test
    from vlab.diagnose.model.modelform import frf_model_form, model_form_uncertainty
    from vlab.diagnose.model.nominal import natural_frequencies

    spec, lab, data, _ctx = nominal_test("bcc", "none")
    fr, _, _ = natural_frequencies(lab)
    mf = model_form_uncertainty(spec, fr, compared_with="fe")
    kw = dict(excitation_point=data.excitation_point, output_points=data.output_points, uncertainty=mf)
    n_pts = len(dict.fromkeys(tuple(data.output_points) + lab.actuators))
    with pytest.raises(ValueError, match=f"2 rows for the {n_pts} points"):
        frf_model_form(lab, data.freq_hz[:50], shape_rel=np.full((2, len(fr)), 1e-3), **kw)
    ok = frf_model_form(lab, data.freq_hz[:50], shape_rel=np.full((n_pts, len(fr)), 1e-3), **kw)
    assert any(label.startswith("phi") for label in ok.labels)
