"""Studies: run specifications (:mod:`~delta_pin.studies.experiments`), metrics, the sweep engine
and the Section V reproduction. Imports ``sim`` and below (docs/architecture.md section 2)."""
