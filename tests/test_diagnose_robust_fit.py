"""An effect's value on the Student-t likelihood (vlab.diagnose.fit.robust): its degrees of freedom and scale against
scipy's own maximum-likelihood fit of the t distribution, and the value of a weak support spring on closed-form
modal FRFs of the BCC whose sixth mode the model misplaces by 0.15 % (a model-form error beyond the lines'
variance), against the spring that made them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.stats

from vlab.diagnose.data.measured import FrfData
from vlab.diagnose.effects.structural import SupportStiffness
from vlab.diagnose.fit.estimate import fit_hypothesis
from vlab.diagnose.fit.robust import DOF_RANGE, t_dof_scale, t_fit, t_nll
from vlab.diagnose.model.labmodel import LabState, point_modes_of, predict_frf
from vlab.diagnose.problem.context import context_for
from vlab.diagnose.problem.residuals import Problem
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model


@pytest.mark.parametrize("nu, scale", [(1.0, 0.3), (3.0, 0.5), (8.0, 2.0)])
def test_the_dof_and_scale_are_scipys_maximum_likelihood_fit(nu, scale):
    r = scale * np.random.default_rng(7).standard_t(nu, size=20000)
    got = t_dof_scale(r**2)
    df, _loc, sc = scipy.stats.t.fit(r, floc=0.0)
    assert got[0] == pytest.approx(df, rel=0.02)
    assert got[1] == pytest.approx(sc, rel=0.02)
    assert got[0] == pytest.approx(nu, rel=0.15) and got[1] == pytest.approx(scale, rel=0.05)
    # the negative log-likelihood is scipy's density's
    assert t_nll(r**2, *got) == pytest.approx(-np.sum(scipy.stats.t.logpdf(r, got[0], scale=got[1])), rel=1e-10)


def test_normal_residuals_give_the_normal_likelihood():
    r = 0.7 * np.random.default_rng(3).standard_normal(20000)
    nu, s = t_dof_scale(r**2)
    assert nu > 50 and s == pytest.approx(0.7, rel=0.03)


def test_residuals_that_are_not_finite_are_refused():
    with pytest.raises(ValueError, match="finite"):
        t_dof_scale(np.array([1.0, np.inf]))
    assert DOF_RANGE[0] > 0


KW = {"excitation_point": 9, "output_points": (3, 6, 7)}
PTS = (3, 5, 6, 7, 9)  # the outputs and the actuators
SPRING = 8.3  # N/m at point 7: mode 1 moves 0.9 %


def _spring_data(misplaced: float) -> tuple[Problem, SupportStiffness]:
    """FRFs of the BCC with the spring (0.1 % complex noise), their mode 6 at ``1 - misplaced`` times the
    model's, and the problem of fitting the spring with the FE model (which has mode 6 where it was)."""
    fe = nominal_fe_model("bcc")
    lab = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), None)
    f = np.arange(10, 501) * 0.05
    h0 = SupportStiffness(point=7, dof="w")
    true = h0.apply(lab, np.array([SPRING]), context_for(lab, (0.5, 25.0), None))
    pm = point_modes_of(true, PTS)
    omega = pm.omega.copy()
    omega[5] *= 1.0 - misplaced
    h = predict_frf(replace(true, point_modes=replace(pm, omega=omega)), f, **KW)
    noise = np.random.default_rng(1).standard_normal((2,) + h.shape)
    h = h * (1 + 1e-3 * (noise[0] + 1j * noise[1]) / np.sqrt(2))
    data = FrfData("closed-form.uff", "frf", f, h, (1e-3 * np.abs(h)) ** 2, 9, (3, 6, 7))
    return Problem(data, lab, context_for(lab, (0.5, 25.0), data), floor=0.0), h0


def test_a_misplaced_mode_pulls_the_least_squares_value_and_not_the_t_likelihoods():
    """Least squares takes the spring 3 % low, pulled by the misplaced mode 6, which the spring hardly moves
    (0.002 %); the t likelihood finds heavy tails (few degrees of freedom) and the spring within 0.5 %, its
    interval holding it."""
    problem, h = _spring_data(0.0015)
    ls = fit_hypothesis(h, problem)
    assert ls.params_[0] / SPRING - 1 < -0.02
    tf = t_fit(ls, problem, ls.params_)
    assert tf.dof < 5
    assert tf.params[0] == pytest.approx(SPRING, rel=5e-3)
    assert tf.ci95[0, 0] <= SPRING <= tf.ci95[0, 1]
    assert tf.nll < tf.nll_nominal
    assert "Student-t" in tf.describe()


def test_without_a_misplaced_mode_the_t_value_is_the_least_squares_value():
    problem, h = _spring_data(0.0)
    ls = fit_hypothesis(h, problem)
    tf = t_fit(ls, problem, ls.params_)
    assert tf.dof > 20
    assert tf.params[0] == pytest.approx(ls.params_[0], rel=2e-3)
    assert tf.params[0] == pytest.approx(SPRING, rel=5e-3)
    width_t, width_ls = np.diff(tf.ci95[0]), np.diff(ls.ci95_[0])
    assert width_t == pytest.approx(width_ls, rel=0.15)


def test_a_start_of_another_length_is_refused():
    problem, h = _spring_data(0.0)
    with pytest.raises(ValueError, match="start of shape"):
        t_fit(h, problem, np.array([1.0, 2.0]))


def test_the_structure_fit_says_which_likelihood_its_value_maximises():
    from vlab.diagnose.fit.onstructure import StructureFit

    plain = StructureFit(np.array([1.0]), np.array([[0.9, 1.1]]), 3.0, "its own replay", 0.1).as_dict()
    assert plain["likelihood"].startswith("normal") and plain["t_dof"] is None and plain["t_scale"] is None
    t = StructureFit(np.array([1.0]), np.array([[0.9, 1.1]]), 3.0, "its own replay", 0.1, "Student-t likelihood",
                     2.5, 0.3).as_dict()
    assert (t["likelihood"], t["t_dof"], t["t_scale"]) == ("Student-t likelihood", 2.5, 0.3)


def test_the_loss_is_the_t_likelihood_at_fixed_dof_and_scale():
    """rho and its derivatives by finite differences; scipy's cost ``0.5 sum s^2 rho(f^2 / s^2)`` is
    ``nu s^2 / (nu + 1)`` times the residual part of the t negative log-likelihood."""
    from vlab.diagnose.fit.robust import _t_loss

    nu, s = 2.5, 0.4
    z = np.array([0.0, 0.3, 2.0, 40.0])
    rho = _t_loss(nu)(z)
    dz = 1e-6
    np.testing.assert_allclose(rho[1], (_t_loss(nu)(z + dz)[0] - _t_loss(nu)(z - dz)[0]) / (2 * dz), rtol=1e-6)
    np.testing.assert_allclose(rho[2], (_t_loss(nu)(z + dz)[1] - _t_loss(nu)(z - dz)[1]) / (2 * dz), rtol=1e-5)
    f = np.array([0.1, -0.5, 1.7, 6.0])
    cost = 0.5 * np.sum(s * s * _t_loss(nu)((f / s) ** 2)[0])
    expected = nu * s * s / (nu + 1) * (t_nll(f**2, nu, s) - t_nll(np.zeros(4), nu, s))
    assert cost == pytest.approx(expected, rel=1e-12)


def test_the_interval_is_the_expected_information_of_the_residuals_own_jacobian():
    """The misplaced-mode fit's interval against one made here: central differences of the problem's residuals
    in the fit's coordinate (log10 of the stiffness), information (nu + 1) / ((nu + 3) max(s, 1)^2) each."""
    problem, h = _spring_data(0.0015)
    ls = fit_hypothesis(h, problem)
    tf = t_fit(ls, problem, ls.params_)
    assert h.log_scale == (True,)
    z0, dz = np.log10(tf.params[0]), 1e-4
    col = (problem.residual(problem.state_for(h, np.array([10 ** (z0 + dz)])))
           - problem.residual(problem.state_for(h, np.array([10 ** (z0 - dz)])))) / (2 * dz)
    s = max(tf.scale, 1.0)
    sd = 1.0 / np.sqrt((tf.dof + 1) / ((tf.dof + 3) * s * s) * col @ col)
    np.testing.assert_allclose(tf.ci95[0], 10 ** (z0 + np.array([-1.96, 1.96]) * sd), rtol=2e-3)


def test_residuals_that_are_mostly_zero_have_no_tail_to_weigh():
    r2 = np.concatenate([np.zeros(900), np.random.default_rng(0).standard_normal(100) ** 2])
    with pytest.raises(ValueError, match="no interior maximum"):
        t_dof_scale(r2)


@pytest.mark.parametrize("start", [0.5, 2.0])
def test_the_value_maximises_the_likelihood_jointly_with_its_dof_and_scale(start):
    """From a start far from the spring, the fit's value is the maximum of the profile t likelihood (the degrees of
    freedom and scale re-estimated at every value, here by scipy's bounded scalar minimiser on vlab's t_dof_scale),
    to the settling tolerance: the conditional maximisations alternate until the value settles (one round with the
    dof and scale of the start's residuals ends about 2.6 % of the interval away)."""
    import scipy.optimize

    from vlab.diagnose.fit.estimate import residuals_in_z, to_z
    from vlab.diagnose.fit.robust import SETTLED

    problem, h = _spring_data(0.0015)
    ls = fit_hypothesis(h, problem)
    tf = t_fit(ls, problem, np.array([start * SPRING]))
    fun, log = residuals_in_z(h, problem), tuple(h.log_scale)

    def profile(x: float) -> float:
        r2 = fun(to_z(np.array([x]), log)) ** 2
        return t_nll(r2, *t_dof_scale(r2))

    width = float(np.diff(tf.ci95[0])[0])
    best = scipy.optimize.minimize_scalar(profile, bounds=(tf.params[0] - width, tf.params[0] + width),
                                          method="bounded", options={"xatol": 1e-3 * width})
    assert abs(tf.params[0] - best.x) <= SETTLED * width
