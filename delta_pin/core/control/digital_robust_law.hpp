// The sampled-data adaptive robust law (delta_pin/control/digital_robust.py, its module docstring
// steps 1-5; the adaptive bound of eqs. 24-25) with its extended-state observer
// (delta_pin/control/observer.py), given a nominal model as a function of (alpha, alpha_dot):
// Eigen only, no Pinocchio, no Python, and no heap allocation for a fixed number of joints (N = 3
// for the Delta). The same arithmetic as the readable digital-robust law of tests/reference/laws.py, which the
// tests hold it to.
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace delta_pin
{
  constexpr int observer_max = 6;  // order + 2 states per joint, order <= 4

  typedef Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, observer_max, observer_max> ObserverMatrix;
  typedef Eigen::Matrix<double, Eigen::Dynamic, 1, 0, observer_max, 1> ObserverVector;

  template<int N>
  struct DigitalRobustGains
  {
    typedef Eigen::Matrix<double, N, 1> JointVector;
    double period = 1e-3;  // T [s]
    int delay = 0;  // samples of computation delay d (predicted over)
    double K_p = 0.0, K_v = 0.0, D = 0.0;  // omega_c^2 [1/s^2], 2 omega_c [1/s], the surface's D [1/s]
    double beta = 0.1, b1 = 10.0, b2 = 2.0, b3 = 0.3;  // eq. 24
    double epsilon = 0.01;  // the dead zone on ||s|| [rad/s] (eq. 25)
    double layer_samples = 8.0;  // n_s
    bool has_limit = false;
    JointVector torque_limit;  // [N m], what the observer is told acted
    // the observer (ExtendedStateObserver): Phi (S x S), Gamma (S), L (S), S = order + 2
    ObserverMatrix transition;
    ObserverVector input_gain, observer_gain;
  };

  template<int N>
  struct DigitalRobustInternals
  {
    typedef Eigen::Matrix<double, N, 1> JointVector;
    double rho_hat = 0.0;  // [N m], the bound this sample used
    JointVector robust_torque, disturbance_estimate, velocity_estimate, s;  // [N m], [N m], [rad/s], [rad/s]
  };

  // the state's length: [estimate (S x n, row-major), the last d + 1 commands newest first, M̄ (n x n,
  // row-major) and n̄ (n) at the estimate, rho_hat, started]
  template<int N>
  Eigen::Index digital_robust_state_size(const DigitalRobustGains<N> & p, Eigen::Index n)
  {
    return p.transition.rows() * n + n * (p.delay + 1) + n * n + n + 2;
  }

  // One sample: the command tau for the measured angles alpha (module docstring steps 1-5), and the
  // next state. model(alpha, alpha_dot, M, n_bar) gives M̄ and n̄ = C̄ alpha_dot + Ḡ + F̄ [+ M̄_f] at
  // an estimate and returns false where the nominal model has no value there (then this returns
  // false, next is not complete). state and next: digital_robust_state_size entries.
  template<int N, typename Model>
  bool digital_robust_law(
    const DigitalRobustGains<N> & p, Model & model, const Eigen::Matrix<double, N, 1> & alpha,
    const Eigen::Matrix<double, N, 1> & ref_alpha, const Eigen::Matrix<double, N, 1> & ref_alpha_dot,
    const Eigen::Matrix<double, N, 1> & ref_alpha_ddot, const double * state, double * next,
    Eigen::Matrix<double, N, 1> & tau, DigitalRobustInternals<N> & info)
  {
    typedef Eigen::Matrix<double, N, 1> JointVector;
    typedef Eigen::Matrix<double, N, N> JointMatrix;
    typedef Eigen::Matrix<double, N, N, Eigen::RowMajor> RowJointMatrix;
    typedef Eigen::Matrix<double, Eigen::Dynamic, N, Eigen::RowMajor, observer_max, N> Estimate;
    typedef Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, N, Eigen::RowMajor>> EstimateMap;
    typedef Eigen::Map<const JointVector> Row;
    const Eigen::Index n = alpha.size(), size = p.transition.rows(), d = p.delay;
    const double T = p.period;
    const double * commands = state + size * n;
    const double * model_state = commands + n * (d + 1);
    const double rho = model_state[n * n + n], started = model_state[n * n + n + 1];
    Estimate estimate(size, n);
    if (started != 0.0)
    {
      // the torque that acted over [t_{k-1}, t_k) was commanded at sample k-1-d
      const JointMatrix M_last = Eigen::Map<const RowJointMatrix>(model_state, n, n);
      const JointVector acceleration = M_last.partialPivLu().solve(Row(commands + n * d, n) - Row(model_state + n * n, n));
      const Estimate predicted = p.transition * EstimateMap(state, size, n) + p.input_gain * acceleration.transpose();
      estimate = predicted + p.observer_gain * (alpha - predicted.row(0).transpose()).transpose();
    }
    else
    {
      estimate.setZero();
      estimate.row(0) = alpha.transpose();
    }
    JointMatrix M(n, n), M_estimate(n, n);
    JointVector n_bar(n), n_estimate(n);
    if (!model(JointVector(estimate.row(0).transpose()), JointVector(estimate.row(1).transpose()), M, n_bar))
      return false;
    M_estimate = M;  // kept for the next sample's prediction
    n_estimate = n_bar;
    Estimate ahead = estimate;
    for (Eigen::Index j = 0; j < d; ++j)  // over [t_{k+j}, t_{k+j+1}) acts the command of sample k+j-d
    {
      const JointVector acceleration = M.partialPivLu().solve(Row(commands + n * (d - 1 - j), n) - n_bar);
      const Estimate predicted = p.transition * ahead + p.input_gain * acceleration.transpose();
      ahead = predicted;
      if (!model(JointVector(ahead.row(0).transpose()), JointVector(ahead.row(1).transpose()), M, n_bar))
        return false;
    }
    const double lead = d * T;  // the reference at t_{k+d}, by its Taylor series
    const JointVector alpha_d = ref_alpha + lead * ref_alpha_dot + 0.5 * lead * lead * ref_alpha_ddot;
    const JointVector alpha_dot_d = ref_alpha_dot + lead * ref_alpha_ddot;
    const JointVector r = ahead.row(0).transpose() - alpha_d, r_dot = ahead.row(1).transpose() - alpha_dot_d;
    const JointVector disturbance = ahead.row(2).transpose();  // f̂ [rad/s^2]
    tau = M * (ref_alpha_ddot - p.K_v * r_dot - p.K_p * r - disturbance) + n_bar;
    const JointVector s = r_dot + p.D * r;
    // lambda_min(M̄) of the damper K_s = lambda_min(M̄) / (n_s T)
    const double inertia = Eigen::SelfAdjointEigenSolver<JointMatrix>(M, Eigen::EigenvaluesOnly).eigenvalues()[0];
    const JointVector damper = inertia / (p.layer_samples * T) * s;
    const double damper_norm = std::sqrt(damper.dot(damper));
    if (damper_norm <= rho)
      info.robust_torque = -damper;
    else
      info.robust_torque = -rho / damper_norm * damper;  // the projection on ||v|| <= rho_hat
    tau = tau + info.robust_torque;
    const double s_norm = std::sqrt(s.dot(s));
    const double leakage = p.b2 * std::exp(-s_norm) + p.b3;
    const double growth = s_norm > p.epsilon ? p.b1 * s_norm : 0.0;  // the dead zone, eq. 25
    const double rho_next = std::max(rho + T * p.beta * (growth - leakage * rho), 0.0);
    // the next state
    double * out = next;
    for (Eigen::Index i = 0; i < size; ++i)
      for (Eigen::Index j = 0; j < n; ++j)
        *out++ = estimate(i, j);
    for (Eigen::Index i = 0; i < n; ++i)
      *out++ = p.has_limit ? std::min(std::max(tau[i], -p.torque_limit[i]), p.torque_limit[i]) : tau[i];
    out = std::copy(commands, commands + n * d, out);
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j)
        *out++ = M_estimate(i, j);
    out = std::copy(n_estimate.data(), n_estimate.data() + n, out);
    out[0] = rho_next;
    out[1] = 1.0;
    info.rho_hat = rho;
    info.disturbance_estimate = M * disturbance;
    info.velocity_estimate = estimate.row(1).transpose();
    info.s = s;
    return true;
  }
} // namespace delta_pin
