// The law of a run (run.hpp), one interface for a compiled law (ProjectedLaw, controller.hpp) and
// a Python call-back (python/bind_run.cpp). It has two faces, one per kind of integrator:
//  - sampled (the RK4 stepper): control(k, ...) once per period, the torque held over it;
//  - continuous (Radau IIA, BDF2): control_at(t, ...) at every evaluation of the integrator,
//    its state z integrated with the plant's, and keep(k, ...) at the samples t_k = k dt.
// A law without a face refuses it in one line (a discrete-time law has no continuous face).
#pragma once

#include <Eigen/Dense>

#include <stdexcept>
#include <string>

namespace delta_pin
{
  class Law
  {
  public:
    typedef Eigen::VectorXd Vector;
    virtual ~Law() = default;

    // sampled: the torque [N m] held over sample k from the plant state x and its actuated joints
    // (alpha [rad], alpha_dot [rad/s]); may throw SimulationFailure (a bad torque, a diverged
    // state), with the sample's time or without one (the run sets k dt)
    virtual Vector control(long /*k*/, const Vector & /*x*/, const Vector & /*alpha*/, const Vector & /*alpha_dot*/)
    {
      throw no_sampled_face();
    }

    // continuous: before the run, records for `samples` samples of a state of `states` values
    virtual void start_continuous(long /*samples*/, Eigen::Index /*states*/) {}
    // continuous: (tau [N m], z_dot) at time t [s] from the plant's assembly q, the actuated
    // joints and the reference at t
    virtual void control_at(
      double /*t*/, const Vector & /*q*/, const Vector & /*alpha*/, const Vector & /*alpha_dot*/,
      const Vector & /*ref_alpha*/, const Vector & /*ref_alpha_dot*/, const Vector & /*ref_alpha_ddot*/,
      const Vector & /*z*/, Vector & /*tau*/, Vector & /*z_dot*/)
    {
      throw no_continuous_face();
    }
    // continuous: the evaluation at sample k was the one kept (its torque and state)
    virtual void keep(long /*k*/, const Vector & /*tau*/, const Vector & /*z*/) {}

    // the faces it has (a run checks before it starts)
    virtual bool sampled() const { return true; }
    virtual bool continuous() const { return true; }
    static std::invalid_argument no_sampled_face()
    {
      return std::invalid_argument("this law has no sampled face: run it with integrator='radau' or 'bdf2'");
    }
    static std::invalid_argument no_continuous_face()
    {
      return std::invalid_argument(
        "this law has no continuous face (a discrete-time law, or a sampled call-back): run it with integrator='rk4'");
    }
  };
} // namespace delta_pin
