// The sampled laws on a closed chain's projected nominal model (controller.hpp): ProjectedLaw with
// its drive, designs I/II, computed torque, PD + gravity, time-delay control, digital-robust, LQR.

#include "controller.hpp"

#include "checks.hpp"
#include "failure.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace delta_pin
{
  ProjectedLaw::ProjectedLaw(std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name)
  : model_(std::move(model))
  , disturbance_(disturbance)
  , name_(name)
  {
    if (!model_)
      throw std::invalid_argument("a law needs a nominal model");
    check_size(disturbance_, model_->dof(), "disturbance");  // one per actuated joint
    friction_.normal_force = Vector::Zero(model_->dof());
  }

  void ProjectedLaw::set_friction(const FrictionSpec & friction)
  {
    if (friction.enabled)
      check_size(friction.normal_force, model_->dof(), "normal_force");  // one per actuated joint
    friction_ = friction;
  }

  void ProjectedLaw::evaluate(
    const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
    const Vector & ref_alpha_ddot, const Vector & z, Vector & torque, Vector & z_dot)
  {
    const Eigen::Index n = model_->dof();  // one value per actuated joint
    check_size(alpha, n, "alpha");
    check_size(alpha_dot, n, "alpha_dot");
    check_size(ref_alpha, n, "ref_alpha");
    check_size(ref_alpha_dot, n, "ref_alpha_dot");
    check_size(ref_alpha_ddot, n, "ref_alpha_ddot");
    compute(alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z, torque, z_dot);
  }

  void ProjectedLaw::terms(const Vector & alpha, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G)
  {
    model_->terms(alpha, alpha_dot, M, C, G);
    const Eigen::Index n = model_->dof();
    if (M.rows() != n || M.cols() != n || C.rows() != n || C.cols() != n || G.size() != n)
      throw std::invalid_argument(
        "the nominal model returned M " + shape_text(M.rows(), M.cols()) + ", C " + shape_text(C.rows(), C.cols())
        + " and G of " + std::to_string(G.size()) + " entries, expected " + shape_text(n, n) + ", " + shape_text(n, n)
        + " and " + std::to_string(n));
  }

  void ProjectedLaw::compensation(const Vector & alpha_dot, Vector & out) const
  {
    if (model_->compensation(alpha_dot, out))  // the model's own (a Python model's)
    {
      check_size(out, model_->dof(), "the nominal model's compensation");
      return;
    }
    out = disturbance_;
    if (friction_.enabled)
      for (Eigen::Index i = 0; i < out.size(); ++i)
        out[i] += friction_.torque(alpha_dot[i], friction_.normal_force[i]);
  }

  void ProjectedLaw::compute(
    const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
    const Vector & ref_alpha_ddot, const Vector & z, Vector & torque, Vector & z_dot)
  {
    terms(alpha, alpha_dot, M_, C_, G_);
    compensation(alpha_dot, compensation_);
    law(M_, C_, G_, compensation_, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z, torque, z_dot);
  }

  void ProjectedLaw::law(
    const Matrix &, const Matrix &, const Vector &, const Vector &, const Vector &, const Vector &, const Vector &,
    const Vector &, const Vector &, const Vector &, Vector &, Vector &)
  {
    throw std::logic_error("law '" + name_ + "' overrides neither compute() nor law()");
  }

  void ProjectedLaw::start(
    const RowMatrix & alpha_d, const RowMatrix & alpha_dot_d, const RowMatrix & alpha_ddot_d, double dt,
    const Vector & state0, long samples)
  {
    const Eigen::Index n = model_->dof();
    if (samples < 0)
      throw std::invalid_argument("samples is " + std::to_string(samples) + ", expected >= 0");
    check_positive(dt, "dt");
    // the reference: one row per sample, one column per actuated joint
    check_shape(alpha_d, samples, n, "alpha_d");
    check_shape(alpha_dot_d, samples, n, "alpha_dot_d");
    check_shape(alpha_ddot_d, samples, n, "alpha_ddot_d");
    alpha_d_ = alpha_d;
    alpha_dot_d_ = alpha_dot_d;
    alpha_ddot_d_ = alpha_ddot_d;
    dt_ = dt;
    z_ = state0;
    z_dot_ = Vector::Zero(state0.size());
    tau.setZero(samples, n);
    state.setZero(samples, state0.size());
    start_records(samples);
  }

  void ProjectedLaw::start_continuous(long samples, Eigen::Index states)
  {
    const Eigen::Index n = model_->dof();
    tau.setZero(samples, n);
    state.setZero(samples, states);
    start_records(samples);
  }

  void ProjectedLaw::keep(long k, const Vector & torque, const Vector & state_k)
  {
    if (k < 0 || k >= tau.rows() || state.cols() != state_k.size())
      throw std::invalid_argument("ProjectedLaw::keep beyond the samples or the state of start_continuous()");
    tau.row(k) = torque.transpose();
    state.row(k) = state_k.transpose();
    record(k);
  }

  Vector ProjectedLaw::control(long k, const Vector & /*x*/, const Vector & alpha, const Vector & alpha_dot)
  {
    if (k < 0 || k >= tau.rows())
      throw std::invalid_argument(
        "sample " + std::to_string(k) + " lies beyond the " + std::to_string(tau.rows())
        + " samples of start(): steps + 1 must not exceed them");
    const double t = k * dt_;
    if (k > 0)
    {
      if (discrete_)
        z_ = z_dot_;  // Controller.advance: the discrete-time law's next state
      else
        z_ += dt_ * z_dot_;  // Controller.advance: explicit Euler once per sample
      if (!z_.allFinite())  // the plant's state the run checked (HeldTorqueRk4)
        throw failure_at("the state became non-finite (alpha=" + joint_values(alpha) + ")", t);
    }
    Vector torque;
    try
    {
      evaluate(alpha, alpha_dot, alpha_d_.row(k).transpose(), alpha_dot_d_.row(k).transpose(),
               alpha_ddot_d_.row(k).transpose(), z_, torque, z_dot_);
    }
    catch (SimulationFailure & failure)
    {
      failure.time = t;
      throw;
    }
    if (!torque.allFinite())
      throw failure_at("controller '" + name_ + "' returned a non-finite torque " + joint_values(torque), t);
    tau.row(k) = torque.transpose();
    state.row(k) = z_.transpose();
    record(k);
    return torque;
  }

  ComputedTorqueLaw::ComputedTorqueLaw(
    std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name, const Vector & D,
    const Vector & T_p, const Vector & T_v)
  : ProjectedLaw(std::move(model), disturbance, name)
  , D_(D)
  , T_p_(T_p)
  , T_v_(T_v)
  {
    check_size(D_, dof(), "D");  // one per actuated joint
    check_size(T_p_, dof(), "T_p");
    check_size(T_v_, dof(), "T_v");
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
    std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name, const Vector & K_p,
    const Vector & K_d)
  : ProjectedLaw(std::move(model), disturbance, name)
  , K_p_(K_p)
  , K_d_(K_d)
  {
    check_size(K_p_, dof(), "K_p");  // one per actuated joint
    check_size(K_d_, dof(), "K_d");
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
    std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name,
    const AdaptiveRobustGains<Eigen::Dynamic> & gains)
  : ProjectedLaw(std::move(model), disturbance, name)
  , gains_(gains)
  {
    check_size(gains_.D, dof(), "D");  // one per actuated joint
    check_size(gains_.T_p, dof(), "T_p");
    check_size(gains_.T_v, dof(), "T_v");
    info_.robust_torque = Vector::Zero(dof());
    if (dof() == 3)
      gains3_ = gains_at_size<3>(gains_);
  }

  void AdaptiveRobust::law(
    const Matrix & M, const Matrix & C, const Vector & G, const Vector & compensation, const Vector & alpha,
    const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot,
    const Vector & z, Vector & torque, Vector & z_dot)
  {
    if (z.size() != (gains_.vector_rho ? 3 : 1))
      throw std::invalid_argument("rho_hat has the wrong size");
    RhoVector rho_hat = z, rate;
    if (dof() == 3)
    {
      typedef Eigen::Vector3d V;
      AdaptiveRobustInternals<3> info;
      V torque3;
      adaptive_robust_law<3>(
        gains3_, Eigen::Matrix3d(M), Eigen::Matrix3d(C), V(G), V(compensation), V(alpha), V(alpha_dot), V(ref_alpha),
        V(ref_alpha_dot), V(ref_alpha_ddot), rho_hat, torque3, rate, info);
      torque = torque3;
      info_.robust_torque = info.robust_torque;
      info_.Lambda = info.Lambda;
      info_.robust_gain = info.robust_gain;
      info_.omega_norm = info.omega_norm;
      info_.adaptation_active = info.adaptation_active;
    }
    else
      adaptive_robust_law<Eigen::Dynamic>(
        gains_, M, C, G, compensation, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho_hat, torque,
        rate, info_);
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
    std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name,
    const TimeDelayGains & gains)
  : ProjectedLaw(std::move(model), disturbance, name)
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
    std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name,
    const DigitalRobustGains<Eigen::Dynamic> & gains)
  : ProjectedLaw(std::move(model), disturbance, name)
  , gains_(gains)
  {
    const Eigen::Index size = gains_.transition.rows();
    if (size < 3 || size > observer_max || gains_.transition.cols() != size)
      throw std::invalid_argument(
        "transition has shape " + shape_text(gains_.transition.rows(), gains_.transition.cols())
        + ", expected the observer's Phi (S, S) with 3 <= S <= " + std::to_string(observer_max));
    check_size(gains_.input_gain, size, "input_gain");  // Gamma (S)
    check_size(gains_.observer_gain, size, "observer_gain");  // L (S)
    if (!(gains_.period > 0.0) || gains_.delay < 0 || !(gains_.layer_samples >= 1.0))
      throw std::invalid_argument("digital-robust needs a period > 0, a delay >= 0 and layer_samples >= 1");
    if (gains_.has_limit)
      check_size(gains_.torque_limit, dof(), "torque_limit");  // one per actuated joint
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
      Vector G, compensation_here;
      terms(a, a_dot, M, C, G);
      compensation(a_dot, compensation_here);
      n_bar = C * a_dot + G + compensation_here;
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
    std::shared_ptr<NominalTerms> model, const Vector & disturbance, const std::string & name,
    const LqrGains<Eigen::Dynamic> & gains)
  : ProjectedLaw(std::move(model), disturbance, name)
  , gains_(gains)
  {
    const Eigen::Index n = dof();
    check_size(gains_.alpha0, n, "alpha0");  // n = the actuated joints
    check_size(gains_.gravity, n, "gravity");
    const auto square = [n](const Matrix & value, const char * name, Eigen::Index cols)
    {
      if (value.rows() != n || value.cols() != cols)
        throw std::invalid_argument(
          std::string(name) + " has shape " + shape_text(value.rows(), value.cols()) + ", expected "
          + shape_text(n, cols));
    };
    square(gains_.gravity_slope, "gravity_slope", n);
    square(gains_.inertia, "inertia", n);
    square(gains_.gain, "gain", 2 * n);
  }

  void LqrLaw::compute(
    const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot,
    const Vector & ref_alpha_ddot, const Vector &, Vector & torque, Vector & state_dot)
  {
    Vector compensation_here;
    compensation(alpha_dot, compensation_here);
    torque = lqr_law<Eigen::Dynamic>(gains_, compensation_here, alpha, alpha_dot, ref_alpha, ref_alpha_dot,
                                     ref_alpha_ddot);
    state_dot.resize(0);
  }
} // namespace delta_pin
