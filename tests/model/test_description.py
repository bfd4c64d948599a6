"""The xacro compiles, its parameters are read back from the URDF, bad input is refused."""

import math

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.model.description import (
    chain_azimuths,
    compile_urdf,
    default_xacro_path,
    read_description,
    xacro_arguments,
)


def test_table1_parameters_are_read_from_the_urdf(robot):
    p = robot.params
    assert (p.R, p.r, p.l_a, p.l_b, p.m_a, p.m_b, p.m_o, p.g) == pytest.approx(
        (0.15, 0.08, 0.2, 0.4, 0.2, 0.2, 0.3, 9.8), rel=1e-14
    )
    assert p.forearm_inertia == "lumped"
    assert p.upper_arm_inertia == pytest.approx(p.m_a * p.l_a**2 / 3.0, rel=1e-14)
    assert p.friction == dp.StribeckParameters(r_a=0.04, v_s=0.1, mu_s=0.2, mu_d=0.1, mu_v=2.0)


def test_xacro_arguments_change_every_number():
    robot = dp.load_delta(
        R=0.21, r=0.07, l_a=0.26, l_b=0.55, m_a=0.31, m_b=0.12, m_o=0.9, forearm_inertia="rod", r_a=0.05
    )
    p = robot.params
    assert (p.R, p.r, p.l_a, p.l_b, p.m_a, p.m_b, p.m_o) == pytest.approx(
        (0.21, 0.07, 0.26, 0.55, 0.31, 0.12, 0.9), rel=1e-14
    )
    assert p.forearm_inertia == "rod"
    assert p.friction.r_a == 0.05


def test_chain_azimuths_match_the_paper():
    assert chain_azimuths() == pytest.approx([math.pi / 6, 5 * math.pi / 6, 3 * math.pi / 2])


def test_hand_written_urdf_file_is_read_the_same(tmp_path, robot):
    path = tmp_path / "my_delta.urdf"
    path.write_text(compile_urdf(l_a=0.23))
    mine = dp.load_delta(urdf=path)
    assert mine.params.l_a == pytest.approx(0.23, rel=1e-14)
    assert mine.params.R == robot.params.R


def test_xacro_file_path_is_compiled():
    robot = dp.load_delta(urdf=default_xacro_path())
    assert robot.params.l_b == pytest.approx(0.4)


def test_shipped_default_urdf_is_up_to_date():
    shipped = default_xacro_path().with_name("delta.urdf").read_text()
    assert shipped == compile_urdf(), "regenerate with: delta-pin urdf > delta_pin/urdf/delta.urdf"


def test_loop_closures_are_point_constraints(robot):
    closures = robot.description.closures
    assert [c.name for c in closures] == ["closure_1", "closure_2", "closure_3"]
    for closure, phi in zip(closures, chain_azimuths()):
        assert closure.kind == "3d"
        assert closure.placement1.translation == pytest.approx((0, 0, -0.4))
        assert closure.placement2.translation == pytest.approx(
            (0.08 * math.cos(phi), 0.08 * math.sin(phi), 0), abs=1e-15
        )


@pytest.mark.parametrize("name", ["R", "r", "l_a", "l_b", "m_a", "m_b", "m_o"])
@pytest.mark.parametrize("value", [0.0, -0.1])
def test_non_positive_length_or_mass_is_refused(name, value):
    with pytest.raises(dp.XacroArgumentError, match=f"{name}="):
        dp.load_delta(**{name: value})


@pytest.mark.parametrize("value", ["nan", "inf", "abc"])
def test_non_finite_or_non_numeric_argument_is_refused(value):
    with pytest.raises(dp.XacroArgumentError, match="l_a="):
        dp.load_delta(l_a=value)


def test_unknown_xacro_argument_is_refused_and_known_ones_listed():
    with pytest.raises(dp.XacroArgumentError, match=r"'arm_length'.*known arguments: R, r, l_a"):
        dp.load_delta(arm_length=0.3)
    assert set(xacro_arguments()) >= {"R", "r", "l_a", "l_b", "m_a", "m_b", "m_o", "forearm_inertia"}


def test_unknown_forearm_inertia_model_is_refused():
    with pytest.raises(dp.XacroArgumentError, match="forearm_inertia='beam'"):
        dp.load_delta(forearm_inertia="beam")


def test_geometry_that_cannot_assemble_is_refused():
    with pytest.raises(dp.AssemblyError, match=r"l_b=0\.05"):
        dp.load_delta(l_b=0.05)


def test_closure_naming_a_missing_link_is_refused():
    urdf = compile_urdf().replace('<child link="platform"/>', '<child link="plate"/>', 1)
    with pytest.raises(dp.URDFConventionError, match="'plate'"):
        read_description(urdf)


def test_urdf_without_a_closure_is_refused():
    urdf = compile_urdf()
    start = urdf.index('<constraint name="closure_2"')
    end = urdf.index("</constraint>", start) + len("</constraint>")
    with pytest.raises(dp.URDFConventionError, match="forearm_2"):
        read_description(urdf[:start] + urdf[end:])


def test_missing_urdf_file_is_refused(tmp_path):
    with pytest.raises(dp.URDFConventionError, match="does not exist"):
        dp.load_delta(urdf=tmp_path / "nope.urdf")


def test_non_positive_gravity_is_refused():
    with pytest.raises(dp.InvalidParameterError, match=r"g=-9\.8"):
        dp.load_delta(g=-9.8)


def test_mass_read_from_the_inertial_not_the_argument():
    urdf = compile_urdf().replace('<mass value="0.3"/>', '<mass value="0.45"/>')
    assert read_description(urdf).params.m_o == pytest.approx(0.45)
    assert np.isclose(read_description(compile_urdf()).params.m_o, 0.3)
