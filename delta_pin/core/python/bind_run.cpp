// The Python face of the core's one run (run.hpp): RunSettings, DriveSettings, RunRecords, HermiteReference and
// run(), called from delta_pin/sim/loop.py (run_loop). Registered by module.cpp (bind_run).

#include "binding.hpp"
#include "failure.hpp"
#include "run.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>

#include <memory>
#include <optional>
#include <tuple>

namespace nb = nanobind;

namespace
{
  using namespace delta_pin;
  using binding::keep_python_error;
  using binding::raise_kept_python_error;

  // A law written in Python behind the run's one interface (law.hpp), with either face or both: a
  // callable control(k, x, alpha, alpha_dot) -> tau (the sampled face: the plant state and the
  // joints as the drive's encoder reads them), and methods evaluate(t, q, alpha, alpha_dot,
  // ref_alpha, ref_alpha_dot, ref_alpha_ddot, z) -> (tau, z_dot) and keep(k, tau, z) (the
  // continuous face).
  // Each call takes the GIL; an exception it raises is kept and the run unwound by CallbackError,
  // then raised again (binding.hpp).
  class CallbackLaw : public Law
  {
  public:
    explicit CallbackLaw(nb::object law)
    {
      if (nb::hasattr(law, "evaluate") && nb::hasattr(law, "keep"))
      {
        evaluate_ = nb::cast<nb::callable>(law.attr("evaluate"));
        keep_ = nb::cast<nb::callable>(law.attr("keep"));
      }
      if (PyCallable_Check(law.ptr()))
        control_ = nb::cast<nb::callable>(law);
      if (!control_.is_valid() && !evaluate_.is_valid())
        throw std::invalid_argument(
          "law must be a compiled law, a callable control(k, x, alpha, alpha_dot) -> tau or an object with "
          "evaluate() and keep()");
    }
    ~CallbackLaw() override
    {
      nb::gil_scoped_acquire gil;  // the callables' references are dropped under the GIL
      control_.reset();
      evaluate_.reset();
      keep_.reset();
    }
    Vector control(long k, const Vector & x, const Vector & alpha, const Vector & alpha_dot) override
    {
      if (!control_.is_valid())
        return Law::control(k, x, alpha, alpha_dot);
      nb::gil_scoped_acquire gil;
      try
      {
        return nb::cast<Vector>(control_(k, x, alpha, alpha_dot));
      }
      catch (nb::python_error & error)
      {
        keep_error(error);
      }
    }
    void control_at(
      double t, const Vector & q, const Vector & alpha, const Vector & alpha_dot, const Vector & ref_alpha,
      const Vector & ref_alpha_dot, const Vector & ref_alpha_ddot, const Vector & z, Vector & tau,
      Vector & z_dot) override
    {
      if (!evaluate_.is_valid())
        return Law::control_at(t, q, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z, tau, z_dot);
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
      if (!keep_.is_valid())
        return;
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
    bool sampled() const override { return control_.is_valid(); }
    bool continuous() const override { return evaluate_.is_valid(); }

  private:
    [[noreturn]] void keep_error(nb::python_error & error) { keep_python_error(error); }
    nb::callable control_, evaluate_, keep_;
  };

  // the plant, the law and the stepper of settings.integrator, run from the plant state x0
  void run_parts(
    CorePlant & plant, Law & law, const RunSettings & settings, const Vector & x0, const std::optional<Vector> & z0,
    std::optional<HermiteReference> & reference, RunRecords & records)
  {
    const std::string & integrator = settings.integrator;
    if (integrator == "rk4")
    {
      if (!law.sampled())
        throw Law::no_sampled_face();
      if (z0 || reference)
        throw std::invalid_argument(
          "z0 and reference are the continuous mode's (integrator='radau' or 'bdf2'); a sampled law holds its own");
      HeldTorqueRk4 stepper(plant, law, x0, settings);
      run(plant, stepper, settings.samples, records);
      return;
    }
    if (integrator != "radau" && integrator != "bdf2")
      throw std::invalid_argument("integrator is '" + integrator + "', expected 'rk4', 'radau' or 'bdf2'");
    if (!law.continuous())
      throw Law::no_continuous_face();
    if (settings.drive.active())
      throw std::invalid_argument(
        "settings.drive (an encoder, a delay, a torque limit) acts between samples: integrator='rk4'");
    if (!z0 || !reference)
      throw std::invalid_argument("a continuous run (integrator='" + integrator + "') needs z0 and reference");
    check_size(x0, plant.nq() + plant.nv(), "x0");  // [q, v]
    check_finite(x0, "x0");
    Vector alpha0(plant.actuated_q().size()), alpha_dot0(plant.actuated_v().size());
    plant.joint_state(x0, alpha0, alpha_dot0);
    reference->linear = integrator == "bdf2";  // BDF2's stages lie on the grid
    ContinuousSystem system(plant, law, *reference, x0.head(plant.nq()), alpha0, alpha_dot0, *z0, settings);
    if (integrator == "radau")
    {
      RadauSteps stepper(system, settings);
      run(plant, stepper, settings.samples, records);
    }
    else
    {
      Bdf2Steps stepper(system, settings);
      run(plant, stepper, settings.samples, records);
    }
  }
} // namespace

void bind_run(nb::module_ & m)
{
  nb::class_<delta_pin::DriveSettings>(
    m, "DriveSettings", "The encoder (resolution [rad], noise per sample [rad], exact velocity) and the drive "
    "(delay [samples], torque limit [N m] per actuated joint, or empty) between the plant and the law of a sampled run.")
    .def(nb::init<>())
    .def_rw("sensor", &delta_pin::DriveSettings::sensor)
    .def_rw("resolution", &delta_pin::DriveSettings::resolution)
    .def_rw("noise", &delta_pin::DriveSettings::noise)
    .def_rw("exact_velocity", &delta_pin::DriveSettings::exact_velocity)
    .def_rw("drive", &delta_pin::DriveSettings::drive)
    .def_rw("delay", &delta_pin::DriveSettings::delay)
    .def_rw("torque_limit", &delta_pin::DriveSettings::torque_limit);
  nb::class_<RunSettings>(m, "RunSettings", "What a run is asked for, by name (SI units; run.hpp).")
    .def(nb::init<>())
    .def_rw("integrator", &RunSettings::integrator, "'rk4' (sampled: the torque held over each period), "
            "'radau' or 'bdf2' (continuous: plant and law as one ODE)")
    .def_rw("dt", &RunSettings::dt, "the sample period [s]")
    .def_rw("samples", &RunSettings::samples, "the samples recorded, t_k = k dt")
    .def_rw("substeps", &RunSettings::substeps, "RK4's or BDF2's fixed steps per sample")
    .def_rw("rtol", &RunSettings::rtol, "Radau IIA's relative tolerance")
    .def_rw("atol", &RunSettings::atol, "Radau IIA's absolute tolerance (SI units of the state)")
    .def_rw("first_step", &RunSettings::first_step, "Radau IIA's first step [s]")
    .def_rw("max_step", &RunSettings::max_step, "Radau IIA's largest step [s]")
    .def_rw("max_joint_speed", &RunSettings::max_joint_speed, "the divergence limit on |alpha_dot| [rad/s]")
    .def_rw("projection_interval", &RunSettings::projection_interval,
            "samples between a whole-state continuous run's projections onto the loops (0: none)")
    .def_rw("drive", &RunSettings::drive, "the encoder and the drive between the plant and the law (DriveSettings; "
            "sampled mode)");
  nb::class_<RunRecords>(m, "RunRecords", "What a run recorded at its samples (run.hpp).")
    .def(nb::init<>())
    .def_ro("alpha", &RunRecords::alpha)
    .def_ro("alpha_dot", &RunRecords::alpha_dot)
    .def_ro("tau", &RunRecords::tau, "the torque that acted [N m]")
    .def_ro("state", &RunRecords::state, "the law's integrated state (continuous mode)")
    .def_ro("q", &RunRecords::q)
    .def_ro("v", &RunRecords::v)
    .def_ro("xyz", &RunRecords::xyz)
    .def_ro("gap", &RunRecords::gap)
    .def_ro("commands", &RunRecords::commands, "with a drive: the law's command at each sample [N m]")
    .def_ro("hits", &RunRecords::hits, "with a torque limit: the samples at which it bound")
    .def_ro("samples", &RunRecords::samples, "the samples recorded (all, or up to a failure)")
    .def_ro("failure_time", &RunRecords::failure_time, "[s] the time of the failure that stopped it (NaN: none)")
    .def_prop_ro("radau_counters", [](const RunRecords & run) {
      const RadauCounters & c = run.radau;
      return nb::make_tuple(c.steps, c.rejected, c.evaluations, c.jacobians, c.factorizations);
    }, "(steps, rejected steps, evaluations, Jacobians, factorisations) of Radau IIA")
    .def_prop_ro("bdf2_counters", [](const RunRecords & run) {
      const Bdf2Counters & c = run.bdf2;
      return nb::make_tuple(c.steps, c.evaluations, c.split_steps, c.jacobians);
    }, "(steps, evaluations, split steps, Jacobians) of BDF2");
  nb::class_<HermiteReference>(
    m, "HermiteReference", "alpha^d and its three derivatives on a uniform grid of `step` [s] (one row per "
    "point, one column per actuated joint), read by cubic Hermite interpolation (linearly by BDF2).")
    .def(nb::init<>())
    .def_rw("step", &HermiteReference::step)
    .def_rw("alpha", &HermiteReference::alpha)
    .def_rw("alpha_dot", &HermiteReference::alpha_dot)
    .def_rw("alpha_ddot", &HermiteReference::alpha_ddot)
    .def_rw("alpha_dddot", &HermiteReference::alpha_dddot);
  m.def(
    "run",
    [](CorePlant & plant, nb::object law, const RunSettings & settings, const Vector & x0, RunRecords & records,
       std::optional<Vector> z0, std::optional<HermiteReference> reference)
    {
      ProjectedLaw * compiled = nullptr;
      if (nb::try_cast<ProjectedLaw *>(law, compiled) && compiled != nullptr)
      {
        try
        {
          // Python is not called unless the plant or the law's nominal model is a Python one
          nb::gil_scoped_release release;
          run_parts(plant, *compiled, settings, x0, z0, reference, records);
        }
        catch (const CallbackError &)
        {
          raise_kept_python_error();
        }
        return;
      }
      CallbackLaw adapter(law);
      try
      {
        nb::gil_scoped_release release;
        run_parts(plant, adapter, settings, x0, z0, reference, records);
      }
      catch (const CallbackError &)
      {
        raise_kept_python_error();
      }
    },
    nb::arg("plant"), nb::arg("law"), nb::arg("settings"), nb::arg("x0"), nb::arg("records"),
    nb::arg("z0").none() = nb::none(), nb::arg("reference").none() = nb::none(),
    "The core's one run (run.hpp): the plant (ClosedChainPlant, AnalyticDeltaPlant, PythonPlant) from its state "
    "x0 = [q, v] under the law -- a compiled law, or a Python one: callable as control(k, x, alpha, alpha_dot) -> "
    "tau (sampled: the joints as settings.drive's encoder reads them) and/or with methods "
    "evaluate(t, q, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z) -> (tau, z_dot) and keep(k, "
    "tau, z) (continuous) -- stepped by settings.integrator: 'rk4' (the torque at t_k held over the period), "
    "'radau' or 'bdf2' (plant and law as one ODE from the law's state z0 along the reference). What the law "
    "raises passes through unchanged; a SimulationFailure leaves the samples before it in `records`.");
}
