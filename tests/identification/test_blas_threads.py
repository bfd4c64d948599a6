"""identify and validate run their least-squares problems on one BLAS thread (issue 37's "the fit
<= 2 s"): on the MuJoCo benchmark's 20 s log the fit took 6.8-9.5 s with OpenBLAS's threads while
two other processes kept the 2 cores busy, 1.1-1.4 s on one thread (0.7-0.9 s against 0.9-1.2 s on
an idle machine; docs/benchmarks.md). The caller's own thread count is left as it was."""

import threadpoolctl

import delta_pin.identification.workflow as workflow
from delta_pin.identification.workflow import identify, simulate_log, validate
from tests.identification.delta_excitation import delta_excitation


def _blas_threads() -> list[int]:
    return [pool["num_threads"] for pool in threadpoolctl.threadpool_info() if pool["user_api"] == "blas"]


def test_the_fit_and_its_validation_take_one_blas_thread(monkeypatch):
    nominal, true, _, _, trajectory = delta_excitation()
    log, _ = simulate_log(true, trajectory, nominal=nominal, seed=1)
    seen = []
    fit = workflow.least_squares_fit

    def watched(*arguments, **options):
        seen.append(_blas_threads())
        return fit(*arguments, **options)

    monkeypatch.setattr(workflow, "least_squares_fit", watched)
    before = _blas_threads()
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):  # a caller with 2 threads
        outside = _blas_threads()
        result = identify(nominal, log)
        validation = validate(result, log)
        assert _blas_threads() == outside  # the caller's setting is back
    assert seen and all(threads == [1] * len(threads) for threads in seen)
    assert validation["away_from_reversals"]["rms_relative"] is not None
    assert _blas_threads() == before
