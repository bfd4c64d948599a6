"""Designs I and II and the baselines: formulas, the adaptive law, the Lyapunov argument and the
paper's Section V claims on this plant (continuous mode, analytic plant, 5 s)."""

import math

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.control import AdaptiveRobustGains, NominalModel, Reference
from delta_pin.studies.metrics import compute_metrics
from tests.reference.laws import readable_evaluate, robust_gain_factor
from tests.reference.plants import ReadableAnalyticPlant


class UnitNominal(NominalModel):
    """M̄ = I, C̄ = 0, Ḡ = 0, no friction: C1 reduces to alpha_ddot^d - D r_dot."""

    dof = 3

    def terms(self, q, q_dot):
        return np.eye(3), np.zeros((3, 3)), np.zeros(3)


R = np.array([0.1, -0.2, 0.05])  # r [rad]
R_DOT = np.array([0.3, 0.1, -0.2])  # r_dot [rad/s]
REFERENCE = Reference(np.array([0.2, 0.3, 0.4]), np.array([0.5, 0.5, 0.5]), np.array([1.0, 0.0, -1.0]))


def _evaluate(design, state=None, r=R, r_dot=R_DOT, **options):
    """The readable law's output (tests/reference/laws.py, with its internals), checked against
    the compiled law's torque and rho_hat rate to 1e-12 (the same arithmetic in C++: equal to
    round-off on these numbers of order 1-100)."""
    controller = dp.AdaptiveRobustController(UnitNominal(), design, **options)
    state = controller.initial_state() if state is None else state
    alpha = REFERENCE.alpha + r
    alpha_dot = REFERENCE.alpha_dot + r_dot
    out = readable_evaluate(controller)(0.0, alpha, alpha_dot, REFERENCE, state)
    compiled = controller.evaluate(0.0, alpha, alpha_dot, REFERENCE, state)
    np.testing.assert_allclose(compiled.tau, out.tau, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(compiled.state_derivative, out.state_derivative, rtol=1e-12, atol=1e-12)
    return controller, out


def test_design1_torque_by_hand():
    _, out = _evaluate("I")
    # by hand with D = 9, T_p = 3, T_v = 9, rho_hat = 2:
    s = np.array([1.2, -1.7, 0.25])  # r_dot + 9 r
    a_ref = np.array([-1.7, -0.9, 0.8])  # alpha_ddot^d - 9 r_dot  (C1 with M̄ = I)
    c2 = np.array([-3.0, -0.3, 1.65])  # -3 r - 9 r_dot
    Lambda = 2.0 * (math.sqrt(4.34) + math.sqrt(5.4525) + 1.0)  # eq. 67: 10.836651
    assert out.internals["Lambda"] == pytest.approx(10.836651, abs=1e-6)
    # ||omega|| = ||s|| Lambda = 22.7 > xi: phi = 1/||omega||, C3 = -Lambda s/||s|| (eqs. 30-32)
    c3 = -Lambda * s / math.sqrt(4.3925)
    np.testing.assert_allclose(out.tau, a_ref + c2 + c3, rtol=1e-12)
    np.testing.assert_allclose(out.internals["robust_torque"], c3, rtol=1e-12)


def test_design2_torque_by_hand():
    _, out = _evaluate("II")
    s = np.array([1.2, -1.7, 0.25])
    Lambda = 2.0 * (math.sqrt(4.34) + math.sqrt(5.4525) + 1.0)
    w = math.sqrt(4.3925) * Lambda
    phi = w / (w * w + w * 1e-3 + 1e-6)  # eq. 56 (erratum 3)
    np.testing.assert_allclose(out.internals["robust_torque"], -phi * Lambda**2 * s, rtol=1e-12)


def test_boundary_layer_branch_of_design1():
    small = 1e-6
    _, out = _evaluate("I", r=np.array([small, 0, 0]), r_dot=np.zeros(3))
    Lambda = out.internals["Lambda"]
    assert out.internals["omega_norm"] < 1e-3  # inside the boundary layer xi
    s = np.array([9 * small, 0, 0])
    np.testing.assert_allclose(out.internals["robust_torque"], -(Lambda**2) / 1e-3 * s, rtol=1e-11)


def test_adaptive_law_outside_the_dead_zone():
    _, out = _evaluate("I")
    s_norm = math.sqrt(4.3925)
    kappa = math.sqrt(4.34) + math.sqrt(5.4525) + 1.0
    expected = 0.1 * (10.0 * kappa * s_norm - (2.0 * math.exp(-s_norm) + 0.3) * 2.0)  # eq. 24
    assert out.state_derivative == pytest.approx([expected], rel=1e-12)
    assert out.internals["adaptation_active"] == 1.0


def test_adaptive_law_in_the_dead_zone_only_leaks():
    _, out = _evaluate("I", r=np.zeros(3), r_dot=np.zeros(3))
    # s = 0: -beta (b2 e^0 + b3) rho_hat = -0.1 * 2.3 * 2
    assert out.state_derivative == pytest.approx([-0.46], rel=1e-12)
    assert out.internals["adaptation_active"] == 0.0


def test_vector_rho_option():
    controller, out = _evaluate("I", vector_rho=True)
    assert controller.initial_state().shape == (3,)
    assert out.internals["Lambda"] == pytest.approx(2.0 * (math.sqrt(4.34) + math.sqrt(5.4525) + 1.0))
    gradient = np.array([math.sqrt(4.34), math.sqrt(5.4525), 1.0])
    s_norm = math.sqrt(4.3925)
    expected = 0.1 * (10.0 * gradient * s_norm - (2.0 * math.exp(-s_norm) + 0.3) * 2.0)
    np.testing.assert_allclose(out.state_derivative, expected, rtol=1e-12)


def test_design2_gain_never_exceeds_design1_remark9():
    one = dp.AdaptiveRobustController(UnitNominal(), "I")
    two = dp.AdaptiveRobustController(UnitNominal(), "II")
    for w in np.concatenate([[0.0], np.logspace(-8, 4, 500)]):
        assert robust_gain_factor(two, w) <= robust_gain_factor(one, w)


@pytest.mark.parametrize("name", ["T_v", "T_p", "D", "beta", "xi", "epsilon", "b1", "b2", "b3", "rho0"])
def test_non_positive_gain_is_refused_with_its_name(name):
    with pytest.raises(dp.InvalidParameterError, match=f"gain {name}="):
        AdaptiveRobustGains(**{name: 0.0})
    with pytest.raises(dp.InvalidParameterError, match=f"gain {name}="):
        dp.design1(UnitNominal(), **{name: -1.0})


def test_bad_options_are_refused():
    with pytest.raises(dp.InvalidParameterError, match="design='III'"):
        dp.AdaptiveRobustController(UnitNominal(), "III")
    with pytest.raises(dp.InvalidParameterError, match="sampling_period=0"):
        dp.design1(UnitNominal(), sampling_period=0)
    with pytest.raises(dp.InvalidParameterError, match="K_p"):
        dp.PDGravity(UnitNominal(), K_p=-1)
    with pytest.raises(dp.InvalidParameterError, match="weight R"):
        dp.LQR(UnitNominal(), np.zeros(3), R=[1.0, 0.0, 1.0])


def test_non_finite_state_is_an_error_with_the_time(robot):
    nominal = dp.DeltaNominalModel(robot)

    class Glitch(dp.Plant):
        """The analytic plant, whose sensor returns NaN after 10 ms."""

        def __init__(self):
            self.inner = ReadableAnalyticPlant(robot)
            super().__init__(robot)

        def initial_state(self, a, ad):
            return self.inner.initial_state(a, ad)

        def derivative(self, t, x, tau):
            return self.inner.derivative(t, x, tau) * (np.nan if t > 0.0105 else 1.0)

        def joint_state(self, x):
            return self.inner.joint_state(x)

        def platform_position(self, x):
            return np.zeros(3)

    with pytest.raises(dp.SimulationError, match=r"non-finite.*t=0\.011 s"):
        dp.simulate(robot, dp.design1(nominal), dp.PathI(), plant=Glitch(), t_end=0.1)


# ------------------------------------------------------------------------------------ closed loops
PAPER = {"alpha0": np.full(3, 0.3322), "friction": dp.Friction(), "uncertainty": dp.PaperUncertainty()}


@pytest.fixture(scope="module")
def paper_runs():
    """The paper's scenario on path I, continuous mode, 5 s, analytic plant (agrees with the
    Pinocchio plant to ~1e-13 rad: tests/sim/test_plant.py)."""
    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    start = robot.inverse_kinematics([0.0, 0.0, -0.35])
    controllers = {
        "I": dp.design1(nominal),
        "II": dp.design2(nominal),
        "I no FC": dp.design1(nominal, friction_compensation=False),
        "II no FC": dp.design2(nominal, friction_compensation=False),
        "LQR": dp.LQR(nominal, start),
    }
    return {
        name: dp.simulate(robot, c, dp.PathI(), plant="analytic", t_end=5.0, mode="continuous", **PAPER)
        for name, c in controllers.items()
    }


def _error(run):
    return np.linalg.norm(run.error, axis=1)


@pytest.mark.parametrize("design", ["I", "II"])
def test_designs_enter_a_small_band_within_one_second_and_stay(paper_runs, design):
    error = _error(paper_runs[design])
    t = paper_runs[design].t
    assert error[0] > 0.14  # the paper's initial deviation (alpha_0 = 0.3322 vs 0.2492 rad)
    assert error[t >= 1.0].max() < 1e-3  # [rad] and stays there


def test_lqr_stays_bounded_with_a_larger_error(paper_runs):
    lqr = _error(paper_runs["LQR"])
    t = paper_runs["LQR"].t
    assert lqr.max() < 0.2  # bounded [rad]
    for design in ("I", "II"):
        assert lqr[t >= 1.0].max() > 10 * _error(paper_runs[design])[t >= 1.0].max()


@pytest.mark.parametrize("design", ["I", "II"])
def test_friction_compensation_lowers_ise(paper_runs, design):
    assert compute_metrics(paper_runs[design]).ise < compute_metrics(paper_runs[f"{design} no FC"]).ise


@pytest.mark.parametrize("design", ["I", "II"])
def test_robust_term_never_pushes_along_the_error_surface(paper_runs, design):
    run = paper_runs[design]
    s = run.error_rate + 9.0 * run.error
    power = np.einsum("ij,ij->i", s, run.internals["robust_torque"])  # (r_dot + D r)^T C3
    assert power.max() <= 1e-12


def test_lyapunov_function_decreases_outside_the_theorem_ball(robot):
    """V of eq. 34 along a continuous run started far from the path and with rho_hat(0) = 10 far
    above the bound: V_dot < 0 whenever ||mu|| exceeds Y of eq. 51, with rho the smallest bound
    that makes Assumption 3 hold along the run."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    gains = AdaptiveRobustGains(rho0=10.0)
    uncertainty = dp.PaperUncertainty()
    run = dp.simulate(
        robot,
        dp.design1(nominal, gains=gains),
        dp.PathI(),
        plant="analytic",
        t_end=1.0,
        mode="continuous",
        alpha0=np.full(3, 0.3322),
        alpha_dot0=np.array([3.0, -3.0, 2.0]),
        friction=dp.Friction(),
        uncertainty=uncertainty,
        rtol=1e-9,
        atol=1e-11,
    )
    plant = dp.AnalyticPlant(robot, dp.Friction(), uncertainty)
    D, T_p, T_v = 9.0, 3.0, 9.0
    r, r_dot = run.error, run.error_rate
    s = r_dot + D * r
    rho_hat = run.internals["rho_hat"][:, 0]
    # eta (eq. 28): what the nominal model misses, from the plant's truth at each sample
    eta_norm, kappa = [], []
    alpha_ddot_d = np.gradient(run.alpha_dot_d, run.t, axis=0)
    for k, t in enumerate(run.t):
        a, ad = run.alpha[k], run.alpha_dot[k]
        a_ref, v_ref = alpha_ddot_d[k] - D * r_dot[k], run.alpha_dot_d[k] - D * r[k]
        mass, passive = plant.acceleration_terms(t, ad)
        true = robot.analytic_dynamics(a, ad, platform_mass=mass)
        Mn, Cn, Gn = nominal.terms(a, ad)
        nominal_passive = nominal.disturbance() + nominal.friction(ad)
        eta = -(true.M - Mn) @ a_ref - (true.C - Cn) @ v_ref - (true.G - Gn) - (passive - nominal_passive)
        eta_norm.append(np.linalg.norm(eta))
        kappa.append(np.linalg.norm(a_ref) + np.linalg.norm(v_ref) + 1.0)
    rho = max(np.array(eta_norm) / np.array(kappa))  # Assumption 3 with Lambda(rho) of eq. 67
    M = np.array(
        [
            robot.analytic_dynamics(a, ad, platform_mass=plant.truth(t)[0]).M
            for t, a, ad in zip(run.t, run.alpha, run.alpha_dot)
        ]
    )
    V = (
        0.5 * np.einsum("ki,kij,kj->k", s, M, s)
        + 0.5 * (T_p + D * T_v) * np.sum(r * r, axis=1)
        + 0.5 * (rho_hat - rho) ** 2 / (gains.beta * gains.b1)
    )
    V_dot = np.gradient(V, run.t)
    mu = np.sqrt(np.sum(r_dot**2, axis=1) + np.sum(r**2, axis=1) + (rho_hat - rho) ** 2)
    sigma1 = min(T_v, D * T_p, 0.5 * (gains.b2 + gains.b3) / gains.b1)
    sigma2 = gains.epsilon
    sigma3 = gains.xi / 4 + 0.5 * (gains.b2 + gains.b3) / gains.b1 * rho**2
    Y = (sigma2 + math.sqrt(sigma2**2 + 4 * sigma1 * sigma3)) / (2 * sigma1)  # eq. 51
    outside = mu[1:-1] > Y
    assert outside.sum() >= 100  # not vacuous: the run spends time outside the ball
    assert V_dot[1:-1][outside].max() < 0.0


# ------------------------------------------------------------------------------------ sampled loops
@pytest.fixture(scope="module")
def paper_nominal():
    robot = dp.load_delta()
    return robot, dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))


@pytest.mark.parametrize("make", [dp.design1, dp.design2])
def test_paper_gains_lose_stability_in_a_1khz_sampled_loop(paper_nominal, make):
    robot, nominal = paper_nominal
    with pytest.raises(dp.SimulationError, match="diverged") as failure:
        dp.simulate(robot, make(nominal), dp.PathI(), plant="analytic", t_end=1.0, dt=1e-3, **PAPER)
    assert 0.05 < failure.value.time < 0.3  # [s] measured: 0.11 s for both designs


@pytest.mark.parametrize("make", [dp.design1, dp.design2])
def test_paper_gains_hold_at_10khz(paper_nominal, make):
    robot, nominal = paper_nominal
    run = dp.simulate(robot, make(nominal), dp.PathI(), plant="analytic", t_end=0.6, dt=1e-4, **PAPER)
    assert _error(run)[run.t >= 0.5].max() < 0.02  # [rad] still converging at 0.6 s


@pytest.mark.parametrize("make", [dp.design1, dp.design2])
def test_sampling_aware_option_is_stable_at_1khz(paper_nominal, make):
    robot, nominal = paper_nominal
    run = dp.simulate(
        robot, make(nominal, sampling_period=1e-3), dp.PathI(), plant="analytic", t_end=3.0, dt=1e-3, **PAPER
    )
    error = _error(run)
    # bounded and small, but NOT in the continuous band (< 1e-3 rad): with D = 9 a 1 kHz loop can
    # only reject the disturbance to ~ |eta| T / (lambda_min(M) D) ~ 1e-2 rad (README, Results)
    assert error[run.t >= 1.0].max() < 0.02
    assert error[run.t >= 1.0].max() > 1e-3
