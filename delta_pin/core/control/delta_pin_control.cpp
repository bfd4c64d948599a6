// The C entry points of delta_pin_control.h: designs I and II and the digital-robust law on the
// Delta's analytic nominal model (delta_analytic.hpp, adaptive_robust_law.hpp,
// digital_robust_law.hpp, friction.hpp), Eigen only.

#include "delta_pin_control.h"

#include "adaptive_robust_law.hpp"
#include "delta_analytic.hpp"
#include "digital_robust_law.hpp"
#include "friction.hpp"

#include <algorithm>
#include <cmath>
#include <new>

struct dp_design
{
  delta_pin::DeltaGeometry geometry;
  delta_pin::AdaptiveRobustGains<3> gains;
  delta_pin::StribeckFriction friction;
  Eigen::Vector3d normal_force, disturbance;
  double period = 0.0, rho0 = 0.0;
  delta_pin::RhoVector rho;
};

namespace
{
  bool positive(const double * values, int n)
  {
    for (int i = 0; i < n; ++i)
      if (!(std::isfinite(values[i]) && values[i] > 0.0))
        return false;
    return true;
  }

  bool non_negative(const double * values, int n)
  {
    for (int i = 0; i < n; ++i)
      if (!(std::isfinite(values[i]) && values[i] >= 0.0))
        return false;
    return true;
  }

  void copy_geometry(const dp_delta_geometry * g, delta_pin::DeltaGeometry & geometry)
  {
    geometry.R = g->R;
    geometry.r = g->r;
    geometry.l_a = g->l_a;
    geometry.l_b = g->l_b;
    geometry.arm_inertia = g->arm_inertia;
    geometry.arm_gravity = g->arm_gravity;
    geometry.g = g->g;
    geometry.m_eq = g->m_eq;
    for (int i = 0; i < 3; ++i)
    {
      geometry.cos_phi[i] = g->cos_phi[i];
      geometry.sin_phi[i] = g->sin_phi[i];
    }
  }

  // the friction a law compensates and its normal forces (none where f is NULL or off)
  void copy_friction(const dp_friction * f, delta_pin::StribeckFriction & friction, Eigen::Vector3d & normal_force)
  {
    if (f != nullptr && f->enabled)
    {
      friction.enabled = true;
      friction.r_a = f->r_a;
      friction.v_s = f->v_s;
      friction.mu_s = f->mu_s;
      friction.mu_d = f->mu_d;
      friction.mu_v = f->mu_v;
      friction.sign_scale = f->sign_scale;
      normal_force = Eigen::Vector3d(f->normal_force);
    }
    else
      normal_force.setZero();
  }

  // the Delta's analytic nominal model as digital_robust_law reads it: M̄ and n̄ = C̄ alpha_dot + Ḡ +
  // F̄ [+ M̄_f(alpha_dot)] at an estimate
  struct DeltaNominal
  {
    const delta_pin::DeltaGeometry & geometry;
    const delta_pin::StribeckFriction & friction;
    const Eigen::Vector3d & normal_force;
    const Eigen::Vector3d & disturbance;

    bool operator()(const Eigen::Vector3d & alpha, const Eigen::Vector3d & alpha_dot, Eigen::Matrix3d & M,
                    Eigen::Vector3d & n_bar) const
    {
      Eigen::Vector3d xyz, G;
      Eigen::Matrix3d J, J_dot, C;
      if (!delta_pin::delta_kinematics(geometry, alpha, alpha_dot, xyz, J, J_dot))
        return false;
      delta_pin::delta_dynamics(geometry, alpha, J, J_dot, M, C, G);
      Eigen::Vector3d compensation = disturbance;
      if (friction.enabled)
        for (int i = 0; i < 3; ++i)
          compensation[i] += friction.torque(alpha_dot[i], normal_force[i]);
      n_bar = C * alpha_dot + G + compensation;
      return true;
    }
  };
} // namespace

constexpr int digital_robust_state_max =
  delta_pin::observer_max * 3 + 3 * (DP_DIGITAL_ROBUST_MAX_DELAY + 1) + 9 + 3 + 2;

struct dp_digital_robust
{
  delta_pin::DeltaGeometry geometry;
  delta_pin::DigitalRobustGains<3> gains;
  delta_pin::StribeckFriction friction;
  Eigen::Vector3d normal_force, disturbance, velocity;
  double rho0 = 0.0;
  int size = 0;  // the state's entries
  double state[digital_robust_state_max], next[digital_robust_state_max];
};

extern "C" {

dp_design * dp_design_create(
  const dp_delta_geometry * g, const dp_adaptive_robust_gains * k, const dp_friction * f, const double disturbance[3],
  double period)
{
  if (g == nullptr || k == nullptr || disturbance == nullptr || !(std::isfinite(period) && period > 0.0))
    return nullptr;
  const double scalars[] = {k->beta, k->xi, k->epsilon, k->b1, k->b2, k->b3, k->rho0, k->sampling_margin};
  if (!positive(k->D, 3) || !positive(k->T_p, 3) || !positive(k->T_v, 3) || !positive(scalars, 8))
    return nullptr;
  dp_design * design = new (std::nothrow) dp_design();
  if (design == nullptr)
    return nullptr;
  copy_geometry(g, design->geometry);
  delta_pin::AdaptiveRobustGains<3> & gains = design->gains;
  gains.D = Eigen::Vector3d(k->D);
  gains.T_p = Eigen::Vector3d(k->T_p);
  gains.T_v = Eigen::Vector3d(k->T_v);
  gains.beta = k->beta;
  gains.xi = k->xi;
  gains.epsilon = k->epsilon;
  gains.b1 = k->b1;
  gains.b2 = k->b2;
  gains.b3 = k->b3;
  gains.design_two = k->design_two != 0;
  gains.vector_rho = k->vector_rho != 0;
  gains.sampling_period = k->sampling_period;
  gains.sampling_margin = k->sampling_margin;
  copy_friction(f, design->friction, design->normal_force);
  design->disturbance = Eigen::Vector3d(disturbance);
  design->period = period;
  design->rho0 = k->rho0;
  dp_design_reset(design);
  return design;
}

int dp_design_step(
  dp_design * design, const double alpha_in[3], const double alpha_dot_in[3], const double ref_alpha[3],
  const double ref_alpha_dot[3], const double ref_alpha_ddot[3], double tau_out[3])
{
  const Eigen::Map<const Eigen::Vector3d> alpha(alpha_in), alpha_dot(alpha_dot_in);
  Eigen::Vector3d xyz, G, compensation, tau;
  Eigen::Matrix3d J, J_dot, M, C;
  if (!delta_pin::delta_kinematics(design->geometry, alpha, alpha_dot, xyz, J, J_dot))
    return 1;
  delta_pin::delta_dynamics(design->geometry, alpha, J, J_dot, M, C, G);
  compensation = design->disturbance;
  if (design->friction.enabled)
    for (int i = 0; i < 3; ++i)
      compensation[i] += design->friction.torque(alpha_dot[i], design->normal_force[i]);
  delta_pin::RhoVector rho_dot;
  delta_pin::AdaptiveRobustInternals<3> info;
  const Eigen::Vector3d reference(ref_alpha[0], ref_alpha[1], ref_alpha[2]);
  const Eigen::Vector3d reference_dot(ref_alpha_dot[0], ref_alpha_dot[1], ref_alpha_dot[2]);
  const Eigen::Vector3d reference_ddot(ref_alpha_ddot[0], ref_alpha_ddot[1], ref_alpha_ddot[2]);
  delta_pin::adaptive_robust_law<3>(
    design->gains, M, C, G, compensation, Eigen::Vector3d(alpha), Eigen::Vector3d(alpha_dot), reference,
    reference_dot, reference_ddot, design->rho, tau, rho_dot, info);
  if (!tau.allFinite())
    return 2;
  for (int i = 0; i < 3; ++i)
    tau_out[i] = tau[i];
  design->rho += design->period * rho_dot;
  return 0;
}

int dp_design_rho(const dp_design * design, double rho[3])
{
  for (Eigen::Index i = 0; i < design->rho.size(); ++i)
    rho[i] = design->rho[i];
  return (int)design->rho.size();
}

void dp_design_reset(dp_design * design)
{
  design->rho = delta_pin::RhoVector::Constant(design->gains.vector_rho ? 3 : 1, design->rho0);
}

void dp_design_destroy(dp_design * design)
{
  delete design;
}

dp_digital_robust * dp_digital_robust_create(
  const dp_delta_geometry * g, const dp_digital_robust_gains * k, const dp_friction * f, const double disturbance[3])
{
  if (g == nullptr || k == nullptr || disturbance == nullptr)
    return nullptr;
  const double rates[] = {k->period, k->K_p, k->K_v, k->D};
  const double adaptation[] = {k->beta, k->b1, k->b2, k->b3, k->epsilon, k->rho0};
  if (!positive(rates, 4) || !non_negative(adaptation, 6) || !(std::isfinite(k->layer_samples) && k->layer_samples >= 1.0))
    return nullptr;
  if (k->delay < 0 || k->delay > DP_DIGITAL_ROBUST_MAX_DELAY || k->observer_size < 3
      || k->observer_size > delta_pin::observer_max || (k->has_limit && !positive(k->torque_limit, 3)))
    return nullptr;
  dp_digital_robust * law = new (std::nothrow) dp_digital_robust();
  if (law == nullptr)
    return nullptr;
  copy_geometry(g, law->geometry);
  copy_friction(f, law->friction, law->normal_force);
  delta_pin::DigitalRobustGains<3> & gains = law->gains;
  gains.period = k->period;
  gains.delay = k->delay;
  gains.K_p = k->K_p;
  gains.K_v = k->K_v;
  gains.D = k->D;
  gains.beta = k->beta;
  gains.b1 = k->b1;
  gains.b2 = k->b2;
  gains.b3 = k->b3;
  gains.epsilon = k->epsilon;
  gains.layer_samples = k->layer_samples;
  gains.has_limit = k->has_limit != 0;
  gains.torque_limit = Eigen::Vector3d(k->torque_limit);
  const int size = k->observer_size;
  gains.transition.resize(size, size);
  gains.input_gain.resize(size);
  gains.observer_gain.resize(size);
  for (int i = 0; i < size; ++i)
  {
    for (int j = 0; j < size; ++j)
      gains.transition(i, j) = k->transition[i * size + j];
    gains.input_gain[i] = k->input_gain[i];
    gains.observer_gain[i] = k->observer_gain[i];
  }
  law->disturbance = Eigen::Vector3d(disturbance);
  law->rho0 = k->rho0;
  law->size = (int)delta_pin::digital_robust_state_size(gains, 3);
  dp_digital_robust_reset(law);
  return law;
}

int dp_digital_robust_step(
  dp_digital_robust * law, const double alpha[3], const double ref_alpha[3], const double ref_alpha_dot[3],
  const double ref_alpha_ddot[3], double tau_out[3])
{
  const DeltaNominal model{law->geometry, law->friction, law->normal_force, law->disturbance};
  Eigen::Vector3d tau;
  delta_pin::DigitalRobustInternals<3> info;
  if (!delta_pin::digital_robust_law<3>(
        law->gains, model, Eigen::Vector3d(alpha), Eigen::Vector3d(ref_alpha), Eigen::Vector3d(ref_alpha_dot),
        Eigen::Vector3d(ref_alpha_ddot), law->state, law->next, tau, info))
    return 1;
  if (!tau.allFinite())
    return 2;
  for (int i = 0; i < 3; ++i)
    tau_out[i] = tau[i];
  std::copy(law->next, law->next + law->size, law->state);
  law->velocity = info.velocity_estimate;
  return 0;
}

double dp_digital_robust_rho(const dp_digital_robust * law, double velocity[3])
{
  if (velocity != nullptr)
    for (int i = 0; i < 3; ++i)
      velocity[i] = law->velocity[i];
  return law->state[law->size - 2];
}

void dp_digital_robust_reset(dp_digital_robust * law)
{
  std::fill(law->state, law->state + digital_robust_state_max, 0.0);
  law->state[law->size - 2] = law->rho0;  // rho_hat; started = 0
  law->velocity.setZero();
}

void dp_digital_robust_destroy(dp_digital_robust * law)
{
  delete law;
}
}
