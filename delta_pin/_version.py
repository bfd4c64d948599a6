"""The version of delta-pin (one home: the package, its manifests and pyproject.toml agree; a test checks)."""

__version__ = "0.1.0"
