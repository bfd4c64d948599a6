// The sampled loop of the compiled core, one for every plant (plant.hpp).

#include "plant.hpp"

#include "checks.hpp"
#include "controller.hpp"
#include "failure.hpp"
#include "interrupt.hpp"

#include <cmath>
#include <stdexcept>

namespace delta_pin
{
  long CorePlant::run_sampled(
    Vector x, long steps, int substeps, double dt, SampledController & controller, RowsOut q_out, RowsOut v_out,
    RowsOut xyz_out, Eigen::Ref<Vector> gap_out)
  {
    const int nq = this->nq(), nv = this->nv();
    if (steps < 0)
      throw std::invalid_argument("steps is " + std::to_string(steps) + ", expected >= 0");
    if (substeps < 1)
      throw std::invalid_argument("substeps is " + std::to_string(substeps) + ", expected >= 1");
    check_positive(dt, "dt");
    check_size(x, nq + nv, "x");  // [q, v]
    check_finite(x, "x");
    // the records: steps + 1 rows each, written row by row below
    check_shape(q_out, steps + 1, nq, "q");
    check_shape(v_out, steps + 1, nv, "v");
    check_shape(xyz_out, steps + 1, 3, "xyz");
    if (gap_out.size() < steps + 1)
      throw std::invalid_argument(
        "gap has " + std::to_string(gap_out.size()) + " entries, expected at least " + std::to_string(steps + 1));
    const double h = dt / substeps;
    double gap = closure_gap(x.head(nq));
    Vector alpha(actuated_q_.size()), alpha_dot(actuated_v_.size());
    for (long k = 0; k <= steps; ++k)
    {
      poll_interrupt();
      joint_state(x, alpha, alpha_dot);
      Vector tau;
      try
      {
        tau = controller.control(k, x, alpha, alpha_dot);
      }
      catch (SimulationFailure & failure)
      {
        if (std::isnan(failure.time))
          failure.time = k * dt;
        failure_time_ = failure.time;
        throw;
      }
      if (tau.size() != dof())
        throw std::invalid_argument(
          "the control returned a torque of " + std::to_string(tau.size()) + " entries at sample " + std::to_string(k)
          + ", expected " + std::to_string(dof()));
      q_out.row(k) = x.head(nq).transpose();
      v_out.row(k) = x.tail(nv).transpose();
      xyz_out.row(k) = end_effector_position(x.head(nq)).transpose();
      gap_out[k] = gap;
      if (k == steps)
        break;
      for (int j = 0; j < substeps; ++j)
      {
        try
        {
          gap = step(x, tau, k * dt + j * h, h);
        }
        catch (SimulationFailure & failure)
        {
          failure_time_ = failure.time = k * dt + (j + 1) * h;
          throw;
        }
      }
    }
    return steps + 1;
  }
} // namespace delta_pin
