// The continuous mode of the compiled core: a plant (plant.hpp) and a law integrated as one ODE
// by Radau IIA with error control (radau.hpp), in active coordinates
//
//     y = [alpha, alpha_dot, z],   y' = [alpha_dot, alpha_ddot(q(alpha), v(alpha_dot), tau, t), z_dot],
//
// where every evaluation completes (q, v) from the actuated joints (for a closed chain q(alpha)
// by Newton, warm-started, and v = S alpha_dot: the loops closed by construction, as
// delta_pin.sim.closed_chain_plant's active coordinates for LSODA; for the reduced Delta q =
// alpha), the law gives (tau, z_dot) at the reference of that time (eqs. 23-26, 30-33 for designs
// I/II), and the plant's dynamics give alpha_ddot with its truth interpolated at t. A plant with
// motion the actuated joints do not determine (idle motions, passive joints) is integrated in
// its whole state instead, y = [q, v, z] (CorePlant::integrates_full_state).
#pragma once

#include "bdf2.hpp"
#include "controller.hpp"
#include "plant.hpp"
#include "radau.hpp"

#include <cmath>

namespace delta_pin
{
  // alpha^d(t) on a uniform grid read by cubic Hermite interpolation (the arithmetic of
  // delta_pin.sim.reference.ReferenceTable: exact at the grid points), or with `linear` by linear
  // interpolation of each row's entries (BDF2's: its stages lie on the grid, and its split steps
  // read the reference as its truth, linearly inside the step)
  struct HermiteReference
  {
    double step = 0.0;
    RowMatrix alpha, alpha_dot, alpha_ddot, alpha_dddot;
    bool linear = false;
    void at(double t, Vector & a, Vector & a_dot, Vector & a_ddot) const;
  };

  // The law of a continuous run: (tau, z_dot) at (t, alpha, alpha_dot) with the plant's assembly
  // q there and the reference at t; keep(k, ...) follows the evaluation at the sample t_k (its
  // torque and state, for the law's records).
  class ContinuousLaw
  {
  public:
    virtual ~ContinuousLaw() = default;
    virtual void evaluate(
      double t, const Vector & q, const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha,
      const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot, const Vector & z, Vector & tau, Vector & z_dot) = 0;
    virtual void keep(long k, const Vector & tau, const Vector & z) = 0;
  };

  // A compiled law of controller.hpp in the continuous run: its nominal assembly warm-started
  // from the plant's, its records (torque, state, internals) at the samples.
  class ProjectedContinuousLaw : public ContinuousLaw
  {
  public:
    ProjectedContinuousLaw(ProjectedLaw & law, long samples, Eigen::Index states)
    : law_(law)
    {
      law_.start_continuous(samples, states);
    }
    void evaluate(
      double, const Vector & q, const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha,
      const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot, const Vector & z, Vector & tau,
      Vector & z_dot) override
    {
      law_.warm_start(q);
      law_.evaluate(alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z, tau, z_dot);
    }
    void keep(long k, const Vector & tau, const Vector & z) override { law_.keep(k, tau, z); }

  private:
    ProjectedLaw & law_;
  };

  // the records of a continuous run at the samples t = k dt
  struct ContinuousRun
  {
    RowMatrix alpha, alpha_dot, tau, state, q, v, xyz;  // the internals: the law's records (keep)
    Vector gap;
    RadauCounters counters;  // Radau IIA's
    Bdf2Counters bdf2_counters;  // BDF2's
    long samples = 0;  // the samples recorded (all of them, or up to a failure)
    double failure_time = std::nan("");  // [s] the time of the SimulationFailure that stopped it
  };

  // Integrate from (alpha0, alpha_dot0, z0) at t = 0 (a closed chain's loops assembled from
  // q_start) over `samples` - 1 periods dt and record the samples: by Radau IIA with `options`,
  // or with bdf2_substeps > 0 by BDF2 (bdf2.hpp) with fixed steps dt / bdf2_substeps. A plant
  // that integrates_full_state (idle motions, passive joints) is integrated as y = [q, v, z]
  // with its whole derivative, started from its completion at (alpha0, alpha_dot0), and
  // projected back onto the loops every projection_interval samples where its gap exceeds the
  // plant's tolerance (the integrator then starts again there; <= 0: never). A failure (the
  // loops cannot be closed, a non-finite state or torque, a torque or state rate of the wrong
  // size, |alpha_dot| above max_joint_speed, the step size collapsing) throws SimulationFailure
  // with its time; a CallbackError of the law passes unchanged; `run` keeps the samples recorded
  // before.
  void run_continuous(
    CorePlant & plant, ContinuousLaw & law, const HermiteReference & reference, const Vector & q_start,
    const Vector & alpha0, const Vector & alpha_dot0, const Vector & z0, double dt, long samples,
    const RadauOptions & options, double max_joint_speed, ContinuousRun & run, int bdf2_substeps = 0,
    long projection_interval = 0);
} // namespace delta_pin
