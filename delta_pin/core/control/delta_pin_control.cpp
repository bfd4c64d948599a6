// The C entry points of delta_pin_control.h: designs I and II on the Delta's analytic nominal
// model (delta_analytic.hpp, adaptive_robust_law.hpp, friction.hpp), Eigen only.

#include "delta_pin_control.h"

#include "adaptive_robust_law.hpp"
#include "delta_analytic.hpp"
#include "friction.hpp"

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
} // namespace

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
  delta_pin::DeltaGeometry & geometry = design->geometry;
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
  if (f != nullptr && f->enabled)
  {
    design->friction.enabled = true;
    design->friction.r_a = f->r_a;
    design->friction.v_s = f->v_s;
    design->friction.mu_s = f->mu_s;
    design->friction.mu_d = f->mu_d;
    design->friction.mu_v = f->mu_v;
    design->friction.sign_scale = f->sign_scale;
    design->normal_force = Eigen::Vector3d(f->normal_force);
  }
  else
    design->normal_force.setZero();
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
}
