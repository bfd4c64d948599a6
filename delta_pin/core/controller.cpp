// Designs I and II on a closed chain's projected nominal model (controller.hpp).

#include "controller.hpp"

#include "failure.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace delta_pin
{
  namespace
  {
    std::string joints(const Vector & values)
    {
      std::ostringstream text;
      text.precision(17);
      text << "[";
      for (Eigen::Index i = 0; i < values.size(); ++i)
        text << (i ? ", " : "") << values[i];
      text << "]";
      return text.str();
    }

  } // namespace

  AdaptiveRobust::AdaptiveRobust(
    const std::string & model_text,
    const std::vector<ClosureFrames> & closures,
    const Indices & actuated_q,
    const Indices & actuated_v,
    const Indices & dependent_v,
    pinocchio::FrameIndex end_effector,
    const Vector & reference_configuration,
    const AdaptiveRobustParameters & parameters)
  : nominal_(model_text, closures, actuated_q, actuated_v, dependent_v, end_effector)
  , p_(parameters)
  , q_(reference_configuration)
  {
    const Eigen::Index n = nominal_.dof();
    const AdaptiveRobustGains<Eigen::Dynamic> & g = p_.gains;
    if (g.D.size() != n || g.T_p.size() != n || g.T_v.size() != n || p_.disturbance.size() != n)
      throw std::invalid_argument("the gains D, T_p, T_v and the disturbance need one value per actuated joint");
    if (p_.friction.enabled && p_.friction.normal_force.size() != n)
      throw std::invalid_argument("the nominal friction needs one normal force per actuated joint");
    if (q_.size() != nominal_.model().nq)
      throw std::invalid_argument("the reference configuration has the wrong size");
    last_robust_ = Vector::Zero(n);
  }

  void AdaptiveRobust::evaluate(
    const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
    const Vector & ref_alpha_ddot, const Vector & rho, Vector & tau, Vector & rho_dot)
  {
    const Eigen::Index n = nominal_.dof();
    Vector q;
    if (!nominal_.configuration(alpha, q_, q))
      throw SimulationFailure("the nominal model's loops do not close at alpha=" + joints(alpha));
    q_ = q;
    Matrix M, C;
    Vector G, C_alpha_dot;
    nominal_.reduced_terms(q, alpha_dot, M, C, G, C_alpha_dot);
    Vector compensation = p_.disturbance;
    if (p_.friction.enabled)
      for (Eigen::Index i = 0; i < n; ++i)
        compensation[i] += p_.friction.torque(alpha_dot[i], p_.friction.normal_force[i]);
    if (rho.size() != (p_.gains.vector_rho ? 3 : 1))
      throw std::invalid_argument("rho_hat has the wrong size");
    RhoVector rho_hat = rho, rate;
    AdaptiveRobustInternals<Eigen::Dynamic> info;
    adaptive_robust_law<Eigen::Dynamic>(
      p_.gains, M, C, G, compensation, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho_hat, tau, rate,
      info);
    rho_dot = rate;
    last_Lambda_ = info.Lambda;
    last_gain_ = info.robust_gain;
    last_omega_norm_ = info.omega_norm;
    last_active_ = info.adaptation_active;
    last_robust_ = info.robust_torque;
  }

  void AdaptiveRobust::set_friction(const FrictionSpec & friction)
  {
    if (friction.enabled && friction.normal_force.size() != nominal_.dof())
      throw std::invalid_argument("the nominal friction needs one normal force per actuated joint");
    p_.friction = friction;
  }

  void AdaptiveRobust::start(
    const RowMatrix & alpha_d, const RowMatrix & alpha_dot_d, const RowMatrix & alpha_ddot_d, double dt,
    const Vector & rho0, long samples, double max_joint_speed)
  {
    const Eigen::Index n = nominal_.dof();
    if (alpha_d.rows() < samples || alpha_dot_d.rows() < samples || alpha_ddot_d.rows() < samples
        || alpha_d.cols() != n || alpha_dot_d.cols() != n || alpha_ddot_d.cols() != n)
      throw std::invalid_argument("the reference table needs one row per sample and one column per actuated joint");
    alpha_d_ = alpha_d;
    alpha_dot_d_ = alpha_dot_d;
    alpha_ddot_d_ = alpha_ddot_d;
    dt_ = dt;
    max_joint_speed_ = max_joint_speed;
    rho_ = rho0;
    rho_dot_ = Vector::Zero(rho0.size());
    tau.setZero(samples, n);
    rho_hat.setZero(samples, rho0.size());
    robust_torque.setZero(samples, n);
    Lambda.setZero(samples);
    robust_gain.setZero(samples);
    omega_norm.setZero(samples);
    adaptation_active.setZero(samples);
  }

  Vector AdaptiveRobust::control(long k, const Vector & x, const Vector & alpha, const Vector & alpha_dot)
  {
    if (k >= tau.rows())
      throw std::invalid_argument("AdaptiveRobust::control beyond the samples of start()");
    const double t = k * dt_;
    if (k > 0)
    {
      rho_ += dt_ * rho_dot_;  // Controller.advance: explicit Euler once per sample
      bool finite = x.allFinite() && rho_.allFinite();
      if (!finite)
      {
        SimulationFailure failure("the state became non-finite (alpha=" + joints(alpha) + ")");
        failure.time = t;
        throw failure;
      }
      const double speed = alpha_dot.cwiseAbs().maxCoeff();
      if (!(speed <= max_joint_speed_))
      {
        std::ostringstream text;
        text.precision(3);
        text << "the run diverged: |alpha_dot| = " << speed << " rad/s > " << max_joint_speed_ << " rad/s";
        SimulationFailure failure(text.str());
        failure.time = t;
        throw failure;
      }
    }
    Vector torque;
    try
    {
      evaluate(alpha, alpha_dot, alpha_d_.row(k).transpose(), alpha_dot_d_.row(k).transpose(),
               alpha_ddot_d_.row(k).transpose(), rho_, torque, rho_dot_);
    }
    catch (SimulationFailure & failure)
    {
      failure.time = t;
      throw;
    }
    if (!torque.allFinite())
    {
      SimulationFailure failure("controller '" + p_.name + "' returned a non-finite torque " + joints(torque));
      failure.time = t;
      throw failure;
    }
    tau.row(k) = torque.transpose();
    rho_hat.row(k) = rho_.transpose();
    robust_torque.row(k) = last_robust_.transpose();
    Lambda[k] = last_Lambda_;
    robust_gain[k] = last_gain_;
    omega_norm[k] = last_omega_norm_;
    adaptation_active[k] = last_active_;
    return torque;
  }
} // namespace delta_pin
