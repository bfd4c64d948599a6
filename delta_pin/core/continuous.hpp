// The continuous mode of the compiled core: a closed-chain plant and a compiled law integrated as
// one ODE by Radau IIA with error control (radau.hpp), in active coordinates
//
//     y = [alpha, alpha_dot, z],   y' = [alpha_dot, alpha_ddot(q(alpha), S alpha_dot, tau), z_dot],
//
// where every evaluation assembles q(alpha) by Newton (warm-started) and v = S alpha_dot, the law
// gives (tau, z_dot) at the reference of that time (eqs. 23-26, 30-33 for designs I/II), and the
// plant's constrained dynamics (constraintDynamics on the tree) give alpha_ddot: the loops are
// closed by construction, as delta_pin.sim.closed_chain_plant's active coordinates for LSODA.
#pragma once

#include "closed_chain.hpp"
#include "controller.hpp"
#include "radau.hpp"

#include <cmath>

namespace delta_pin
{
  // alpha^d(t) on a uniform grid read by cubic Hermite interpolation (the arithmetic of
  // delta_pin.sim.reference.ReferenceTable: exact at the grid points)
  struct HermiteReference
  {
    double step = 0.0;
    RowMatrix alpha, alpha_dot, alpha_ddot, alpha_dddot;
    void at(double t, Vector & a, Vector & a_dot, Vector & a_ddot) const;
  };

  // the records of a continuous run at the samples t = k dt
  struct ContinuousRun
  {
    RowMatrix alpha, alpha_dot, q, v, xyz;  // the torque, the state, the internals: the law's records
    Vector gap;
    RadauCounters counters;
    long samples = 0;  // the samples recorded (all of them, or up to a failure)
    double failure_time = std::nan("");  // [s] the time of the SimulationFailure that stopped it
  };

  // Integrate from (alpha0, alpha_dot0, z0) at t = 0 (the loops assembled from q_start) over
  // `samples` - 1 periods dt and record the samples; torques act on the joints `actuated_v` (indices in v). A failure (the loops cannot
  // be closed, a non-finite state or torque, |alpha_dot| above max_joint_speed, the step size
  // collapsing) throws SimulationFailure with its time; `run` keeps the samples recorded before.
  void run_continuous(
    ClosedChainPlant & plant, ProjectedLaw & law, const HermiteReference & reference, const Indices & actuated_v,
    const Vector & q_start, const Vector & alpha0, const Vector & alpha_dot0, const Vector & z0, double dt,
    long samples,
    const RadauOptions & options, double max_joint_speed, ContinuousRun & run);
} // namespace delta_pin
