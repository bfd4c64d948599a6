// A plant written in Python (a user's delta_pin.sim.plants.Plant, or one of delta-pin's without a
// compiled copy) in the core's sampled loop (plant.hpp): the loop, its RK4 and its checks are the
// core's; the plant's derivative, its correction after a step (finish_step), its joint state, end
// effector and closure gap are called back. Its state x is the plant's own vector (nq = len(x),
// nv = 0, no multibody configuration to record). delta_pin/sim/compiled_plant.py builds it
// (python_core_plant). The continuous loop takes a plant with a compiled copy only.

#include "checks.hpp"
#include "plant.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/stl/function.h>
#include <nanobind/stl/pair.h>

#include <functional>
#include <stdexcept>
#include <string>
#include <utility>

namespace nb = nanobind;

namespace delta_pin
{
  class PythonPlant : public CorePlant
  {
  public:
    using Derivative = std::function<Vector(double, const Vector &, const Vector &)>;  // (t, x, tau) -> dx/dt
    using Finish = std::function<std::pair<Vector, double>(const Vector &, double)>;  // (x, t) -> (x, gap)
    using Joints = std::function<std::pair<Vector, Vector>(const Vector &)>;  // x -> (alpha, alpha_dot)
    using Position = std::function<Eigen::Vector3d(const Vector &)>;  // x -> xyz [m]
    using Gap = std::function<double(const Vector &)>;  // x -> closure gap [m or rad]

    PythonPlant(int states, int dof, Derivative derivative, Finish finish, Joints joints, Position position, Gap gap)
    : states_(states)
    , derivative_(std::move(derivative))
    , finish_(std::move(finish))
    , joints_(std::move(joints))
    , position_(std::move(position))
    , gap_(std::move(gap))
    {
      if (states < 1 || dof < 0)
        throw std::invalid_argument(
          "a Python plant needs a state of >= 1 entries and >= 0 actuated joints, not " + std::to_string(states)
          + " and " + std::to_string(dof));
      actuated_q_ = Indices::LinSpaced(dof, 0, dof - 1);  // not read: joint_state asks the plant
      actuated_v_ = actuated_q_;
    }

    int nq() const override { return states_; }
    int nv() const override { return 0; }
    bool has_configuration() const override { return false; }

    double step(Vector & x, const Vector & tau, double t, double h) override
    {
      auto f = [&](const Vector & y, double time, Vector & dy)
      {
        dy = derivative_(time, y, tau);
        if (dy.size() != states_)
          throw std::invalid_argument(
            "the plant's derivative returned " + std::to_string(dy.size()) + " entries, expected "
            + std::to_string(states_));
      };
      rk4_step(x, t, h, f, k1_, k2_, k3_, k4_, y_);
      auto finished = finish_(x, t + h);
      check_size(finished.first, states_, "the plant's finish_step state");
      x = finished.first;
      return finished.second;
    }

    void joint_state(const Vector & x, Vector & alpha, Vector & alpha_dot) override
    {
      auto joints = joints_(x);
      check_size(joints.first, alpha.size(), "the plant's alpha");
      check_size(joints.second, alpha_dot.size(), "the plant's alpha_dot");
      alpha = joints.first;
      alpha_dot = joints.second;
    }
    Eigen::Vector3d end_effector_position(const Vector & x) override { return position_(x); }
    double closure_gap(const Vector & x) override { return gap_(x); }

    bool complete(const Vector &, const Vector &, Vector &, Vector &) override { throw not_continuous(); }
    void active_accelerations(double, const Vector &, const Vector &, const Vector &, Vector &) override
    {
      throw not_continuous();
    }
    void set_truth_table(const TruthTable &) override {}  // the Python plant reads its own truth

  private:
    static std::logic_error not_continuous()
    {
      return std::logic_error("a plant written in Python runs in the core's sampled loop only");
    }

    int states_;
    Derivative derivative_;
    Finish finish_;
    Joints joints_;
    Position position_;
    Gap gap_;
    Vector k1_, k2_, k3_, k4_, y_;
  };
} // namespace delta_pin

void bind_python_plant(nb::module_ & m)  // called by module.cpp
{
  using delta_pin::CorePlant;
  using delta_pin::PythonPlant;
  nb::class_<PythonPlant, CorePlant>(m, "PythonPlant", "A plant written in Python, stepped by the core's sampled loop.")
    .def(
      nb::init<int, int, PythonPlant::Derivative, PythonPlant::Finish, PythonPlant::Joints, PythonPlant::Position,
               PythonPlant::Gap>(),
      nb::arg("states"), nb::arg("dof"), nb::arg("derivative"), nb::arg("finish_step"), nb::arg("joint_state"),
      nb::arg("platform_position"), nb::arg("closure_residual"),
      "derivative(t, x, tau) -> dx/dt; finish_step(x, t) -> (x, gap); joint_state(x) -> (alpha, alpha_dot); "
      "platform_position(x) -> xyz; closure_residual(x) -> gap.");
}
