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

  // What a continuous run is asked for, by name (run_continuous): the sample period [s] and count,
  // Radau IIA's tolerances and step bounds [s], the divergence limit [rad/s], BDF2's sub-steps per
  // sample (0: Radau IIA) and the samples between projections of a whole-state run (0: none)
  struct ContinuousSettings
  {
    double dt = 1e-3;
    long samples = 0;
    double rtol = 1e-6, atol = 1e-8, first_step = 1e-5, max_step = 1e-2;
    double max_joint_speed = 1e3;
    int bdf2_substeps = 0;
    long projection_interval = 0;
  };

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
  nb::class_<ContinuousSettings>(m, "ContinuousSettings", "What a continuous run is asked for, by name (SI units).")
    .def(nb::init<>())
    .def_rw("dt", &ContinuousSettings::dt, "the sample period [s]")
    .def_rw("samples", &ContinuousSettings::samples, "the samples recorded, t_k = k dt")
    .def_rw("rtol", &ContinuousSettings::rtol, "Radau IIA's relative tolerance")
    .def_rw("atol", &ContinuousSettings::atol, "Radau IIA's absolute tolerance (SI units of the state)")
    .def_rw("first_step", &ContinuousSettings::first_step, "Radau IIA's first step [s]")
    .def_rw("max_step", &ContinuousSettings::max_step, "Radau IIA's largest step [s]")
    .def_rw("max_joint_speed", &ContinuousSettings::max_joint_speed, "the divergence limit on |alpha_dot| [rad/s]")
    .def_rw("bdf2_substeps", &ContinuousSettings::bdf2_substeps, "BDF2's fixed steps per sample (0: Radau IIA)")
    .def_rw("projection_interval", &ContinuousSettings::projection_interval,
            "samples between a whole-state run's projections onto the loops (0: none)");
  m.def(
    "run_continuous",
    [](CorePlant & plant, nb::object law, double step, const RowMatrix & alpha, const RowMatrix & alpha_dot,
       const RowMatrix & alpha_ddot, const RowMatrix & alpha_dddot, const Vector & q_start,
       const Vector & alpha0, const Vector & alpha_dot0, const Vector & z0, const ContinuousSettings & settings,
       ContinuousRun & run)
    {
      const double dt = settings.dt, max_joint_speed = settings.max_joint_speed;
      const long samples = settings.samples, projection_interval = settings.projection_interval;
      const int bdf2_substeps = settings.bdf2_substeps;
      HermiteReference reference{step, alpha, alpha_dot, alpha_ddot, alpha_dddot, bdf2_substeps > 0};
      RadauOptions options;
      options.rtol = settings.rtol;
      options.atol = settings.atol;
      options.first_step = settings.first_step;
      options.max_step = settings.max_step;
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
    nb::arg("z0"), nb::arg("settings"), nb::arg("run"),
    "Continuous mode: a plant (ClosedChainPlant, AnalyticDeltaPlant) and a law integrated by Radau IIA, or with "
    "settings.bdf2_substeps > 0 by BDF2 with fixed steps dt / bdf2_substeps (continuous.hpp); a plant with idle "
    "motions or passive joints in its whole state, projected back onto the loops every "
    "settings.projection_interval samples; the law is a compiled "
    "ProjectedLaw, or an object with evaluate(t, q, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, "
    "z) -> (tau, z_dot) and keep(k, tau, z) called from the loop (what it raises passes through "
    "unchanged). The records go to `run` (kept up to a SimulationFailure).");
  m.def("new_continuous_run", []() { return ContinuousRun(); });
}
