"""Shared fixtures: robots are compiled once per session (compiling a xacro takes ~0.1 s)."""

import numpy as np
import pytest

import delta_pin as dp

# Dimension and mass sets besides Table 1 used across tests (SI units).
OTHER_ROBOTS = {
    "long_arms": {"l_a": 0.25, "l_b": 0.5, "m_o": 0.5},
    "wide_base": {"R": 0.2, "r": 0.05, "m_a": 0.35, "m_b": 0.1},
    "heavy_platform": {"R": 0.1, "r": 0.06, "l_a": 0.15, "l_b": 0.35, "m_o": 2.0, "m_b": 0.3},
}


@pytest.fixture(scope="session")
def robot():
    """The paper's Table 1 robot."""
    return dp.load_delta()


@pytest.fixture(scope="session", params=sorted(OTHER_ROBOTS))
def other_robot(request):
    return dp.load_delta(**OTHER_ROBOTS[request.param])


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
