"""Install-time compilation (issue 14): nothing is compiled at a user's first run.

``pip install`` builds the package in an isolated environment holding the run-time dependencies
(``[build-system] requires`` in pyproject.toml lists them, pinned as the run-time ones), and this
hook adds two steps to setuptools' ``build_py``:

1. the native tree dynamics (``delta_pin/compiled/native/tree_dynamics.cpp``) compiled against that
   environment's ``pin`` into ``delta_pin/compiled/native/prebuilt/``, with a stamp of the source,
   the flags and the Pinocchio version; at run time the library is used where the stamp matches
   the installed Pinocchio, else built on first use as before (a different ``pin`` installed
   later, an edited source);
2. for an editable install (the README's), ``python -m delta_pin.warmup``: numba compiles every
   kernel once and writes its caches beside the sources, where the installed package finds them.
   A regular wheel carries the library but not the caches (numba keys them to the source files'
   paths): its first run compiles the kernels.

Either step failing (no C++ compiler, say) prints why and leaves the first-use path in place.
``DELTA_PIN_INSTALL_COMPILE=0`` skips both.
"""

import os
import subprocess
import sys
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent


def _python(code_or_module: list[str]) -> int:
    environment = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, *code_or_module], cwd=ROOT, env=environment).returncode


class BuildPyCompiled(build_py):
    """setuptools' build_py, then the native library and (editable installs) numba's caches."""

    def run(self):
        super().run()
        if os.environ.get("DELTA_PIN_INSTALL_COMPILE", "1") == "0":
            return
        editable = bool(getattr(self, "editable_mode", False))
        base = ROOT if editable else Path(self.build_lib)
        target = base / "delta_pin" / "compiled" / "native" / "prebuilt"
        print(f"delta-pin: compiling the native tree dynamics into {target} (~50 s)", flush=True)
        code = (
            "from pathlib import Path; from delta_pin.compiled import native; "
            f"native.build_prebuilt(Path({str(target)!r}))"
        )
        if _python(["-c", code]) != 0:
            print("delta-pin: the native library was not built; it will be at first use", flush=True)
            return
        if editable:
            print("delta-pin: compiling the numba kernels once (~90 s)", flush=True)
            if _python(["-m", "delta_pin.warmup"]) != 0:
                print("delta-pin: the kernels will compile at first use instead", flush=True)


class BinaryDistribution(Distribution):
    """A wheel that carries a compiled library is tagged for its platform, not ``py3-none-any``."""

    def has_ext_modules(self):
        return True


setup(cmdclass={"build_py": BuildPyCompiled}, distclass=BinaryDistribution)
