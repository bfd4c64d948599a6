// Time-delay control (Youcef-Toumi & Ito 1990) given a nominal model's M̄ and C̄ alpha_dot + Ḡ + F̄
// at the measured state: Eigen only, no Pinocchio, no Python. The same arithmetic as
// readable time-delay control of tests/reference/laws.py, which the tests hold it to.
#pragma once

#include <Eigen/Dense>

#include <algorithm>

namespace delta_pin
{
  struct TimeDelayGains
  {
    double period = 1e-3;  // T [s]
    double K_p = 0.0, K_v = 0.0;  // omega^2 [1/s^2], 2 omega [1/s]
    int delay = 0;  // samples of computation delay d
    bool mean_pairing = false;  // pair the second difference with the mean of two torques
  };

  // the state's length: [alpha_{k-1}, alpha_{k-2}, the last d + 2 commands newest first, samples seen]
  inline Eigen::Index time_delay_state_size(const TimeDelayGains & p, Eigen::Index n) { return 2 * n + n * (p.delay + 2) + 1; }

  // tau_k = M̄ (alpha_ddot^d - K_v r_dot - K_p r) + N̂_k with N̂_k = tau_acted - M̄ (alpha_k -
  // 2 alpha_{k-1} + alpha_{k-2}) / T^2 once three samples exist, else the nominal C̄ alpha_dot + Ḡ + F̄
  // (model_rest). state: time_delay_state_size entries; next: the state at the next sample.
  template<typename Matrix, typename Vector, typename Out>
  void time_delay_control(
    const TimeDelayGains & p, const Matrix & M, const Vector & model_rest, const Vector & alpha,
    const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot,
    const double * state, double * next, Out & tau, Out & lumped)
  {
    typedef Eigen::Map<const Eigen::VectorXd> Row;
    const Eigen::Index n = alpha.size();
    const Row previous(state, n), before(state + n, n);
    const double * commands = state + 2 * n;  // newest first: tau_cmd[k-1], ..., tau_cmd[k-2-d]
    const double seen = state[time_delay_state_size(p, n) - 1];
    (void)alpha_dot;
    if (seen >= 3.0)
    {
      const Row last(commands + n * p.delay, n), oldest(commands + n * (p.delay + 1), n);
      if (p.mean_pairing)
        lumped = 0.5 * (oldest + last) - M * ((alpha - 2.0 * previous + before) / (p.period * p.period));
      else
        lumped = last - M * ((alpha - 2.0 * previous + before) / (p.period * p.period));
    }
    else
      lumped = model_rest;
    tau = M * (ref_alpha_ddot - p.K_v * (alpha_dot - ref_alpha_dot) - p.K_p * (alpha - ref_alpha)) + lumped;
    std::copy(alpha.data(), alpha.data() + n, next);
    std::copy(state, state + n, next + n);
    std::copy(tau.data(), tau.data() + n, next + 2 * n);
    std::copy(commands, commands + n * (p.delay + 1), next + 3 * n);
    next[time_delay_state_size(p, n) - 1] = std::min(seen + 1.0, 3.0);
  }
} // namespace delta_pin
