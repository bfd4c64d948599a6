"""``delta-pin validate`` loads only what it needs, and the lazy ``delta_pin`` namespace still
offers every public name (checked in fresh interpreters: imports are process-wide)."""

import subprocess
import sys
import textwrap

import pytest


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
        heavy = ["scipy", "matplotlib", "meshcat", "delta_pin.control", "delta_pin.sim.runner",
                 "delta_pin.studies.experiments", "delta_pin.model.trajectory"]
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
        assert dp.model.kinematics.forward_kinematics is not None  # the layers as attributes
        """
    )


def test_no_module_shadows_a_public_name():
    """Importing every module of the package leaves each public name bound to its object (no
    submodule is named like a public function)."""
    _run(
        """
        import importlib, pkgutil
        import delta_pin as dp
        before = {name: getattr(dp, name) for name in dp.__all__}
        for module in pkgutil.walk_packages(dp.__path__, "delta_pin."):
            if module.name != "delta_pin.__main__":
                importlib.import_module(module.name)
        assert all(getattr(dp, name) is value for name, value in before.items())
        assert callable(dp.simulate) and callable(dp.simulate_batch)
        """
    )


@pytest.mark.parametrize("command", ["urdf", "validate", "run", "view", "compare", "sweep", "reproduce"])
def test_help_loads_no_heavy_module(command):
    """``delta-pin CMD --help`` lists every choice without importing SciPy or Pinocchio
    (issue 14: it took 2.4 s when the choices lived in the modules that implement them)."""
    import subprocess
    import sys

    code = (
        "import sys\nfrom delta_pin.cli import main\n"
        f"try:\n    main([{command!r}, '--help'])\nexcept SystemExit:\n    pass\n"
        "loaded = {m.split('.')[0] for m in sys.modules}\n"
        "heavy = sorted(loaded & {'scipy', 'pinocchio', 'matplotlib'})\n"
        "print('HEAVY', heavy)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    )
    assert "HEAVY []" in result.stdout, result.stdout[-300:]
    assert "--help" in result.stdout or "usage:" in result.stdout


def test_the_version_has_one_home_that_pyproject_agrees_with():
    """delta_pin.__version__ (what every manifest records) is pyproject.toml's version."""
    import re
    from pathlib import Path

    import delta_pin
    from delta_pin._version import __version__

    text = (Path(__file__).resolve().parents[1] / "pyproject.toml").read_text()
    (version,) = re.findall(r'(?m)^version = "([^"]+)"$', text)  # [project]'s (tomllib is 3.11+)
    assert delta_pin.__version__ == __version__ == version


def test_the_package_never_imports_the_tests():
    """The readable references live in tests/ as oracles, never as run-time code (issue 38): no
    module of delta_pin imports ``tests`` (import-linter sees only delta_pin's own modules, so the
    check reads every module's imports here). It fails on a planted ``from tests import x``."""
    import ast
    from pathlib import Path

    def imports_tests(source: str) -> bool:
        for node in ast.walk(ast.parse(source)):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            if any(name == "tests" or name.startswith("tests.") for name in names):
                return True
        return False

    assert imports_tests("from tests.reference import loop") and imports_tests("import tests")
    package = Path(__file__).resolve().parents[1] / "delta_pin"
    offenders = [str(p.relative_to(package)) for p in package.rglob("*.py") if imports_tests(p.read_text())]
    assert offenders == []
