// The LQR baseline (delta_pin/control/baselines.py LQR): the nominal model linearised at alpha0
// (M̄0, Ḡ(alpha0), dḠ/dalpha there) and the gain K of the Riccati solution, computed by delta-pin's
// Python at construction. Eigen only, no Pinocchio, no Python. The same arithmetic as the readable LQR of tests/reference/laws.py,
// which the tests hold it to.
#pragma once

#include <Eigen/Dense>

namespace delta_pin
{
  template<int N>
  struct LqrGains
  {
    Eigen::Matrix<double, N, 1> alpha0, gravity;  // [rad], Ḡ(alpha0) [N m]
    Eigen::Matrix<double, N, N> gravity_slope, inertia;  // dḠ/dalpha [N m/rad], M̄0 [kg m^2]
    Eigen::Matrix<double, N, (N == Eigen::Dynamic ? Eigen::Dynamic : 2 * N)> gain;  // K on [r, r_dot]
  };

  // tau = Ḡ(alpha0) + compensation + dḠ/dalpha (alpha^d - alpha0) + M̄0 alpha_ddot^d - K [r; r_dot];
  // compensation: F̄ [+ M̄_f(alpha_dot)] [N m]
  template<int N, typename Vector>
  Eigen::Matrix<double, N, 1> lqr_law(
    const LqrGains<N> & p, const Vector & compensation, const Vector & alpha, const Vector & alpha_dot,
    const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot)
  {
    const Eigen::Index n = alpha.size();
    Eigen::Matrix<double, (N == Eigen::Dynamic ? Eigen::Dynamic : 2 * N), 1> error(2 * n);
    error << alpha - ref_alpha, alpha_dot - ref_alpha_dot;
    return p.gravity + compensation + p.gravity_slope * (ref_alpha - p.alpha0) + p.inertia * ref_alpha_ddot
           - p.gain * error;
  }
} // namespace delta_pin
