// The controllers of the compiled core: one interface for the sampled loop
// (ClosedChainPlant::run_sampled), which every law implements -- a C++ law, or a Python
// callable behind an adapter (delta_pin/core/module.cpp).
#pragma once

#include "closed_chain.hpp"
#include "control/adaptive_robust_law.hpp"

#include <Eigen/Dense>

#include <functional>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

namespace delta_pin
{
  // A law sampled once per period: the torque held over sample k from the plant state x and its
  // actuated joints. It may throw SimulationFailure (a bad torque, a diverged state) with the
  // sample's time.
  class SampledController
  {
  public:
    virtual ~SampledController() = default;
    virtual Vector control(long k, const Vector & x, const Vector & alpha, const Vector & alpha_dot) = 0;
  };

  // A law given as a function of (k, x): the Python controller of run_python_loop.
  class FunctionController : public SampledController
  {
  public:
    explicit FunctionController(std::function<Vector(long, const Vector &)> function)
    : function_(std::move(function))
    {
    }
    Vector control(long k, const Vector & x, const Vector &, const Vector &) override { return function_(k, x); }

  private:
    std::function<Vector(long, const Vector &)> function_;
  };

  // Designs I and II (eqs. 23-26, 30-33, 54-57, 67) on the projected nominal model of a closed
  // chain, with the same arithmetic as AdaptiveRobustController.evaluate_reference
  // (delta_pin/control/adaptive_robust.py): C1 + C2 (computed torque with F̄ and the nominal
  // friction), the robust term phi Lambda^2 s (sampling-aware cap per inertia direction where a
  // sampling period is given) and rho_hat's adaptive law, advanced once per sample by explicit
  // Euler (Controller.advance). The reference comes as a table of the samples.
  struct AdaptiveRobustParameters
  {
    AdaptiveRobustGains<Eigen::Dynamic> gains;  // D, T_p, T_v per actuated joint, beta, xi, ...
    Vector disturbance;  // F̄ [N m]
    FrictionSpec friction;  // the nominal friction, applied where enabled (friction compensation)
    std::string name = "designI";  // what a refusal calls the controller
  };

  class AdaptiveRobust : public SampledController
  {
  public:
    AdaptiveRobust(
      const std::string & model_text,
      const std::vector<ClosureFrames> & closures,
      const Indices & actuated_q,
      const Indices & actuated_v,
      const Indices & dependent_v,
      pinocchio::FrameIndex end_effector,
      const Vector & reference_configuration,
      const AdaptiveRobustParameters & parameters);

    // the reference per sample (rows: alpha^d, alpha_dot^d, alpha_ddot^d), the sample period
    // [s], the initial rho_hat and the number of samples to record
    void start(const RowMatrix & alpha_d, const RowMatrix & alpha_dot_d, const RowMatrix & alpha_ddot_d, double dt,
               const Vector & rho0, long samples, double max_joint_speed);
    Vector control(long k, const Vector & x, const Vector & alpha, const Vector & alpha_dot) override;
    void set_friction(const FrictionSpec & friction);
    // the last evaluation's (Lambda, robust gain, ||omega||, adaptation active, robust torque)
    std::tuple<double, double, double, double, Vector> internals() const
    {
      return {last_Lambda_, last_gain_, last_omega_norm_, last_active_, last_robust_};
    }

    // one evaluation: tau, rho_dot and the internals (Lambda, gain, ||omega||, c3, active)
    void evaluate(const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
                  const Vector & ref_alpha_ddot, const Vector & rho, Vector & tau, Vector & rho_dot);

    // the records of the last run (samples rows)
    RowMatrix tau, rho_hat, robust_torque;
    Vector Lambda, robust_gain, omega_norm, adaptation_active;

  private:
    ClosedChainModel nominal_;
    AdaptiveRobustParameters p_;
    Vector q_;  // the nominal model's last assembly (warm start)
    RowMatrix alpha_d_, alpha_dot_d_, alpha_ddot_d_;
    double dt_ = 0.0, max_joint_speed_ = 1e3;
    Vector rho_, rho_dot_;
    // the last evaluation's internals
    double last_Lambda_ = 0.0, last_gain_ = 0.0, last_omega_norm_ = 0.0, last_active_ = 0.0;
    Vector last_robust_;
  };
} // namespace delta_pin
