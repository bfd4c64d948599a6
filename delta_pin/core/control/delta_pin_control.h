/* delta-pin's controllers for a drive written in C or C++: designs I and II of the paper and the
 * sampled-data adaptive robust law with its extended-state observer (digital-robust), on the
 * Delta's analytic nominal model, with no Python, no Pinocchio and no heap allocation per step
 * (Eigen only; delta_pin/core/control/). Built by examples/drive_cpp/CMakeLists.txt.
 *
 * Units: SI (rad, rad/s, N m, m, kg). One call of dp_design_step per sample period: the torque
 * for the measured joint state and the reference, then rho_hat advances by one explicit Euler
 * step over the period (delta_pin's Controller.advance). One call of dp_digital_robust_step per
 * sample period: the command for the measured angles, then the law's discrete state advances. */
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

/* The digital-robust law's gains (delta_pin.control.digital_robust.DigitalRobustController) and
 * its observer's matrices (delta_pin.control.observer.ExtendedStateObserver: transition Phi
 * row-major, input_gain Gamma, observer_gain L; observer_size = order + 2, 3 to 6). */
#define DP_DIGITAL_ROBUST_MAX_DELAY 8
typedef struct dp_digital_robust_gains
{
  double period;                       /* T [s] */
  int delay;                           /* samples of computation delay, 0 to DP_DIGITAL_ROBUST_MAX_DELAY */
  double K_p, K_v, D;                  /* omega_c^2 [1/s^2], 2 omega_c [1/s], the surface's D [1/s] */
  double beta, b1, b2, b3, epsilon;    /* eqs. 24-25; epsilon the dead zone on ||s|| [rad/s] */
  double layer_samples, rho0;          /* n_s >= 1; rho_hat(0) [N m] */
  int has_limit;                       /* the drive's saturation the observer is told of */
  double torque_limit[3];              /* [N m] */
  int observer_size;
  double transition[36], input_gain[6], observer_gain[6];
} dp_digital_robust_gains;

typedef struct dp_digital_robust dp_digital_robust;

/* A controller; friction: the nominal friction in n̄ (NULL or enabled 0: none); disturbance: F̄
 * [N m]. NULL where an argument is invalid (a period <= 0, a delay out of range, a negative
 * gain, layer_samples < 1, an observer size out of 3..6, a torque limit <= 0). */
dp_digital_robust * dp_digital_robust_create(
  const dp_delta_geometry * geometry, const dp_digital_robust_gains * gains, const dp_friction * friction,
  const double disturbance[3]);
/* The command tau [N m] of one sample from the measured angles alpha [rad] and the reference; 0
 * where it succeeds, 1 where the nominal model has no forward kinematics at an estimate, 2 where
 * the torque is not finite (then tau is not written and the state does not advance). */
int dp_digital_robust_step(
  dp_digital_robust * law, const double alpha[3], const double ref_alpha[3], const double ref_alpha_dot[3],
  const double ref_alpha_ddot[3], double tau[3]);
/* rho_hat [N m] the next step uses, and the observer's velocity estimate [rad/s] of the last step */
double dp_digital_robust_rho(const dp_digital_robust * law, double velocity[3]);
void dp_digital_robust_reset(dp_digital_robust * law);
void dp_digital_robust_destroy(dp_digital_robust * law);

#ifdef __cplusplus
}
#endif

#endif
