// The sampled loop of the compiled core, one for every plant (plant.hpp).

#include "plant.hpp"

#include "controller.hpp"
#include "failure.hpp"

#include <cmath>
#include <stdexcept>

namespace delta_pin
{
  long CorePlant::run_sampled(
    Vector x, long steps, int substeps, double dt, SampledController & controller, RowsOut q_out, RowsOut v_out,
    RowsOut xyz_out, Eigen::Ref<Vector> gap_out)
  {
    const int nq = this->nq(), nv = this->nv();
    if (
      x.size() != nq + nv || q_out.rows() < steps + 1 || q_out.cols() != nq || v_out.cols() != nv
      || xyz_out.rows() < steps + 1 || gap_out.size() < steps + 1)
      throw std::invalid_argument("run_sampled: the state or the record arrays have the wrong shape");
    const double h = dt / substeps;
    double gap = closure_gap(x.head(nq));
    Vector alpha(actuated_q_.size()), alpha_dot(actuated_v_.size());
    for (long k = 0; k <= steps; ++k)
    {
      for (Eigen::Index i = 0; i < actuated_q_.size(); ++i)
        alpha[i] = x[actuated_q_[i]];
      for (Eigen::Index i = 0; i < actuated_v_.size(); ++i)
        alpha_dot[i] = x[nq + actuated_v_[i]];
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
        throw std::invalid_argument("run_sampled: the control returned a torque of the wrong size");
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
          gap = step(x, tau, 2 * (k * (long)substeps + j), h);
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
