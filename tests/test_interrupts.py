"""Ctrl-C or SIGTERM that lands inside a compiled call (numba's, issue 25) can surface as ``SystemError: ...
returned a result with an exception set`` carrying the KeyboardInterrupt (issue 25: 2 of 17
interrupted runs exited 1 with that error, and a serial sweep recorded the interrupt as a failed
point and ran on). Here such an error is made the way CPython makes it, and the command and the
sweep must treat it as the interrupt."""

import pytest

from delta_pin import cli
from delta_pin.studies import sweep
from delta_pin.utils.interrupts import interrupt_of


def _interrupted_compiled_call() -> SystemError:
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as interrupt:
            raise SystemError(
                "CPUDispatcher(<function f>) returned a result with an exception set"
            ) from interrupt
    except SystemError as error:
        return error


def test_the_interrupt_is_found_inside_the_system_error():
    error = _interrupted_compiled_call()
    assert isinstance(interrupt_of(error), KeyboardInterrupt)
    assert interrupt_of(SystemError("a real one")) is None
    assert interrupt_of(ValueError("x")) is None


def test_a_command_interrupted_inside_a_compiled_call_exits_130_with_its_line(monkeypatch, capsys, tmp_path):
    def run_command(args):
        raise _interrupted_compiled_call()

    monkeypatch.setattr(cli, "_cmd_run", run_command)  # build_parser reads it when it builds
    assert cli.main(["run", "--t-end", "0.01", "--out", str(tmp_path / "x")]) == cli.EXIT_INTERRUPTED
    err = capsys.readouterr().err
    assert err.strip() == "delta-pin run: interrupted" and "SystemError" not in err


def test_a_sweep_point_interrupted_inside_a_compiled_call_stops_the_sweep(monkeypatch):
    def run_spec(spec, robot):
        raise _interrupted_compiled_call()

    monkeypatch.setattr(sweep, "run_spec", run_spec)
    with pytest.raises(KeyboardInterrupt):
        sweep.evaluate_spec({"controller": "design1", "t_end": 0.01}, None)
