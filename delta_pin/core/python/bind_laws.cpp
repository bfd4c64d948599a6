// The compiled laws in Python (issue 38, item 2: one binding file per part): their nominal models
// (a closed chain's projection, the Delta's analytic model, a Python one), ProjectedLaw, what
// every law on a nominal model shares, each law with its gains struct,
// and the laws of core/laws/ that bind themselves (law_registry.hpp).

#include "law_registry.hpp"
#include "binding.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/function.h>
#include <nanobind/stl/shared_ptr.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <memory>
#include <tuple>

namespace nb = nanobind;
using namespace delta_pin::binding;
using delta_pin::RowMatrix;
using delta_pin::check_finite;

namespace
{
  using Terms = std::shared_ptr<delta_pin::NominalTerms>;

  // A nominal model written in Python (any delta_pin NominalModel, or an object with its
  // methods): terms(alpha, alpha_dot) -> (M, C, G) and compensation(alpha_dot) -> F̄ [+ M̄_f],
  // called back with the GIL taken; what they raise is kept and the run unwound by
  // CallbackError, then raised again unchanged (binding.hpp).
  class PythonTerms : public delta_pin::NominalTerms
  {
  public:
    PythonTerms(Eigen::Index dof, nb::callable terms, nb::callable compensation)
    : dof_(dof)
    , terms_(std::move(terms))
    , compensation_(std::move(compensation))
    {
      if (dof < 1)
        throw std::invalid_argument("dof=" + std::to_string(dof) + ": a nominal model needs >= 1 actuated joint");
    }
    ~PythonTerms() override
    {
      nb::gil_scoped_acquire gil;  // the callables' references are dropped under the GIL
      terms_.reset();
      compensation_.reset();
    }
    Eigen::Index dof() const override { return dof_; }
    void terms(const Vector & alpha, const Vector & alpha_dot, Matrix & M, Matrix & C, Vector & G) override
    {
      nb::gil_scoped_acquire gil;
      try
      {
        auto out = nb::cast<std::tuple<Matrix, Matrix, Vector>>(terms_(alpha, alpha_dot));
        M = std::get<0>(out);
        C = std::get<1>(out);
        G = std::get<2>(out);
      }
      catch (nb::python_error & error)
      {
        keep_python_error(error);
      }
      catch (const nb::cast_error &)
      {
        throw std::invalid_argument("the nominal model's terms() must return (M, C, G): two matrices and a vector");
      }
    }
    bool compensation(const Vector & alpha_dot, Vector & out) override
    {
      nb::gil_scoped_acquire gil;
      try
      {
        out = nb::cast<Vector>(compensation_(alpha_dot));
      }
      catch (nb::python_error & error)
      {
        keep_python_error(error);
      }
      catch (const nb::cast_error &)
      {
        throw std::invalid_argument("the nominal model's compensation() must return a vector [N m]");
      }
      return true;
    }

  private:
    Eigen::Index dof_;
    nb::callable terms_, compensation_;
  };

  // the gains of the two laws whose C++ constructors take their vectors one by one
  struct ComputedTorqueGains
  {
    Eigen::VectorXd D, T_p, T_v;  // [1/s], [N m/rad], [N m s/rad]
  };
  struct PDGravityGains
  {
    Eigen::VectorXd K_p, K_d;  // [N m/rad], [N m s/rad]
  };
} // namespace

void bind_laws(nb::module_ & m)
{
  // a law's nominal model, one of three kinds (nominal_terms.hpp), shared with the law
  nb::class_<delta_pin::NominalTerms>(
    m, "NominalTerms", "A compiled law's nominal model: M, C, G of the actuated joints (nominal_terms.hpp).")
    .def_prop_ro("dof", &delta_pin::NominalTerms::dof);
  nb::class_<delta_pin::ProjectedTerms, delta_pin::NominalTerms>(
    m, "ProjectedTerms", "A closed chain's projected dynamics (ClosedChainNominalModel).")
    .def(nb::init<const delta_pin::ChainDescription &, const Eigen::VectorXd &>(), nb::arg("chain"),
         nb::arg("reference_configuration"));
  nb::class_<delta_pin::DeltaTerms, delta_pin::NominalTerms>(
    m, "DeltaTerms",
    "The Delta's analytic M, C, G (eqs. 7-10; lengths [m], the arm's inertia [kg m^2] and gravity torque [N m], "
    "g [m/s^2], m_eq [kg], the chain azimuths' cos and sin; DeltaNominalModel).")
    .def(
      "__init__",
      [](delta_pin::DeltaTerms * self, double R, double r, double l_a, double l_b, double arm_inertia,
         double arm_gravity, double g, double m_eq, const Eigen::Vector3d & cos_phi, const Eigen::Vector3d & sin_phi)
      { new (self) delta_pin::DeltaTerms(delta_geometry(R, r, l_a, l_b, arm_inertia, arm_gravity, g, m_eq, cos_phi, sin_phi)); },
      nb::arg("R"), nb::arg("r"), nb::arg("l_a"), nb::arg("l_b"), nb::arg("arm_inertia"), nb::arg("arm_gravity"),
      nb::arg("g"), nb::arg("m_eq"), nb::arg("cos_phi"), nb::arg("sin_phi"));
  nb::class_<PythonTerms, delta_pin::NominalTerms>(
    m, "PythonTerms",
    "A nominal model written in Python, called back: terms(alpha, alpha_dot) -> (M, C, G) and "
    "compensation(alpha_dot) -> F [N m] (the law's F̄ [+ M̄_f]).")
    .def(nb::init<Eigen::Index, nb::callable, nb::callable>(), nb::arg("dof"), nb::arg("terms"),
         nb::arg("compensation"));
  nb::class_<delta_pin::ProjectedLaw>(m, "ProjectedLaw")
    .def(
      "set_friction",
      [](delta_pin::ProjectedLaw & self, const delta_pin::FrictionSpec & friction) { self.set_friction(switched_on(friction)); },
      nb::arg("friction"),
      "The nominal friction the law compensates (eq. 12).")
    .def("start", &delta_pin::ProjectedLaw::start,
         "The reference table, the period [s], the initial state and the samples to record.")
    .def(
      "evaluate",
      [](delta_pin::ProjectedLaw & self, const Eigen::VectorXd & alpha, const Eigen::VectorXd & alpha_dot,
         const Eigen::VectorXd & ref_alpha, const Eigen::VectorXd & ref_alpha_dot, const Eigen::VectorXd & ref_alpha_ddot,
         const Eigen::VectorXd & state)
      {
        check_finite(alpha, "alpha");
        check_finite(alpha_dot, "alpha_dot");
        check_finite(ref_alpha, "ref_alpha");
        check_finite(ref_alpha_dot, "ref_alpha_dot");
        check_finite(ref_alpha_ddot, "ref_alpha_ddot");
        check_finite(state, "state");
        Eigen::VectorXd tau, state_dot;
        try
        {
          self.evaluate(alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, state, tau, state_dot);
        }
        catch (const delta_pin::CallbackError &)  // a Python nominal model raised
        {
          raise_kept_python_error();
        }
        return std::make_tuple(tau, state_dot);
      },
      nb::arg("alpha"), nb::arg("alpha_dot"), nb::arg("ref_alpha"), nb::arg("ref_alpha_dot"), nb::arg("ref_alpha_ddot"),
      nb::arg("state"), "(tau, the state's derivative) at one state.")
    .def_prop_ro(
      "records",
      [](const delta_pin::ProjectedLaw & self)
      {
        const delta_pin::Records records = self.records();
        nb::dict out;
        for (const auto & [name, value] : records.matrices)
          out[name.c_str()] = nb::cast(value);
        for (const auto & [name, value] : records.vectors)
          out[name.c_str()] = nb::cast(value);
        return out;
      },
      "The law's own records of its last run by name (samples rows), besides tau and state: what its "
      "Python twin's evaluate() returns as internals.")
    .def_prop_ro(
      "discrete", [](const delta_pin::ProjectedLaw & self) { return !self.continuous(); },
      "Whether the law is discrete-time (evaluate() returns its next state, not the state's derivative).")
    .def_ro("tau", &delta_pin::ProjectedLaw::tau)
    .def_ro("state", &delta_pin::ProjectedLaw::state);
  for (const delta_pin::LawBinder bind_law : delta_pin::law_binders())  // core/laws/*.cpp
    bind_law(m);
  // gains cross the binding by name (issue 38, item 3): one struct per law, each field bound, and
  // each law's constructor takes (model, disturbance, name, gains)
  nb::class_<ComputedTorqueGains>(m, "ComputedTorqueGains", "Computed torque's gains by name (SI units).")
    .def(nb::init<>())
    .def_rw("D", &ComputedTorqueGains::D)
    .def_rw("T_p", &ComputedTorqueGains::T_p)
    .def_rw("T_v", &ComputedTorqueGains::T_v);
  nb::class_<delta_pin::ComputedTorqueLaw, delta_pin::ProjectedLaw>(m, "ComputedTorque")
    .def(
      "__init__",
      [](delta_pin::ComputedTorqueLaw * self, Terms model, const Eigen::VectorXd & disturbance, const std::string & name, const ComputedTorqueGains & g)
      { new (self) delta_pin::ComputedTorqueLaw(std::move(model), disturbance, name, g.D, g.T_p, g.T_v); },
      nb::arg("model"), nb::arg("disturbance"), nb::arg("name"),
      nb::arg("gains"));
  nb::class_<PDGravityGains>(m, "PDGravityGains", "PD + gravity's gains by name (SI units).")
    .def(nb::init<>())
    .def_rw("K_p", &PDGravityGains::K_p)
    .def_rw("K_d", &PDGravityGains::K_d);
  nb::class_<delta_pin::PDGravityLaw, delta_pin::ProjectedLaw>(m, "PDGravity")
    .def(
      "__init__",
      [](delta_pin::PDGravityLaw * self, Terms model, const Eigen::VectorXd & disturbance, const std::string & name, const PDGravityGains & g)
      { new (self) delta_pin::PDGravityLaw(std::move(model), disturbance, name, g.K_p, g.K_d); },
      nb::arg("model"), nb::arg("disturbance"), nb::arg("name"),
      nb::arg("gains"));
  using AdaptiveRobustGains = delta_pin::AdaptiveRobustGains<Eigen::Dynamic>;
  nb::class_<AdaptiveRobustGains>(
    m, "AdaptiveRobustGains", "Designs I/II's gains by name (control/adaptive_robust_law.hpp; SI units).")
    .def(nb::init<>())
    .def_rw("D", &AdaptiveRobustGains::D)
    .def_rw("T_p", &AdaptiveRobustGains::T_p)
    .def_rw("T_v", &AdaptiveRobustGains::T_v)
    .def_rw("beta", &AdaptiveRobustGains::beta)
    .def_rw("xi", &AdaptiveRobustGains::xi)
    .def_rw("epsilon", &AdaptiveRobustGains::epsilon)
    .def_rw("b1", &AdaptiveRobustGains::b1)
    .def_rw("b2", &AdaptiveRobustGains::b2)
    .def_rw("b3", &AdaptiveRobustGains::b3)
    .def_rw("design_two", &AdaptiveRobustGains::design_two)
    .def_rw("vector_rho", &AdaptiveRobustGains::vector_rho)
    .def_rw("sampling_period", &AdaptiveRobustGains::sampling_period)
    .def_rw("sampling_margin", &AdaptiveRobustGains::sampling_margin);
  nb::class_<delta_pin::AdaptiveRobust, delta_pin::ProjectedLaw>(m, "AdaptiveRobust")
    .def(
      "__init__",
      [](delta_pin::AdaptiveRobust * self, Terms model, const Eigen::VectorXd & disturbance, const std::string & name, const AdaptiveRobustGains & gains)
      { new (self) delta_pin::AdaptiveRobust(std::move(model), disturbance, name, gains); },
      nb::arg("model"), nb::arg("disturbance"), nb::arg("name"),
      nb::arg("gains"));
  nb::class_<delta_pin::TimeDelayGains>(m, "TimeDelayControlGains", "TDC's gains by name (time_delay_control.hpp).")
    .def(nb::init<>())
    .def_rw("period", &delta_pin::TimeDelayGains::period)
    .def_rw("K_p", &delta_pin::TimeDelayGains::K_p)
    .def_rw("K_v", &delta_pin::TimeDelayGains::K_v)
    .def_rw("delay", &delta_pin::TimeDelayGains::delay)
    .def_rw("mean_pairing", &delta_pin::TimeDelayGains::mean_pairing);
  nb::class_<delta_pin::TimeDelayControlLaw, delta_pin::ProjectedLaw>(m, "TimeDelayControl")
    .def(
      "__init__",
      [](delta_pin::TimeDelayControlLaw * self, Terms model, const Eigen::VectorXd & disturbance, const std::string & name, const delta_pin::TimeDelayGains & g)
      { new (self) delta_pin::TimeDelayControlLaw(std::move(model), disturbance, name, g); },
      nb::arg("model"), nb::arg("disturbance"), nb::arg("name"),
      nb::arg("gains"));
  using DigitalRobustGains = delta_pin::DigitalRobustGains<Eigen::Dynamic>;
  nb::class_<DigitalRobustGains>(
    m, "DigitalRobustGains",
    "The digital robust law's gains and observer by name (control/digital_robust_law.hpp; SI units; an "
    "empty torque_limit: none).")
    .def(nb::init<>())
    .def_rw("period", &DigitalRobustGains::period)
    .def_rw("delay", &DigitalRobustGains::delay)
    .def_rw("K_p", &DigitalRobustGains::K_p)
    .def_rw("K_v", &DigitalRobustGains::K_v)
    .def_rw("D", &DigitalRobustGains::D)
    .def_rw("beta", &DigitalRobustGains::beta)
    .def_rw("b1", &DigitalRobustGains::b1)
    .def_rw("b2", &DigitalRobustGains::b2)
    .def_rw("b3", &DigitalRobustGains::b3)
    .def_rw("epsilon", &DigitalRobustGains::epsilon)
    .def_rw("layer_samples", &DigitalRobustGains::layer_samples)
    .def_rw("torque_limit", &DigitalRobustGains::torque_limit)
    // the observer's tables have a compile-time largest size: checked here before they are copied in
    .def_prop_rw(
      "transition", [](const DigitalRobustGains & g) { return Eigen::MatrixXd(g.transition); },
      [](DigitalRobustGains & g, const Eigen::MatrixXd & value)
      {
        if (value.rows() > delta_pin::observer_max || value.cols() > delta_pin::observer_max)
          throw std::invalid_argument(
            "transition has shape " + delta_pin::shape_text(value.rows(), value.cols()) + ", expected at most ("
            + std::to_string(delta_pin::observer_max) + ", " + std::to_string(delta_pin::observer_max) + ")");
        g.transition = value;
      })
    .def_prop_rw(
      "input_gain", [](const DigitalRobustGains & g) { return Eigen::VectorXd(g.input_gain); },
      [](DigitalRobustGains & g, const Eigen::VectorXd & value)
      {
        if (value.size() > delta_pin::observer_max)
          throw std::invalid_argument(
            "input_gain has " + std::to_string(value.size()) + " entries, expected at most "
            + std::to_string(delta_pin::observer_max));
        g.input_gain = value;
      })
    .def_prop_rw(
      "observer_gain", [](const DigitalRobustGains & g) { return Eigen::VectorXd(g.observer_gain); },
      [](DigitalRobustGains & g, const Eigen::VectorXd & value)
      {
        if (value.size() > delta_pin::observer_max)
          throw std::invalid_argument(
            "observer_gain has " + std::to_string(value.size()) + " entries, expected at most "
            + std::to_string(delta_pin::observer_max));
        g.observer_gain = value;
      });
  nb::class_<delta_pin::DigitalRobustLaw, delta_pin::ProjectedLaw>(m, "DigitalRobust")
    .def(
      "__init__",
      [](delta_pin::DigitalRobustLaw * self, Terms model, const Eigen::VectorXd & disturbance, const std::string & name, const DigitalRobustGains & gains)
      {
        const Eigen::Index size = gains.transition.rows();
        if (size < 3 || size > delta_pin::observer_max || gains.transition.cols() != size)
          throw std::invalid_argument(
            "transition has shape " + delta_pin::shape_text(gains.transition.rows(), gains.transition.cols())
            + ", expected the observer's Phi (S, S) with 3 <= S <= " + std::to_string(delta_pin::observer_max));
        DigitalRobustGains g = gains;
        g.has_limit = g.torque_limit.size() > 0;  // empty: no limit
        new (self) delta_pin::DigitalRobustLaw(std::move(model), disturbance, name, g);
      },
      nb::arg("model"), nb::arg("disturbance"), nb::arg("name"),
      nb::arg("gains"));
  using LqrGains = delta_pin::LqrGains<Eigen::Dynamic>;
  nb::class_<LqrGains>(m, "LQRGains", "The LQR's linearisation and gain by name (lqr_law.hpp; SI units).")
    .def(nb::init<>())
    .def_rw("alpha0", &LqrGains::alpha0)
    .def_rw("gravity", &LqrGains::gravity)
    .def_rw("gravity_slope", &LqrGains::gravity_slope)
    .def_rw("inertia", &LqrGains::inertia)
    .def_rw("gain", &LqrGains::gain);
  nb::class_<delta_pin::LqrLaw, delta_pin::ProjectedLaw>(m, "LQR").def(
    "__init__",
    [](delta_pin::LqrLaw * self, Terms model, const Eigen::VectorXd & disturbance, const std::string & name, const LqrGains & g)
    { new (self) delta_pin::LqrLaw(std::move(model), disturbance, name, g); },
    nb::arg("model"), nb::arg("disturbance"), nb::arg("name"),
    nb::arg("gains"));
}
