"""The identification tests' shared case: the CAD Delta, a true one whose masses are off the CAD
file's by +30 %, -30 %, +30 %, and a 3 s excitation about home + 0.3 rad (6 harmonics, not
optimised: max_iterations=0, so it is the same on every machine)."""

import delta_pin as dp
from delta_pin.identification.base import base_parameters
from delta_pin.identification.excitation import ExcitationLimits, optimize_excitation
from delta_pin.identification.regressor import ClosedChainRegressor


def delta_excitation():
    """(nominal robot, true robot, regressor, base parameters, 3 s trajectory)."""
    nominal = dp.load_delta()
    true = dp.load_delta(m_a=0.26, m_b=0.14, m_o=0.39)
    regressor = ClosedChainRegressor(nominal)
    base = base_parameters(regressor, count=80)
    trajectory, _ = optimize_excitation(regressor, base, regressor.parameters(), alpha0=nominal.home + 0.3,
                                        limits=ExcitationLimits(position_range=0.6), max_iterations=0,
                                        period=3.0, duration=3.0, harmonics=6)  # fmt: skip
    return nominal, true, regressor, base, trajectory
