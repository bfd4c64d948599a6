/* delta-pin's controllers for a drive written in C or C++: designs I and II of the paper on the
 * Delta's analytic nominal model, with no Python, no Pinocchio and no heap allocation per step
 * (Eigen only; delta_pin/core/control/). Built by examples/drive_cpp/CMakeLists.txt.
 *
 * Units: SI (rad, rad/s, N m, m, kg). One call of dp_design_step per sample period: the torque
 * for the measured joint state and the reference, then rho_hat advances by one explicit Euler
 * step over the period (delta_pin's Controller.advance). */
#ifndef DELTA_PIN_CONTROL_H
#define DELTA_PIN_CONTROL_H

#ifdef __cplusplus
extern "C" {
#endif

/* the robot's constants (delta_pin.model.dynamics.kernel_geometry) and the chain azimuths */
typedef struct dp_delta_geometry
{
  double R, r, l_a, l_b, arm_inertia, arm_gravity, g, m_eq;
  double cos_phi[3], sin_phi[3];
} dp_delta_geometry;

/* the gains of designs I and II (AdaptiveRobustGains), per joint where they are vectors */
typedef struct dp_adaptive_robust_gains
{
  double D[3], T_p[3], T_v[3];
  double beta, xi, epsilon, b1, b2, b3;
  int design_two, vector_rho;
  double sampling_period, sampling_margin; /* sampling_period 0: the paper's law unchanged */
  double rho0;
} dp_adaptive_robust_gains;

/* the nominal friction the law compensates (eq. 12; enabled 0: none) */
typedef struct dp_friction
{
  int enabled;
  double r_a, v_s, mu_s, mu_d, mu_v, sign_scale;
  double normal_force[3];
} dp_friction;

typedef struct dp_design dp_design;

/* A controller; period: the sample period [s]; disturbance: the nominal F̄ [N m]. NULL where an
 * argument is invalid (a non-positive gain or period). */
dp_design * dp_design_create(
  const dp_delta_geometry * geometry, const dp_adaptive_robust_gains * gains, const dp_friction * friction,
  const double disturbance[3], double period);
/* The torque tau [N m] of one sample; 0 where it succeeds, 1 where the nominal model has no
 * forward kinematics at alpha, 2 where the torque is not finite (then tau is not written and the
 * state does not advance). */
int dp_design_step(
  dp_design * design, const double alpha[3], const double alpha_dot[3], const double ref_alpha[3],
  const double ref_alpha_dot[3], const double ref_alpha_ddot[3], double tau[3]);
/* rho_hat now (1 entry, or 3 with vector_rho); returns the number of entries */
int dp_design_rho(const dp_design * design, double rho[3]);
void dp_design_reset(dp_design * design);
void dp_design_destroy(dp_design * design);

#ifdef __cplusplus
}
#endif

#endif
