"""`identify` refuses, in one line, a log too short to fit, a log whose fit would not fit in memory
and an excitation made for another robot (issue 36, items 3, 5 and 6). Before: a 10-sample log
ended in "unexpected ValueError: The length of the input vector x must be greater than padlen,
which is 15" (exit 1); an 80 MB log took 5.1 GB with no size check; read_trajectory compared only
the number of joints, so another Delta's excitation was simulated without a word.
"""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.identification import log as log_module
from delta_pin.identification.estimation import filtered_states
from delta_pin.identification.excitation import FourierExcitation
from delta_pin.identification.log import IdentificationLog, count_samples, kinematics_digest, write_log
from delta_pin.identification.regressor import ClosedChainRegressor
from delta_pin.identification.workflow import (
    FIT_BYTES_PER_ENTRY,
    decimation,
    fit_memory,
    identify,
    minimum_samples,
    read_trajectory,
    write_trajectory,
)
from delta_pin.utils import memory

JOINTS = ("active_1", "active_2", "active_3")
FIT = ["identify", "fit", "--no-consistent", "--no-figures"]
ERROR = "delta-pin identify: error: "


@pytest.fixture(scope="module")
def delta():
    return dp.load_delta()


def _log(n: int, rate: float = 1000.0) -> IdentificationLog:
    """n samples of every joint moving (never at rest: no row dropped near a reversal)."""
    t = np.arange(n) / rate
    alpha = 0.3 + np.outer(t, [2.0, -2.5, 3.0]) + 0.05 * np.sin(np.outer(t, [31.0, 47.0, 59.0]))
    tau = np.cos(3 * alpha) + 0.1 * np.sin(np.outer(t, [13.0, 17.0, 19.0]))
    return IdentificationLog(t, alpha, tau, JOINTS, header={"torque_hold": "sample"})


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(ERROR), err
    return lines[0][len(ERROR) :]


# ------------------------------------------------------------------------------ too short
def test_a_10_sample_log_is_refused_naming_the_samples_a_fit_needs(tmp_path, capsys):
    """Before: 'unexpected ValueError: ... padlen, which is 15', exit 1. Now exit 2 before any
    filtering, naming the minimum (minimum_samples: 46 base parameters over 3 joints at 1 kHz)."""
    path = write_log(tmp_path / "short.csv", _log(10))
    need = minimum_samples(_log(10).sample_rate, 20.0, 46, 3)
    assert need == 478  # (46 // 3) x 25 + 1 after 2 x 51 trimmed
    capsys.readouterr()
    assert main([*FIT, "--data", str(path), "--out", str(tmp_path / "fit")]) == 2
    line = _one_line(capsys)
    assert f"log {path} has 10 samples" in line
    assert f"fitting the 46 base parameters of robot 'delta' at 1000 Hz needs at least {need}" in line
    assert not (tmp_path / "fit" / "manifest.json").exists()


def test_the_minimum_is_what_the_fit_takes(delta):
    """One sample fewer than minimum_samples is refused; at the minimum the fit gets past its
    filters with just more rows than base parameters, and what it says next is the log's motion
    (necessary, not sufficient: a joint that never reverses cannot tell Coulomb from the offset,
    and which of the two is named depends on the rows kept)."""
    need = minimum_samples(_log(600).sample_rate, 20.0, 46, 3)
    with pytest.raises(InvalidParameterError, match=f"has {need - 1} samples; .* needs at least {need}"):
        identify(delta, _log(need - 1), consistent=False)
    log = _log(need)
    states = filtered_states(log)
    rows = len(range(0, len(states.t), decimation(log.sample_rate, 20.0)))
    assert rows * 3 > 46 and (rows - 1) * 3 <= 46  # the fewest rows least squares take
    with pytest.raises(
        InvalidParameterError, match=r"rank-deficient excitation: 2 of 46 .*\((fc|off)\[active_\d\]"
    ):
        identify(delta, log, consistent=False)


def test_filtering_a_log_shorter_than_the_filter_is_one_line():
    """validate and predict filter a log too: before, filtfilt's ValueError on 10 samples."""
    with pytest.raises(
        InvalidParameterError, match=r"the log has 10 samples; filtering it needs at least 118"
    ):
        filtered_states(_log(10))


# ------------------------------------------------------------------------------ too large
def test_count_samples_counts_the_data_lines(tmp_path):
    path = write_log(tmp_path / "log.csv", _log(1234))
    assert count_samples(path) == (1234, True)
    path.write_bytes(path.read_bytes().rstrip(b"\n"))  # a last line without its newline
    assert count_samples(path) == (1234, True)
    big = write_log(tmp_path / "big.csv", _log(300_000))
    estimate, exact = count_samples(big, stop=1000)  # stops after the first MiB
    assert not exact and 0.9 * 300_000 < estimate < 1.1 * 300_000


def test_a_log_too_large_for_memory_is_refused_before_it_is_read(tmp_path, capsys, monkeypatch):
    """Before: no size check (an 80 MB log took 5.1 GB). Now the fit's peak (fit_memory, 36 bytes a
    sample, joint and regressor column: 9.2 kB a Delta sample) past half of the machine's memory
    is refused in one line, before the log is read, naming how many samples would do."""
    path = write_log(tmp_path / "log.csv", _log(2000))
    regressor = ClosedChainRegressor(dp.load_delta())
    per = 3 * regressor.size * FIT_BYTES_PER_ENTRY
    assert fit_memory(regressor, 2000) == 2000 * per
    monkeypatch.setattr(memory, "memory_limit", lambda: 1000 * per)  # 1000 samples' worth

    def not_read(*args, **kwargs):
        raise AssertionError("the log was read")

    monkeypatch.setattr(log_module, "read_log", not_read)
    capsys.readouterr()
    assert main([*FIT, "--data", str(path), "--out", str(tmp_path / "fit")]) == 2
    line = _one_line(capsys)
    assert f"log {path} has 2,000 samples: a fit of robot 'delta' holds about" in line
    assert "(half of this machine's memory); shorten the log to at most 1,000 samples" in line
    # the --validate log too, whichever is too large
    monkeypatch.undo()
    monkeypatch.setattr(memory, "memory_limit", lambda: 1000 * per)
    small = write_log(tmp_path / "small.csv", _log(900))
    fit = [*FIT, "--data", str(small), "--validate", str(path), "--out", str(tmp_path / "fit")]
    assert main(fit) == 2
    assert f"log {path} has 2,000 samples" in _one_line(capsys)


def test_identify_refuses_a_log_in_memory_past_the_limit(delta, monkeypatch):
    monkeypatch.setattr(memory, "memory_limit", lambda: 10 * 1024**2)
    with pytest.raises(InvalidParameterError, match=r"the log has 5,000 samples: .* at most 1,14\d samples"):
        identify(delta, _log(5000), consistent=False)


# ------------------------------------------------------------------------------ whose excitation
def _excitation(robot) -> FourierExcitation:
    a = np.zeros((robot.dof, 2))
    a[:, 1] = 0.05
    return FourierExcitation(robot.home, a, np.zeros((robot.dof, 2)), period=1.0, duration=1.0)


def test_another_robot_s_excitation_is_refused(tmp_path, delta):
    """Before: only the number of joints was compared: the Table 1 Delta's excitation read for a
    Delta with 0.25 m arms (same name, same joints) without a word."""
    path = write_trajectory(tmp_path / "traj.csv", _excitation(delta), delta, rate=100.0)
    assert f"# kinematics_sha256: {kinematics_digest(delta)}" in path.read_text()
    read_trajectory(path, delta)  # its own robot
    other = dp.load_delta(l_a=0.25)
    with pytest.raises(
        InvalidParameterError, match="was excited for a robot 'delta' of other kinematics"
    ) as error:
        read_trajectory(path, other)
    assert kinematics_digest(other) in str(error.value) and "\n" not in str(error.value)
    renamed = tmp_path / "renamed.csv"
    renamed.write_text(path.read_text().replace("# robot: delta", "# robot: my_delta"))
    with pytest.raises(InvalidParameterError, match=r"excited for robot 'my_delta' \(its header's"):
        read_trajectory(renamed, delta)
    anyone = tmp_path / "anyone.csv"  # no robot lines: anyone's file, accepted
    anyone.write_text("".join(line for line in path.read_text().splitlines(keepends=True)
                              if not line.startswith(("# robot", "# kinematics"))))  # fmt: skip
    assert read_trajectory(anyone, other).alpha0.shape == (3,)


def test_simulate_refuses_another_delta_s_excitation(tmp_path, delta, capsys):
    path = write_trajectory(tmp_path / "traj.csv", _excitation(delta), delta, rate=100.0)
    out = tmp_path / "log.csv"
    capsys.readouterr()
    code = main(["identify", "simulate", "--set", "l_a=0.25", "--trajectory", str(path), "--out", str(out)])
    line = _one_line(capsys)
    assert code == 2
    assert f"trajectory {path} was excited for a robot 'delta' of other kinematics" in line
    assert not out.exists()


def test_decimation_keeps_a_rate_measured_from_rounded_time_stamps():
    """A 1 kHz log whose time stamps are arange(n) / 1000 written with finite digits measures
    999.99999 Hz, and decimation rounded 24.99999975 down to 24 (a 4 % denser, more correlated set
    of rows than the same log's 25); a ratio within 1e-6 of a whole number is now that number,
    and a rate genuinely below it still rounds down."""
    assert decimation(999.99999, 20.0) == 25
    assert decimation(1000.00001, 20.0) == 25
    assert decimation(1000.0, 20.0) == 25
    assert decimation(990.0, 20.0) == 24  # 24.75: down
    assert decimation(999.9, 20.0) == 24  # 24.9975: 1e-4 off, a rate of its own
    assert decimation(10.0, 20.0) == 1
