"""The controllers' declarations (delta_pin.control.registry) say what each built law does: each
declaration is checked against the object it builds, and every reader of a declaration (RunSpec,
the sweeps' cost estimate, run --robot, the labels) against it (issue 38, item 3)."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.choices import CONTROLLERS as NAMES
from delta_pin.cli import main
from delta_pin.control.registry import CONTROLLERS, LawOptions, declaration, label
from delta_pin.errors import InvalidParameterError
from delta_pin.studies.closed_chain_run import closed_chain_controller
from delta_pin.studies.experiments import RunSpec, build_controller
from delta_pin.studies.sweep import estimated_cost


@pytest.fixture(scope="module")
def delta():
    return dp.load_delta()


def test_one_list_of_names():
    assert tuple(CONTROLLERS) == NAMES


@pytest.mark.parametrize("name", NAMES)
def test_each_declaration_says_what_its_law_does(delta, name):
    """What the run-time reads from the declaration is what the built controller does: its class,
    discrete (a period dt: simulate takes it in sampled mode only), a compiled law for the core's
    continuous loop (compiled_continuous) and the name its runs carry."""
    law = declaration(name)
    controller = law.make(dp.DeltaNominalModel(delta), LawOptions(start=delta.home))
    assert type(controller) is law.law
    assert (getattr(controller, "dt", None) is not None) == law.discrete
    compiled = not law.discrete and controller.sampled_core_law() is not None
    assert compiled == law.compiled_continuous
    assert controller.name == (law.run_name or law.name)
    assert label(controller.name) == label(name) == law.label


@pytest.mark.parametrize("name", NAMES)
def test_a_switch_a_law_has_not_is_refused_for_that_law_alone(name):
    """friction_compensation=False for TDC (which has no friction term) and sampling_aware=True for
    a law without a robust gain to cap used to be dropped silently by ``run``; each law that has the
    switch still takes it, and a study of several laws (a RunSpec each) sets it where it applies."""
    law = declaration(name)
    for switch, value in (("friction_compensation", False), ("sampling_aware", True)):
        RunSpec(controller=name, mode="sampled", **{switch: value})  # compare, sweep
        if switch in law.options:
            law.check_options(**{switch: value})
        else:
            with pytest.raises(InvalidParameterError, match=f"controller '{name}' has no {switch} switch"):
                law.check_options(**{switch: value})


def test_the_cli_refuses_a_switch_the_law_has_not_in_one_line(tmp_path, capsys):
    code = main(["run", "--controller", "tdc", "--no-friction-compensation", "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "controller 'tdc' has no friction_compensation switch" in err[0]


def test_switches_reach_the_law(delta):
    spec = RunSpec(controller="digital-robust", mode="sampled", friction_compensation=False, delay=1)
    controller = build_controller(spec, delta)
    assert controller.friction_compensation is False and controller.delay == 1
    aware = build_controller(
        RunSpec(controller="design2", mode="sampled", sampling_aware=True, dt=2e-3), delta
    )
    assert aware.sampling_period == 2e-3  # the robust gain capped for this dt
    assert build_controller(RunSpec(controller="design2", mode="sampled"), delta).sampling_period is None


def test_the_sweeps_cost_estimate_reads_the_declarations():
    """A continuous CTC or PD run is as cheap as design I's (all compiled); before, the sweep's own
    list (designs I/II and the LQR) priced them as LSODA runs, 10 times dearer."""
    design = estimated_cost(RunSpec(controller="design1"))
    for name in ("ctc", "pd", "lqr"):
        assert estimated_cost(RunSpec(controller=name)) == pytest.approx(design, rel=1e-12)


def test_a_closed_chain_robot_builds_every_law_by_its_declaration():
    robot = dp.load_robot("five_bar")
    for name in NAMES:
        controller = closed_chain_controller(name, robot, 1e-3)
        assert type(controller) is declaration(name).law
        if "sampling_aware" not in declaration(name).options:  # run --robot --sampling-aware
            with pytest.raises(InvalidParameterError, match="has no sampling_aware switch"):
                closed_chain_controller(name, robot, 1e-3, sampling_aware=True)
    lqr = closed_chain_controller("lqr", robot, 1e-3)
    np.testing.assert_array_equal(lqr.alpha0, robot.home)
    with pytest.raises(InvalidParameterError, match="controller 'nope' must be one of design1, design2"):
        closed_chain_controller("nope", robot, 1e-3)


@pytest.mark.parametrize("name", NAMES)
def test_each_law_takes_the_gains_its_declaration_names(delta, name):
    """Every name gain_names() lists is a keyword the law takes (set to its own default, the law
    builds), and an unknown one is refused naming the valid ones (issue 39: "a wrong gain name
    does not list the valid ones"; rho0, design I's starting rho_hat, was in neither help nor README)."""
    law = declaration(name)
    names = law.gain_names()
    assert names and len(names) == len(set(names))
    built = build_controller(RunSpec(controller=name, mode="sampled"), delta)
    for gain in names:  # each one, at the value the default law holds
        value = getattr(getattr(built, "gains", built), gain, None)
        if value is None:
            continue  # a derived or optional gain (e.g. TDC's bandwidth is kept as K_p, K_v)
        build_controller(RunSpec(controller=name, mode="sampled", gains={gain: value}), delta)
    with pytest.raises(InvalidParameterError, match=f"controller '{name}' has no gain ksi; its gains: "):
        build_controller(RunSpec(controller=name, mode="sampled", gains={"ksi": 1.0}), delta)
    if name in ("design1", "design2"):
        assert "rho0" in names and "xi" in names
