// Designs I and II (eqs. 23-26, 30-33, 54-57, 67 of the paper) given a nominal model's M, C, G at
// the state: Eigen only, no Pinocchio, no Python, and no heap allocation for a fixed number of
// joints (N = 3 for the Delta). The same arithmetic as
// readable designs I/II of tests/reference/laws.py (the module docstring of delta_pin/control/adaptive_robust.py), which the
// tests hold it to.
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace delta_pin
{
  // rho_hat: 1 (the scalar bound of eq. 67) or 3 (a vector bound) entries, on the stack
  typedef Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1> RhoVector;

  template<int N>
  struct AdaptiveRobustGains
  {
    typedef Eigen::Matrix<double, N, 1> JointVector;
    JointVector D, T_p, T_v;  // [1/s], [N m/rad], [N m s/rad]
    double beta = 0.1, xi = 1e-3, epsilon = 0.05, b1 = 10.0, b2 = 2.0, b3 = 0.3;
    bool design_two = false, vector_rho = false;
    double sampling_period = 0.0, sampling_margin = 1.0;  // 0: the paper's law unchanged
  };

  // The same gains at another size (N = 3 from the dynamic size: the Delta's fixed-size law)
  template<int To, int From>
  AdaptiveRobustGains<To> gains_at_size(const AdaptiveRobustGains<From> & from)
  {
    AdaptiveRobustGains<To> to;
    to.D = from.D;
    to.T_p = from.T_p;
    to.T_v = from.T_v;
    to.beta = from.beta;
    to.xi = from.xi;
    to.epsilon = from.epsilon;
    to.b1 = from.b1;
    to.b2 = from.b2;
    to.b3 = from.b3;
    to.design_two = from.design_two;
    to.vector_rho = from.vector_rho;
    to.sampling_period = from.sampling_period;
    to.sampling_margin = from.sampling_margin;
    return to;
  }

  // What one evaluation gives besides the torque (the controller's internals).
  template<int N>
  struct AdaptiveRobustInternals
  {
    double Lambda = 0.0, robust_gain = 0.0, omega_norm = 0.0, adaptation_active = 0.0;
    Eigen::Matrix<double, N, 1> robust_torque;
  };

  // C1 + C2 (eqs. 23 and 26): M̄ a_ref + C̄ v_ref + Ḡ + compensation - T_p r - T_v r_dot with
  // a_ref = alpha_ddot^d - D r_dot, v_ref = alpha_dot^d - D r (ComputedTorque.terms)
  template<int N, typename Matrix, typename Vector, typename Gains>
  Eigen::Matrix<double, N, 1> computed_torque_law(
    const Gains & D, const Gains & T_p, const Gains & T_v, const Matrix & M, const Matrix & C, const Vector & G,
    const Vector & compensation, const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha,
    const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot)
  {
    typedef Eigen::Matrix<double, N, 1> JointVector;
    const JointVector r = alpha - ref_alpha, r_dot = alpha_dot - ref_alpha_dot;
    const JointVector a_ref = ref_alpha_ddot - D.cwiseProduct(r_dot);
    const JointVector v_ref = ref_alpha_dot - D.cwiseProduct(r);
    const JointVector c1 = M * a_ref + C * v_ref + G + compensation;
    return c1 + (-T_p.cwiseProduct(r) - T_v.cwiseProduct(r_dot));
  }

  // tau = C1 + C2 + C3 (design I) or + C4 (design II) and rho_dot (eq. 24, dead-zone eq. 25).
  // compensation: F̄ [+ M̄_f(alpha_dot)] [N m].
  template<int N, typename Matrix, typename Vector>
  void adaptive_robust_law(
    const AdaptiveRobustGains<N> & p, const Matrix & M, const Matrix & C, const Vector & G,
    const Vector & compensation, const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha,
    const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot, const RhoVector & rho, Vector & tau,
    RhoVector & rho_dot, AdaptiveRobustInternals<N> & info)
  {
    typedef Eigen::Matrix<double, N, 1> JointVector;
    typedef Eigen::Matrix<double, N, N> JointMatrix;
    const JointVector r = alpha - ref_alpha, r_dot = alpha_dot - ref_alpha_dot;
    const JointVector a_ref = ref_alpha_ddot - p.D.cwiseProduct(r_dot);
    const JointVector v_ref = ref_alpha_dot - p.D.cwiseProduct(r);
    const JointVector c12 = computed_torque_law<N>(
      p.D, p.T_p, p.T_v, M, C, G, compensation, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot);
    const JointVector s = r_dot + p.D.cwiseProduct(r);
    // Lambda of eq. 67 and its gradient
    const double kappa0 = std::sqrt(a_ref.dot(a_ref)), kappa1 = std::sqrt(v_ref.dot(v_ref));
    RhoVector gradient(p.vector_rho ? 3 : 1);
    if (p.vector_rho)
      gradient << kappa0, kappa1, 1.0;
    else
      gradient << kappa0 + kappa1 + 1.0;
    const double Lambda = gradient.dot(rho);
    const double s_norm = std::sqrt(s.dot(s));
    const double omega_norm = s_norm * Lambda;
    const double xi = p.xi;
    double phi;  // eq. 31 (design I) or eq. 56 (design II)
    if (p.design_two)
      phi = omega_norm / (omega_norm * omega_norm + omega_norm * xi + xi * xi);
    else
      phi = omega_norm > xi ? 1.0 / omega_norm : 1.0 / xi;
    double gain = phi * Lambda * Lambda;
    if (p.sampling_period <= 0.0)
      info.robust_torque = -gain * s;
    else  // sampling-aware: per inertia direction k_j = min(gain, margin mu_j / T - T_v)
    {
      Eigen::SelfAdjointEigenSolver<JointMatrix> eigen(JointMatrix(M), Eigen::ComputeEigenvectors);
      const JointVector & inertia = eigen.eigenvalues();
      const JointMatrix & directions = eigen.eigenvectors();
      const double t_v_max = p.T_v.maxCoeff();
      JointVector gains = JointVector::Zero(s.size());
      for (Eigen::Index j = 0; j < s.size(); ++j)
        gains[j] = std::min(gain, std::max(p.sampling_margin * inertia[j] / p.sampling_period - t_v_max, 0.0));
      info.robust_torque = -(directions * gains.cwiseProduct(directions.transpose() * s));
      gain = gains.minCoeff();
    }
    const RhoVector leak = (p.b2 * std::exp(-s_norm) + p.b3) * rho;
    const bool active = s_norm * std::sqrt(gradient.dot(gradient)) > p.epsilon;
    if (active)
      rho_dot = p.beta * (p.b1 * gradient * s_norm - leak);
    else
      rho_dot = -p.beta * leak;
    tau = c12 + info.robust_torque;
    info.Lambda = Lambda;
    info.robust_gain = gain;
    info.omega_norm = omega_norm;
    info.adaptation_active = active ? 1.0 : 0.0;
  }

} // namespace delta_pin
