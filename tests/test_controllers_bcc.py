"""controllers on the vlab BCC model in the thesis unit system (inch, lbf, cs): Tables 7 and 9.

The design package itself never imports vlab; this test only feeds it vlab's matrices.
"""

from __future__ import annotations

import numpy as np
import pytest

models = pytest.importorskip("vlab.models")
calibration = pytest.importorskip("vlab.calibration")
units = pytest.importorskip("vlab.units")

from controllers.drf import mfdrf  # noqa: E402
from controllers.lq import lqr_weight_for_damping  # noqa: E402
from controllers.statespace import state_space  # noqa: E402

CS = 0.01  # [s] per centisecond, the thesis' design time unit (Sec. 3)


@pytest.fixture(scope="module")
def bcc_thesis_units():
    """(A, B, C) of the full BCC model in inch, lbf, cs (translations in in, rotations in rad)."""
    fe = models.nominal_fe_model("bcc")
    c = calibration.modal_damping_matrix(fe.m, fe.k, calibration.open_loop_ratios(fe.spec, fe.n))
    U = fe.force_input(fe.spec.instrumentation.actuators)
    s = np.array([units.INCH_M if d == "w" else 1.0 for _, d in fe.dofs.labels])
    work = units.LBF_N * units.INCH_M  # [J] per lbf*in: generalised forces S^T f in lbf (lbf*in)
    m, cc, k = (s[:, None] * x * s[None, :] / work for x in (fe.m, c, fe.k))
    return state_space(m, cc, k, s[:, None] * U / units.INCH_M, time_unit_s=CS)


def test_bcc_mfdrf_gamma_matches_table_7(bcc_thesis_units):
    """MFDRF, zeta_L = 0.03 on six modes: gamma = 0.050 lb*s/in in Table 7 (within 25 %)."""
    ss = bcc_thesis_units
    d = mfdrf(ss.A, ss.B, ss.C, zeta_min=0.03, n_modes=6, time_unit_s=CS)
    assert d.converged, d.message
    gamma_lbf_s_per_in = d.gamma * CS
    assert gamma_lbf_s_per_in == pytest.approx(0.050, rel=0.25)
    assert d.constrained_damping.min() >= 0.03 - 1e-6


def test_bcc_lqr_weight_for_three_percent_matches_sec_6_1(bcc_thesis_units):
    """Sec. 6.1: Q = I and R = 0.22 I give 3 % damping on the first six modes (within 25 %)."""
    ss = bcc_thesis_units
    res = lqr_weight_for_damping(ss.A, ss.B, np.eye(ss.A.shape[0]), zeta_min=0.03, n_modes=6,
                                 time_unit_s=CS)
    assert res.converged, res.message
    assert res.r == pytest.approx(0.22, rel=0.25)
