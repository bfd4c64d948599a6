// The Python face of the continuous mode (continuous.hpp): run_continuous, called from
// delta_pin/sim/continuous_core.py. Registered by module.cpp (bind_continuous).

#include "continuous.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/stl/string.h>

namespace nb = nanobind;

void bind_continuous(nb::module_ & m)
{
  using namespace delta_pin;
  nb::class_<ContinuousRun>(m, "ContinuousRun", "The records of a continuous run at its samples.")
    .def_ro("alpha", &ContinuousRun::alpha)
    .def_ro("alpha_dot", &ContinuousRun::alpha_dot)
    .def_ro("q", &ContinuousRun::q)
    .def_ro("v", &ContinuousRun::v)
    .def_ro("xyz", &ContinuousRun::xyz)
    .def_ro("gap", &ContinuousRun::gap)
    .def_ro("samples", &ContinuousRun::samples)
    .def_ro("failure_time", &ContinuousRun::failure_time)
    .def_prop_ro("counters", [](const ContinuousRun & run) {
      const RadauCounters & c = run.counters;
      return nb::make_tuple(c.steps, c.rejected, c.evaluations, c.jacobians, c.factorizations);
    }, "(steps, rejected steps, evaluations, Jacobians, factorisations) of Radau IIA");
  m.def(
    "run_continuous",
    [](ClosedChainPlant & plant, ProjectedLaw & law, double step, const RowMatrix & alpha, const RowMatrix & alpha_dot,
       const RowMatrix & alpha_ddot, const RowMatrix & alpha_dddot, const Indices & actuated_v, const Vector & q_start,
       const Vector & alpha0, const Vector & alpha_dot0, const Vector & z0, double dt, long samples, double rtol,
       double atol, double first_step, double max_step, double max_joint_speed, ContinuousRun & run)
    {
      HermiteReference reference{step, alpha, alpha_dot, alpha_ddot, alpha_dddot};
      RadauOptions options;
      options.rtol = rtol;
      options.atol = atol;
      options.first_step = first_step;
      options.max_step = max_step;
      nb::gil_scoped_release release;  // nothing in the loop touches Python
      run_continuous(
        plant, law, reference, actuated_v, q_start, alpha0, alpha_dot0, z0, dt, samples, options, max_joint_speed, run);
    },
    nb::arg("plant"), nb::arg("law"), nb::arg("step"), nb::arg("alpha"), nb::arg("alpha_dot"), nb::arg("alpha_ddot"),
    nb::arg("alpha_dddot"), nb::arg("actuated_v"), nb::arg("q_start"), nb::arg("alpha0"), nb::arg("alpha_dot0"),
    nb::arg("z0"), nb::arg("dt"), nb::arg("samples"), nb::arg("rtol"), nb::arg("atol"), nb::arg("first_step"),
    nb::arg("max_step"), nb::arg("max_joint_speed"), nb::arg("run"),
    "Continuous mode: the plant and the compiled law integrated by Radau IIA (continuous.hpp); the records "
    "go to `run` (kept up to a SimulationFailure).");
  m.def("new_continuous_run", []() { return ContinuousRun(); });
}
