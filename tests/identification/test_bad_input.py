"""Bad input is one line naming the column, the line, the time or the parameter (issue 24)."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.errors import InvalidParameterError
from delta_pin.identification.estimation import check_identifiable
from delta_pin.identification.excitation import ExcitationLimits, FourierExcitation, check_excitation
from delta_pin.identification.log import IdentificationLog, read_log, write_log
from delta_pin.identification.regressor import ClosedChainRegressor
from delta_pin.identification.workflow import identify

JOINTS = ("active_1", "active_2", "active_3")


@pytest.fixture(scope="module")
def delta():
    return dp.load_delta()


def _log(n=200, rate=1000.0):
    t = np.arange(n) / rate
    alpha = 0.1 * np.sin(np.outer(t, [1.0, 2.0, 3.0]))
    return IdentificationLog(t, alpha, np.cos(alpha), JOINTS)


def _lines(path):
    return path.read_text().splitlines()


def test_a_log_round_trips(tmp_path):
    path = write_log(tmp_path / "log.csv", _log())
    back = read_log(path, JOINTS)
    np.testing.assert_array_equal(back.alpha, _log().alpha)  # %.17g is exact
    assert back.sample_rate == pytest.approx(1000.0, rel=1e-9)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda lines: [lines[0], lines[1], lines[2].replace(",tau[active_2]", ",torque_2"), *lines[3:]],
         "column 'tau[active_2]' is missing"),
        (lambda lines: [*lines[:10], lines[10].replace(lines[10].split(",")[2], "nan", 1), *lines[11:]],
         "line 11, column 'q[active_2]' is nan"),
        (lambda lines: [*lines[:20], lines[21], lines[20], *lines[22:]], "time is not increasing at line 22"),
        (lambda lines: [*lines[:30], *lines[35:]], "differs from the median"),
        (lambda lines: [lines[0], "# sample_rate_hz: 500", *lines[2:]],
         "header says sample_rate_hz: 500 but column 't' is sampled at 1000 Hz"),
        (lambda lines: [*lines[:40], lines[40].replace(lines[40].split(",")[4], "abc", 1), *lines[41:]],
         "line 41, column 'tau[active_1]': 'abc' is not a number"),
    ],
    ids=["missing column", "nan", "time backwards", "gap", "header rate", "not a number"],
)  # fmt: skip
def test_a_bad_log_is_one_line(tmp_path, edit, message):
    path = write_log(tmp_path / "log.csv", _log())
    lines = _lines(path)  # 0: title, 1: sample_rate_hz, 2..: other header keys, then the columns
    assert lines[1].startswith("# sample_rate_hz") and lines[2].startswith("t,")
    path.write_text("\n".join(edit(lines)) + "\n")
    with pytest.raises(InvalidParameterError, match=message.replace("[", r"\[").replace("]", r"\]")) as error:
        read_log(path, JOINTS)
    assert "\n" not in str(error.value)


def test_rank_deficient_excitation_names_the_parameters(delta):
    """A log in which only joint 1 moves leaves the other joints' friction (and more) unidentifiable:
    the fit says how many and which, instead of dropping them."""
    rate, n = 1000.0, 1500
    t = np.arange(n) / rate
    alpha = np.zeros((n, 3)) + delta.home
    alpha[:, 0] += 0.3 * np.sin(2 * np.pi * 1.0 * t)
    tau = np.random.default_rng(0).normal(0.0, 0.1, (n, 3))  # any torque but a constant (refused first)
    log = IdentificationLog(t, alpha, tau, JOINTS, header={"torque_hold": "sample"})
    with pytest.raises(
        InvalidParameterError, match=r"rank-deficient excitation: \d+ of \d+ base parameters"
    ) as error:
        identify(delta, log, consistent=False)
    assert "fv[active_2]" in str(error.value) and "fc[active_3]" in str(error.value)


def test_check_identifiable_counts_a_collinear_column():
    W = np.random.default_rng(0).normal(size=(100, 3))
    W = np.hstack([W, W[:, :1] * 2.0])
    with pytest.raises(InvalidParameterError, match="1 of 4 base parameters are not identifiable"):
        check_identifiable(W, ["a", "b", "c", "d"])


def test_an_excitation_out_of_the_workspace_or_near_a_singularity_is_named(delta):
    regressor = ClosedChainRegressor(delta)
    theta = regressor.parameters()
    a = np.zeros((3, 2))
    a[0, 1] = 1.2  # joint 1 swings by ~2.4 rad: the loops cannot close
    far = FourierExcitation(delta.home, a, np.zeros((3, 2)), period=2.0, duration=2.0)
    limits = ExcitationLimits(
        position_range=10.0, velocity_limit=100.0, torque_limit=1e9, jacobian_condition=1e12
    )
    with pytest.raises(InvalidParameterError, match=r"leaves the workspace at t = \d\.\d{3} s"):
        check_excitation(regressor, far, theta, limits=limits, rate=200.0)
    a[0, 1] = 0.05
    near = FourierExcitation(delta.home, a, np.zeros((3, 2)), period=2.0, duration=2.0)
    strict = ExcitationLimits(position_range=10.0, velocity_limit=100.0, jacobian_condition=5.0)
    with pytest.raises(
        InvalidParameterError, match=r"near a singularity of the closures at t = 0.000 s: cond J_p"
    ):
        check_excitation(regressor, near, theta, limits=strict, rate=200.0)
    with pytest.raises(InvalidParameterError, match=r"exceeds \|alpha_dot\| <= 0.1 on active_1"):
        check_excitation(regressor, near, theta, limits=ExcitationLimits(velocity_limit=0.1), rate=200.0)
