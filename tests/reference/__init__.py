"""Readable Python references the compiled core is tested against (docs/architecture.md
section 12): oracles for the tests and benchmarks, never a run-time path of the package (an
import-linter contract forbids ``delta_pin`` from importing ``tests``)."""
