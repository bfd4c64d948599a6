// A simulation that cannot go on, with the simulated time [s] at which it stopped (Python sees
// delta_pin.compiled._core.SimulationFailure and raises delta_pin's SimulationError from it).
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace delta_pin
{
  struct SimulationFailure : std::runtime_error
  {
    explicit SimulationFailure(const std::string & message)
    : std::runtime_error(message)
    {
    }
    double time = std::nan("");
  };

  // a failure at the simulated time t [s]
  inline SimulationFailure failure_at(const std::string & message, double t)
  {
    SimulationFailure failure(message);
    failure.time = t;
    return failure;
  }

  // "[a, b, c]" at full precision, for the messages
  inline std::string joint_values(const Eigen::VectorXd & values)
  {
    std::ostringstream text;
    text.precision(17);
    text << "[";
    for (Eigen::Index i = 0; i < values.size(); ++i)
      text << (i ? ", " : "") << values[i];
    text << "]";
    return text.str();
  }

  // The loops' check of a sample at t [s] (delta_pin.sim.integrators.check_state): the state
  // finite, |alpha_dot| within max_joint_speed [rad/s]
  inline void check_sample(
    bool finite, const Eigen::VectorXd & alpha, const Eigen::VectorXd & alpha_dot, double max_joint_speed, double t)
  {
    if (!finite)
      throw failure_at("the state became non-finite (alpha=" + joint_values(alpha) + ")", t);
    const double speed = alpha_dot.size() ? alpha_dot.cwiseAbs().maxCoeff() : 0.0;  // none: no motor
    if (!(speed <= max_joint_speed))
    {
      std::ostringstream text;
      text.precision(3);  // Python's {speed:.3g} and {limit:g} (delta_pin.sim.integrators.check_state)
      text << "the run diverged: |alpha_dot| = " << speed << " rad/s > ";
      text.precision(6);
      text << max_joint_speed << " rad/s";
      throw failure_at(text.str(), t);
    }
  }

  // An error raised by a caller's callback inside a compiled loop (a Python controller): the
  // loops let it pass unchanged, and the binding that called the loop re-raises the caller's own
  // error.
  struct CallbackError : std::runtime_error
  {
    CallbackError()
    : std::runtime_error("the callback raised")
    {
    }
  };
} // namespace delta_pin
