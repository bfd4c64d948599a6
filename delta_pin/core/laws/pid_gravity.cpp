// PID + gravity in joint space (PIDGravity in delta_pin/control/pid_gravity.py; its readable twin in
// tests/reference/laws.py):
//   tau = Ḡ(alpha) + F̄ [+ M̄_f(alpha_dot)] - K_p r - K_i z - K_d r_dot,  z_dot = r = alpha - alpha^d,
// the integral z the law's continuous-time state [rad s]. The example of a compiled law added in
// one file (law_registry.hpp).
#include "checks.hpp"
#include "controller.hpp"
#include "law_registry.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/stl/shared_ptr.h>
#include <nanobind/stl/string.h>

#include <memory>

namespace
{
  namespace nb = nanobind;
  using delta_pin::Matrix;
  using delta_pin::Vector;

  struct PIDGravityGains
  {
    Vector K_p, K_i, K_d;  // [N m/rad], [N m/(rad s)], [N m s/rad]
  };

  class PIDGravityLaw : public delta_pin::ProjectedLaw
  {
  public:
    PIDGravityLaw(
      std::shared_ptr<delta_pin::NominalTerms> model, const Vector & disturbance, const std::string & name,
      const PIDGravityGains & gains)
    : ProjectedLaw(std::move(model), disturbance, name)
    , gains_(gains)
    {
      delta_pin::check_size(gains_.K_p, dof(), "K_p");  // one per actuated joint
      delta_pin::check_size(gains_.K_i, dof(), "K_i");
      delta_pin::check_size(gains_.K_d, dof(), "K_d");
    }

  protected:
    void law(const Matrix &, const Matrix &, const Vector & G, const Vector & compensation, const Vector & alpha,
             const Vector & alpha_dot, const Vector & ref_alpha, const Vector & ref_alpha_dot, const Vector &,
             const Vector & state, Vector & torque, Vector & state_dot) override
    {
      delta_pin::check_size(state, dof(), "state");  // the integral of r
      const Vector r = alpha - ref_alpha;
      torque = G + compensation - gains_.K_p.cwiseProduct(r) - gains_.K_i.cwiseProduct(state)
               - gains_.K_d.cwiseProduct(alpha_dot - ref_alpha_dot);
      state_dot = r;
    }

  private:
    PIDGravityGains gains_;
  };

  void bind(nb::module_ & m)
  {
    nb::class_<PIDGravityGains>(m, "PIDGravityGains", "PID + gravity's gains by name (SI units).")
      .def(nb::init<>())
      .def_rw("K_p", &PIDGravityGains::K_p)
      .def_rw("K_i", &PIDGravityGains::K_i)
      .def_rw("K_d", &PIDGravityGains::K_d);
    nb::class_<PIDGravityLaw, delta_pin::ProjectedLaw>(m, "PIDGravity")
      .def(nb::init<std::shared_ptr<delta_pin::NominalTerms>, const Vector &, const std::string &, const PIDGravityGains &>(),
           nb::arg("model"), nb::arg("disturbance"), nb::arg("name"), nb::arg("gains"));
  }

  const delta_pin::RegisterLaw registered(&bind);
} // namespace
