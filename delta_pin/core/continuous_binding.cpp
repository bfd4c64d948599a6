// The Python face of the continuous mode (continuous.hpp): run_continuous, called from
// delta_pin/sim/continuous_core.py. Registered by module.cpp (bind_continuous).

#include "continuous.hpp"
#include "failure.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>

#include <memory>
#include <tuple>

namespace nb = nanobind;

namespace
{
  using namespace delta_pin;

  // A controller in Python inside the compiled continuous loop: each call takes the GIL; an
  // exception it raises is kept and the loop unwound by CallbackError, then raised again.
  class PythonContinuousLaw : public ContinuousLaw
  {
  public:
    PythonContinuousLaw(nb::callable evaluate, nb::callable keep)
    : evaluate_(std::move(evaluate))
    , keep_(std::move(keep))
    {
    }
    ~PythonContinuousLaw() override
    {
      nb::gil_scoped_acquire gil;  // the callables' references are dropped under the GIL
      evaluate_.reset();
      keep_.reset();
    }
    void evaluate(
      double t, const Vector & q, const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha,
      const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot, const Vector & z, Vector & tau,
      Vector & z_dot) override
    {
      nb::gil_scoped_acquire gil;
      try
      {
        nb::object out = evaluate_(t, q, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z);
        auto pair = nb::cast<std::tuple<Vector, Vector>>(out);
        tau = std::get<0>(pair);
        z_dot = std::get<1>(pair);
      }
      catch (nb::python_error & error)
      {
        keep_error(error);
      }
    }
    void keep(long k, const Vector & tau, const Vector & z) override
    {
      nb::gil_scoped_acquire gil;
      try
      {
        keep_(k, tau, z);
      }
      catch (nb::python_error & error)
      {
        keep_error(error);
      }
    }
    [[noreturn]] void raise() { throw *error_; }

  private:
    [[noreturn]] void keep_error(nb::python_error & error)
    {
      error_ = std::make_unique<nb::python_error>(std::move(error));
      throw CallbackError();
    }
    nb::callable evaluate_, keep_;
    std::unique_ptr<nb::python_error> error_;
  };
} // namespace

void bind_continuous(nb::module_ & m)
{
  nb::class_<ContinuousRun>(m, "ContinuousRun", "The records of a continuous run at its samples.")
    .def_ro("alpha", &ContinuousRun::alpha)
    .def_ro("alpha_dot", &ContinuousRun::alpha_dot)
    .def_ro("tau", &ContinuousRun::tau)
    .def_ro("state", &ContinuousRun::state)
    .def_ro("q", &ContinuousRun::q)
    .def_ro("v", &ContinuousRun::v)
    .def_ro("xyz", &ContinuousRun::xyz)
    .def_ro("gap", &ContinuousRun::gap)
    .def_ro("samples", &ContinuousRun::samples)
    .def_ro("failure_time", &ContinuousRun::failure_time)
    .def_prop_ro("counters", [](const ContinuousRun & run) {
      const RadauCounters & c = run.counters;
      return nb::make_tuple(c.steps, c.rejected, c.evaluations, c.jacobians, c.factorizations);
    }, "(steps, rejected steps, evaluations, Jacobians, factorisations) of Radau IIA")
    .def_prop_ro("bdf2_counters", [](const ContinuousRun & run) {
      const Bdf2Counters & c = run.bdf2_counters;
      return nb::make_tuple(c.steps, c.evaluations, c.split_steps, c.jacobians);
    }, "(steps, evaluations, split steps, Jacobians) of BDF2");
  m.def(
    "run_continuous",
    [](CorePlant & plant, nb::object law, double step, const RowMatrix & alpha, const RowMatrix & alpha_dot,
       const RowMatrix & alpha_ddot, const RowMatrix & alpha_dddot, const Vector & q_start,
       const Vector & alpha0, const Vector & alpha_dot0, const Vector & z0, double dt, long samples, double rtol,
       double atol, double first_step, double max_step, double max_joint_speed, ContinuousRun & run,
       int bdf2_substeps, long projection_interval)
    {
      HermiteReference reference{step, alpha, alpha_dot, alpha_ddot, alpha_dddot, bdf2_substeps > 0};
      RadauOptions options;
      options.rtol = rtol;
      options.atol = atol;
      options.first_step = first_step;
      options.max_step = max_step;
      ProjectedLaw * compiled = nullptr;
      if (nb::try_cast<ProjectedLaw *>(law, compiled) && compiled != nullptr)
      {
        ProjectedContinuousLaw adapter(*compiled, samples, z0.size());
        nb::gil_scoped_release release;  // nothing in the loop touches Python
        run_continuous(
          plant, adapter, reference, q_start, alpha0, alpha_dot0, z0, dt, samples, options,
          max_joint_speed, run, bdf2_substeps, projection_interval);
        return;
      }
      // a law in Python: (evaluate, keep), called with the GIL held
      PythonContinuousLaw adapter(nb::cast<nb::callable>(law.attr("evaluate")), nb::cast<nb::callable>(law.attr("keep")));
      try
      {
        nb::gil_scoped_release release;
        run_continuous(
          plant, adapter, reference, q_start, alpha0, alpha_dot0, z0, dt, samples, options,
          max_joint_speed, run, bdf2_substeps, projection_interval);
      }
      catch (const CallbackError &)
      {
        adapter.raise();
      }
    },
    nb::arg("plant"), nb::arg("law"), nb::arg("step"), nb::arg("alpha"), nb::arg("alpha_dot"), nb::arg("alpha_ddot"),
    nb::arg("alpha_dddot"), nb::arg("q_start"), nb::arg("alpha0"), nb::arg("alpha_dot0"),
    nb::arg("z0"), nb::arg("dt"), nb::arg("samples"), nb::arg("rtol"), nb::arg("atol"), nb::arg("first_step"),
    nb::arg("max_step"), nb::arg("max_joint_speed"), nb::arg("run"), nb::arg("bdf2_substeps") = 0,
    nb::arg("projection_interval") = 0,
    "Continuous mode: a plant (ClosedChainPlant, AnalyticDeltaPlant) and a law integrated by Radau IIA, or with "
    "bdf2_substeps > 0 by BDF2 with fixed steps dt / bdf2_substeps (continuous.hpp); a plant with idle motions or "
    "passive joints in its whole state, projected back onto the loops every projection_interval samples; the law is a compiled "
    "ProjectedLaw, or an object with evaluate(t, q, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, "
    "z) -> (tau, z_dot) and keep(k, tau, z) called from the loop (what it raises passes through "
    "unchanged). The records go to `run` (kept up to a SimulationFailure).");
  m.def("new_continuous_run", []() { return ContinuousRun(); });
}
