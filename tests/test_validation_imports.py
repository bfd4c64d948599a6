"""``delta-pin validate`` loads only what it needs, and the lazy ``delta_pin`` namespace still
offers every public name (checked in fresh interpreters: imports are process-wide)."""

import subprocess
import sys
import textwrap


def _run(code: str) -> str:
    result = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_validate_command_does_not_import_the_heavy_modules():
    out = _run(
        """
        import sys
        from delta_pin.cli import main
        assert main(["validate", "--samples", "3"]) == 0
        heavy = ["scipy", "numba", "matplotlib", "meshcat", "delta_pin.control", "delta_pin.simulate",
                 "delta_pin.experiments", "delta_pin.trajectory", "delta_pin.fast_model"]
        print("LOADED", [name for name in heavy if name in sys.modules])
        """
    )
    assert "LOADED []" in out and "all checks passed" in out


def test_every_public_name_is_importable_from_the_package():
    _run(
        """
        import importlib
        import delta_pin as dp
        for name in dp.__all__:
            value = getattr(dp, name)
            home = importlib.import_module(value.__module__)
            assert value is getattr(home, name), name
        from delta_pin import PathI, load_delta, simulate  # the from-import form
        assert callable(simulate) and PathI is dp.PathI and load_delta is dp.load_delta
        assert set(dp.__all__) <= set(dir(dp))
        assert dp.kinematics.forward_kinematics is not None  # submodules as attributes
        """
    )


def test_simulate_stays_the_function_when_its_module_is_imported_first():
    _run(
        """
        import delta_pin.simulate
        import delta_pin as dp
        from delta_pin.simulate import simulate
        assert dp.simulate is simulate and callable(dp.simulate)
        """
    )
    _run(
        """
        import delta_pin as dp
        import delta_pin.experiments  # imports delta_pin.simulate inside
        from delta_pin.simulate import simulate
        assert dp.simulate is simulate
        """
    )
