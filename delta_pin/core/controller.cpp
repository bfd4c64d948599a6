// The sampled laws on a closed chain's projected nominal model (controller.hpp): ProjectedLaw with
// its drive, designs I/II, computed torque, PD + gravity, time-delay control, digital-robust, LQR.

#include "controller.hpp"

#include "failure.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace delta_pin
{
  ProjectedLaw::ProjectedLaw(
    const ChainDescription & chain, const Vector & reference_configuration, const Vector & disturbance, const std::string & name)
  : nominal_(chain)
  , q_(reference_configuration)
  , disturbance_(disturbance)
  , name_(name)
  {
    if (disturbance_.size() != nominal_.dof())
      throw std::invalid_argument("the disturbance needs one value per actuated joint");
    if (q_.size() != nominal_.model().nq)
      throw std::invalid_argument("the reference configuration has the wrong size");
    friction_.normal_force = Vector::Zero(nominal_.dof());
  }

  void ProjectedLaw::set_friction(const FrictionSpec & friction)
  {
    if (friction.enabled && friction.normal_force.size() != nominal_.dof())
      throw std::invalid_argument("the nominal friction needs one normal force per actuated joint");
    friction_ = friction;
  }

  void ProjectedLaw::evaluate(
    const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
    const Vector & ref_alpha_ddot, const Vector & z, Vector & torque, Vector & z_dot)
  {
    const Eigen::Index n = nominal_.dof();
    if (alpha.size() != n || alpha_dot.size() != n || ref_alpha.size() != n || ref_alpha_dot.size() != n
        || ref_alpha_ddot.size() != n)
      throw std::invalid_argument("the joint state and the reference need one value per actuated joint");
    compute(alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z, torque, z_dot);
  }

  void ProjectedLaw::use_delta_model(const DeltaGeometry & geometry)
  {
    if (nominal_.dof() != 3)
      throw std::invalid_argument("the Delta's analytic model needs three actuated joints");
    geometry_ = geometry;
    delta_model_ = true;
  }

  void ProjectedLaw::terms(const Vector & alpha, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G)
  {
    if (delta_model_)
    {
      Vector3 xyz, G3;
      Matrix3 J, J_dot, M3, C3;
      if (!delta_kinematics(geometry_, alpha, alpha_dot, xyz, J, J_dot))
        throw SimulationFailure("the nominal model's forward kinematics has no solution at alpha=" + joint_values(alpha));
      delta_dynamics(geometry_, alpha, J, J_dot, M3, C3, G3);
      M = M3;
      C = C3;
      G = G3;
      return;
    }
    Vector q;
    if (!nominal_.configuration(alpha, q_, q))
      throw SimulationFailure("the nominal model's loops do not close at alpha=" + joint_values(alpha));
    q_ = q;
    Vector C_alpha_dot;
    nominal_.reduced_terms(q, alpha_dot, M, C, G, C_alpha_dot);
  }

  Vector ProjectedLaw::compensation(const Vector & alpha_dot) const
  {
    Vector compensation = disturbance_;
    if (friction_.enabled)
      for (Eigen::Index i = 0; i < compensation.size(); ++i)
        compensation[i] += friction_.torque(alpha_dot[i], friction_.normal_force[i]);
    return compensation;
  }

  void ProjectedLaw::compute(
    const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
    const Vector & ref_alpha_ddot, const Vector & z, Vector & torque, Vector & z_dot)
  {
    Matrix M, C;
    Vector G;
    terms(alpha, alpha_dot, M, C, G);
    law(M, C, G, compensation(alpha_dot), alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z, torque, z_dot);
  }

  void ProjectedLaw::law(
    const Matrix &, const Matrix &, const Vector &, const Vector &, const Vector &, const Vector &, const Vector &,
    const Vector &, const Vector &, const Vector &, Vector &, Vector &)
  {
    throw std::logic_error("law '" + name_ + "' overrides neither compute() nor law()");
  }

  void ProjectedLaw::set_drive(
    bool sensor, double resolution, const RowMatrix & noise, bool exact_velocity, bool drive, int delay,
    const Vector & torque_limit)
  {
    const Eigen::Index n = nominal_.dof();
    if (sensor && !(resolution > 0.0))
      throw std::invalid_argument("the encoder needs a resolution > 0 [rad]");
    if (noise.size() && noise.cols() != n)
      throw std::invalid_argument("the encoder noise needs one column per actuated joint");
    if (delay < 0 || (torque_limit.size() && torque_limit.size() != n))
      throw std::invalid_argument("the drive needs a delay >= 0 and one torque limit per actuated joint (or none)");
    sensor_ = sensor;
    resolution_ = resolution;
    noise_ = noise;
    exact_velocity_ = exact_velocity;
    drive_ = drive;
    delay_ = drive ? delay : 0;
    limit_ = drive ? torque_limit : Vector();
  }

  void ProjectedLaw::start(
    const RowMatrix & alpha_d, const RowMatrix & alpha_dot_d, const RowMatrix & alpha_ddot_d, double dt,
    const Vector & state0, long samples, double max_joint_speed)
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
    z_ = state0;
    z_dot_ = Vector::Zero(state0.size());
    if (sensor_ && noise_.size() && noise_.rows() < samples)
      throw std::invalid_argument("the encoder noise needs one row per sample");
    tau.setZero(samples, n);
    state.setZero(samples, state0.size());
    tau_command.setZero(drive_ ? samples : 0, n);
    pending_.setZero(delay_, n);
    head_ = 0;
    hits = 0;
    has_previous_ = false;
    start_records(samples);
  }

  void ProjectedLaw::start_continuous(long samples, Eigen::Index states)
  {
    const Eigen::Index n = nominal_.dof();
    tau.setZero(samples, n);
    state.setZero(samples, states);
    tau_command.setZero(0, n);
    hits = 0;
    start_records(samples);
  }

  void ProjectedLaw::keep(long k, const Vector & torque, const Vector & state_k)
  {
    if (k >= tau.rows() || state.cols() != state_k.size())
      throw std::invalid_argument("ProjectedLaw::keep beyond the samples or the state of start_continuous()");
    tau.row(k) = torque.transpose();
    state.row(k) = state_k.transpose();
    record(k);
  }

  Vector ProjectedLaw::control(long k, const Vector & x, const Vector & alpha, const Vector & alpha_dot)
  {
    if (k >= tau.rows())
      throw std::invalid_argument("ProjectedLaw::control beyond the samples of start()");
    const double t = k * dt_;
    if (k > 0)
    {
      if (discrete_)
        z_ = z_dot_;  // Controller.advance: the discrete-time law's next state
      else
        z_ += dt_ * z_dot_;  // Controller.advance: explicit Euler once per sample
      check_sample(x.allFinite() && z_.allFinite(), alpha, alpha_dot, max_joint_speed_, t);
    }
    Vector measured = alpha, rate = alpha_dot;
    if (sensor_)  // Encoder.read
    {
      for (Eigen::Index i = 0; i < measured.size(); ++i)
      {
        const double angle = noise_.size() ? alpha[i] + noise_(k, i) : alpha[i];
        measured[i] = std::nearbyint(angle / resolution_) * resolution_;  // np.round: half to even
      }
      if (!exact_velocity_)
        rate = has_previous_ ? Vector((measured - previous_) / dt_) : Vector::Zero(measured.size());
      previous_ = measured;
      has_previous_ = true;
    }
    Vector torque;
    try
    {
      evaluate(measured, rate, alpha_d_.row(k).transpose(), alpha_dot_d_.row(k).transpose(),
               alpha_ddot_d_.row(k).transpose(), z_, torque, z_dot_);
    }
    catch (SimulationFailure & failure)
    {
      failure.time = t;
      throw;
    }
    if (!torque.allFinite())
      throw failure_at("controller '" + name_ + "' returned a non-finite torque " + joint_values(torque), t);
    if (drive_)  // Drive.apply
    {
      tau_command.row(k) = torque.transpose();
      if (delay_ > 0)
      {
        const Vector command = torque;
        torque = pending_.row(head_).transpose();
        pending_.row(head_) = command.transpose();
        head_ = (head_ + 1) % delay_;
      }
      if (limit_.size())
      {
        const Vector clipped = torque.cwiseMax(-limit_).cwiseMin(limit_);
        if (clipped != torque)
          ++hits;
        torque = clipped;
      }
    }
    tau.row(k) = torque.transpose();
    state.row(k) = z_.transpose();
    record(k);
    return torque;
  }

  ComputedTorqueLaw::ComputedTorqueLaw(
    const ChainDescription & chain, const Vector & reference_configuration, const Vector & disturbance, const std::string & name, const Vector & D,
    const Vector & T_p, const Vector & T_v)
  : ProjectedLaw(chain, reference_configuration,
                 disturbance, name)
  , D_(D)
  , T_p_(T_p)
  , T_v_(T_v)
  {
    if (D_.size() != dof() || T_p_.size() != dof() || T_v_.size() != dof())
      throw std::invalid_argument("the gains D, T_p, T_v need one value per actuated joint");
  }

  void ComputedTorqueLaw::law(
    const Matrix & M, const Matrix & C, const Vector & G, const Vector & compensation, const Vector & alpha,
    const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot,
    const Vector &, Vector & torque, Vector & state_dot)
  {
    torque = computed_torque_law<Eigen::Dynamic>(
      D_, T_p_, T_v_, M, C, G, compensation, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot);
    state_dot.resize(0);
  }

  PDGravityLaw::PDGravityLaw(
    const ChainDescription & chain, const Vector & reference_configuration, const Vector & disturbance, const std::string & name, const Vector & K_p,
    const Vector & K_d)
  : ProjectedLaw(chain, reference_configuration,
                 disturbance, name)
  , K_p_(K_p)
  , K_d_(K_d)
  {
    if (K_p_.size() != dof() || K_d_.size() != dof())
      throw std::invalid_argument("the gains K_p, K_d need one value per actuated joint");
  }

  void PDGravityLaw::law(
    const Matrix &, const Matrix &, const Vector & G, const Vector & compensation, const Vector & alpha,
    const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector &, const Vector &,
    Vector & torque, Vector & state_dot)
  {
    torque = G + compensation - K_p_.cwiseProduct(alpha - ref_alpha) - K_d_.cwiseProduct(alpha_dot - ref_alpha_dot);
    state_dot.resize(0);
  }

  AdaptiveRobust::AdaptiveRobust(
    const ChainDescription & chain, const Vector & reference_configuration, const Vector & disturbance, const std::string & name,
    const AdaptiveRobustGains<Eigen::Dynamic> & gains)
  : ProjectedLaw(chain, reference_configuration,
                 disturbance, name)
  , gains_(gains)
  {
    if (gains_.D.size() != dof() || gains_.T_p.size() != dof() || gains_.T_v.size() != dof())
      throw std::invalid_argument("the gains D, T_p, T_v need one value per actuated joint");
    info_.robust_torque = Vector::Zero(dof());
  }

  void AdaptiveRobust::law(
    const Matrix & M, const Matrix & C, const Vector & G, const Vector & compensation, const Vector & alpha,
    const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot,
    const Vector & z, Vector & torque, Vector & z_dot)
  {
    if (z.size() != (gains_.vector_rho ? 3 : 1))
      throw std::invalid_argument("rho_hat has the wrong size");
    RhoVector rho_hat = z, rate;
    adaptive_robust_law<Eigen::Dynamic>(
      gains_, M, C, G, compensation, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho_hat, torque, rate,
      info_);
    z_dot = rate;
  }

  void AdaptiveRobust::start_records(long samples)
  {
    robust_torque.setZero(samples, dof());
    Lambda.setZero(samples);
    robust_gain.setZero(samples);
    omega_norm.setZero(samples);
    adaptation_active.setZero(samples);
  }

  void AdaptiveRobust::record(long k)
  {
    robust_torque.row(k) = info_.robust_torque.transpose();
    Lambda[k] = info_.Lambda;
    robust_gain[k] = info_.robust_gain;
    omega_norm[k] = info_.omega_norm;
    adaptation_active[k] = info_.adaptation_active;
  }

  TimeDelayControlLaw::TimeDelayControlLaw(
    const ChainDescription & chain, const Vector & reference_configuration, const Vector & disturbance, const std::string & name,
    const TimeDelayGains & gains)
  : ProjectedLaw(chain, reference_configuration,
                 disturbance, name)
  , gains_(gains)
  {
    if (!(gains_.period > 0.0) || gains_.delay < 0)
      throw std::invalid_argument("time-delay control needs a period > 0 and a delay >= 0");
    set_discrete();
  }

  void TimeDelayControlLaw::law(
    const Matrix & M, const Matrix & C, const Vector & G, const Vector & compensation, const Vector & alpha,
    const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot,
    const Vector & z, Vector & torque, Vector & next)
  {
    const Eigen::Index n = alpha.size();
    if (z.size() != time_delay_state_size(gains_, n))
      throw std::invalid_argument("the time-delay control's state has the wrong size");
    const Vector rest = C * alpha_dot + G + compensation;  // C̄ alpha_dot + Ḡ + F̄ (no M̄_f: none set)
    torque.resize(n);
    lumped_.resize(n);
    next.resize(z.size());
    time_delay_control(gains_, M, rest, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z.data(),
                       next.data(), torque, lumped_);
  }

  void TimeDelayControlLaw::start_records(long samples) { lumped_estimate.setZero(samples, dof()); }

  void TimeDelayControlLaw::record(long k) { lumped_estimate.row(k) = lumped_.transpose(); }

  DigitalRobustLaw::DigitalRobustLaw(
    const ChainDescription & chain, const Vector & reference_configuration, const Vector & disturbance, const std::string & name,
    const DigitalRobustGains<Eigen::Dynamic> & gains)
  : ProjectedLaw(chain, reference_configuration,
                 disturbance, name)
  , gains_(gains)
  {
    const Eigen::Index size = gains_.transition.rows();
    if (size < 3 || size > observer_max || gains_.transition.cols() != size || gains_.input_gain.size() != size
        || gains_.observer_gain.size() != size)
      throw std::invalid_argument("the observer needs Phi (S x S), Gamma (S) and L (S) with 3 <= S <= 6");
    if (!(gains_.period > 0.0) || gains_.delay < 0 || !(gains_.layer_samples >= 1.0))
      throw std::invalid_argument("digital-robust needs a period > 0, a delay >= 0 and layer_samples >= 1");
    if (gains_.has_limit && gains_.torque_limit.size() != dof())
      throw std::invalid_argument("the torque limit needs one value per actuated joint");
    set_discrete();
  }

  void DigitalRobustLaw::compute(
    const Vector & alpha, const Vector &, const Vector & ref_alpha, const Vector & ref_alpha_dot,
    const Vector & ref_alpha_ddot, const Vector & z, Vector & torque, Vector & next)
  {
    if (z.size() != digital_robust_state_size(gains_, alpha.size()))
      throw std::invalid_argument("the digital-robust law's state has the wrong size");
    auto model = [this](const Vector & a, const Vector & a_dot, Matrix & M, Vector & n_bar)
    {
      Matrix C;
      Vector G;
      terms(a, a_dot, M, C, G);
      n_bar = C * a_dot + G + compensation(a_dot);
      return true;
    };
    next.resize(z.size());
    digital_robust_law<Eigen::Dynamic>(gains_, model, alpha, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z.data(),
                                       next.data(), torque, info_);
  }

  void DigitalRobustLaw::start_records(long samples)
  {
    rho_hat.setZero(samples, 1);
    robust_torque.setZero(samples, dof());
    disturbance_estimate.setZero(samples, dof());
    velocity_estimate.setZero(samples, dof());
    s.setZero(samples, dof());
  }

  void DigitalRobustLaw::record(long k)
  {
    rho_hat(k, 0) = info_.rho_hat;
    robust_torque.row(k) = info_.robust_torque.transpose();
    disturbance_estimate.row(k) = info_.disturbance_estimate.transpose();
    velocity_estimate.row(k) = info_.velocity_estimate.transpose();
    s.row(k) = info_.s.transpose();
  }

  LqrLaw::LqrLaw(
    const ChainDescription & chain, const Vector & reference_configuration, const Vector & disturbance, const std::string & name,
    const LqrGains<Eigen::Dynamic> & gains)
  : ProjectedLaw(chain, reference_configuration,
                 disturbance, name)
  , gains_(gains)
  {
    const Eigen::Index n = dof();
    if (gains_.alpha0.size() != n || gains_.gravity.size() != n || gains_.gravity_slope.rows() != n
        || gains_.gravity_slope.cols() != n || gains_.inertia.rows() != n || gains_.inertia.cols() != n
        || gains_.gain.rows() != n || gains_.gain.cols() != 2 * n)
      throw std::invalid_argument("the LQR needs alpha0, G0 (n), dG/dalpha, M0 (n x n) and K (n x 2n)");
  }

  void LqrLaw::compute(
    const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
    const Vector & ref_alpha_ddot, const Vector &, Vector & torque, Vector & state_dot)
  {
    torque = lqr_law<Eigen::Dynamic>(gains_, compensation(alpha_dot), alpha, alpha_dot, ref_alpha, ref_alpha_dot,
                                     ref_alpha_ddot);
    state_dot.resize(0);
  }
} // namespace delta_pin
