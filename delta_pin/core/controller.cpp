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

    // eq. 12 with sgn smoothed by tanh (delta_pin.model.friction.stribeck_torque)
    double stribeck(const FrictionSpec & f, double speed, double normal)
    {
      const double coulomb = f.mu_d * normal, level_static = f.mu_s * normal;
      const double sliding = speed * f.r_a / f.v_s;
      const double sign = f.sign_scale > 0.0 ? std::tanh(speed / f.sign_scale) : (double)((speed > 0.0) - (speed < 0.0));
      const double level = coulomb + (level_static - coulomb) * std::exp(-(sliding * sliding));
      return level * sign * f.r_a + f.mu_v * speed * f.r_a;
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
    if (p_.D.size() != n || p_.T_p.size() != n || p_.T_v.size() != n || p_.disturbance.size() != n)
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
    // C1 + C2 (ComputedTorque.terms)
    const Vector r = alpha - ref_alpha, r_dot = alpha_dot - ref_alpha_dot;
    const Vector a_ref = ref_alpha_ddot - p_.D.cwiseProduct(r_dot);
    const Vector v_ref = ref_alpha_dot - p_.D.cwiseProduct(r);
    Vector compensation = p_.disturbance;
    if (p_.friction.enabled)
      for (Eigen::Index i = 0; i < n; ++i)
        compensation[i] += stribeck(p_.friction, alpha_dot[i], p_.friction.normal_force[i]);
    const Vector c1 = M * a_ref + C * v_ref + G + compensation;
    const Vector c2 = -p_.T_p.cwiseProduct(r) - p_.T_v.cwiseProduct(r_dot);
    const Vector s = r_dot + p_.D.cwiseProduct(r);
    // Lambda of eq. 67 and its gradient (AdaptiveRobustController.bound)
    const double kappa0 = std::sqrt(a_ref.dot(a_ref)), kappa1 = std::sqrt(v_ref.dot(v_ref));
    Vector gradient;
    if (p_.vector_rho)
      gradient = (Vector(3) << kappa0, kappa1, 1.0).finished();
    else
      gradient = (Vector(1) << kappa0 + kappa1 + 1.0).finished();
    if (rho.size() != gradient.size())
      throw std::invalid_argument("rho_hat has the wrong size");
    const double Lambda = gradient.dot(rho);
    const double s_norm = std::sqrt(s.dot(s));
    const double omega_norm = s_norm * Lambda;
    const double xi = p_.xi;
    double phi;
    if (p_.design_two)
      phi = omega_norm / (omega_norm * omega_norm + omega_norm * xi + xi * xi);
    else
      phi = omega_norm > xi ? 1.0 / omega_norm : 1.0 / xi;
    double gain = phi * Lambda * Lambda;
    Vector c3;
    if (p_.sampling_period <= 0.0)
      c3 = -gain * s;
    else  // per inertia direction: k_j = min(gain, margin mu_j / T - T_v)
    {
      Eigen::SelfAdjointEigenSolver<Matrix> eigen(M);
      const Vector & inertia = eigen.eigenvalues();
      const Matrix & directions = eigen.eigenvectors();
      const double t_v_max = p_.T_v.maxCoeff();
      Vector gains(n);
      for (Eigen::Index j = 0; j < n; ++j)
        gains[j] = std::min(gain, std::max(p_.sampling_margin * inertia[j] / p_.sampling_period - t_v_max, 0.0));
      c3 = -(directions * gains.cwiseProduct(directions.transpose() * s));
      gain = gains.minCoeff();
    }
    // the adaptive law, eq. 24 with the dead-zone of eq. 25 (AdaptiveRobustController.adaptation_rate)
    const Vector leak = (p_.b2 * std::exp(-s_norm) + p_.b3) * rho;
    const bool active = s_norm * std::sqrt(gradient.dot(gradient)) > p_.epsilon;
    rho_dot = active ? Vector(p_.beta * (p_.b1 * gradient * s_norm - leak)) : Vector(-p_.beta * leak);
    tau = c1 + c2 + c3;
    last_Lambda_ = Lambda;
    last_gain_ = gain;
    last_omega_norm_ = omega_norm;
    last_active_ = active ? 1.0 : 0.0;
    last_robust_ = c3;
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
