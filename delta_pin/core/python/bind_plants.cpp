// The plants in Python (issue 38, item 2: one binding file per part): the settings they take by
// name (StribeckFriction), CorePlant -- what every plant of the run shares --, the
// closed chain's constrained plant and the paper's reduced Delta.

#include "binding.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

namespace nb = nanobind;
using namespace delta_pin::binding;
using delta_pin::RowMatrix;
using delta_pin::check_finite;

namespace
{
  // dx/dt of a plant's state x [q, v] under its actuated torques, the truth at the table's row
  // position `row`: shapes and values checked, one line each
  template<typename Plant>
  Eigen::VectorXd checked_derivative(Plant & plant, const Eigen::VectorXd & x, const Eigen::VectorXd & tau, double row)
  {
    delta_pin::check_size(x, plant.nq() + plant.nv(), "x");
    delta_pin::check_size(tau, plant.dof(), "tau");
    check_finite(x, "x");
    check_finite(tau, "tau");
    check_finite(row, "row");
    Eigen::VectorXd dx;
    plant.derivative(x, tau, row, dx);
    return dx;
  }
} // namespace

void bind_plants(nb::module_ & m)
{
  using delta_pin::ChainDescription;
  using delta_pin::ClosedChainPlant;
  nb::class_<delta_pin::FrictionSpec>(
    m, "StribeckFriction", "Eq. 12's friction by name (SI units): r_a [m], v_s [m/s], mu_s, mu_d, mu_v [s/m], "
    "sign_scale [rad/s] (tanh's velocity scale), normal_force [N] per actuated joint.")
    .def(nb::init<>())
    .def_rw("r_a", &delta_pin::FrictionSpec::r_a)
    .def_rw("v_s", &delta_pin::FrictionSpec::v_s)
    .def_rw("mu_s", &delta_pin::FrictionSpec::mu_s)
    .def_rw("mu_d", &delta_pin::FrictionSpec::mu_d)
    .def_rw("mu_v", &delta_pin::FrictionSpec::mu_v)
    .def_rw("sign_scale", &delta_pin::FrictionSpec::sign_scale)
    .def_rw("normal_force", &delta_pin::FrictionSpec::normal_force);
  using delta_pin::AnalyticDeltaPlant;
  using delta_pin::CorePlant;
  nb::class_<CorePlant>(m, "CorePlant", "A plant of the core's loops (plant.hpp).")
    .def_prop_ro("nq", &CorePlant::nq)
    .def_prop_ro("nv", &CorePlant::nv)
    .def_prop_ro("dof", &CorePlant::dof)
    .def_prop_ro("actuated_q", &CorePlant::actuated_q, "The actuated joints' entries in q.")
    .def_prop_ro("actuated_v", &CorePlant::actuated_v, "The actuated joints' entries in v.")
    .def_prop_ro("has_configuration", &CorePlant::has_configuration,
                 "Whether x's q and v are a multibody configuration (a run records them).")
    .def_prop_ro("integrates_full_state", &CorePlant::integrates_full_state,
                 "Whether the continuous loop integrates x = [q, v] whole (idle motions, passive joints).")
    .def_prop_ro("projections", &CorePlant::projections)
    .def_prop_ro("largest_projected_gap", &CorePlant::largest_projected_gap,
                 "The largest closure gap a projection brought back [m or rad] (0 before one).")
    .def(
      "closure_gap",
      [](CorePlant & self, const Eigen::VectorXd & q)
      {
        delta_pin::check_size(q, self.nq(), "q");
        return self.closure_gap(q);
      },
      nb::arg("q"), "The largest closure residual at q [m or rad] (NaN where q holds one).")
    .def("end_effector_position", &CorePlant::end_effector_position, nb::arg("q"))
    .def(
      "step",
      [](CorePlant & self, const Eigen::VectorXd & x, const Eigen::VectorXd & tau, double t, double h)
      {
        delta_pin::check_size(x, self.nq() + self.nv(), "x");
        delta_pin::check_size(tau, self.dof(), "tau");
        check_finite(x, "x");
        check_finite(tau, "tau");
        delta_pin::check_positive(h, "h");
        Eigen::VectorXd y = x;
        check_finite(t, "t");
        const double gap = self.step(y, tau, t, h);
        return std::make_tuple(y, gap);
      },
      nb::arg("x"), nb::arg("tau"), nb::arg("t"), nb::arg("h"),
      "One RK4 step of length h [s] from time t [s] under tau, the truth read by time: (x, closure gap).");
  nb::class_<ClosedChainPlant, CorePlant>(m, "ClosedChainPlant")
    .def(
      "__init__",
      [](
        ClosedChainPlant * self, const ChainDescription & chain,
        const std::vector<std::tuple<int, size_t, Eigen::Matrix4d, size_t, Eigen::Matrix4d, int>> & constraints,
        double kp, double kd, double accuracy, double mu, int iterations, double projection_tolerance)
      {
        std::vector<delta_pin::ConstraintSpec> specs;
        for (const auto & [size, j1, p1, j2, p2, reference] : constraints)
          specs.push_back({size, j1, j2, p1, p2, reference});
        new (self) ClosedChainPlant(chain, specs, kp, kd, accuracy, mu, iterations, projection_tolerance);
      },
      nb::arg("chain"), nb::arg("constraints"), nb::arg("baumgarte_kp"), nb::arg("baumgarte_kd"),
      nb::arg("proximal_accuracy"), nb::arg("proximal_mu"), nb::arg("proximal_iterations"),
      nb::arg("projection_tolerance"))
    .def(
      "set_friction",
      [](ClosedChainPlant & self, const delta_pin::FrictionSpec & friction) { self.set_friction(switched_on(friction)); },
      nb::arg("friction"), "The actuated joints' friction (StribeckFriction).")
    .def("set_truth", &ClosedChainPlant::set_truth, nb::arg("joint"), nb::arg("point"), nb::arg("step"),
         nb::arg("body_masses"), nb::arg("point_masses"), nb::arg("normal_forces"), nb::arg("disturbances"),
         "The time-varying truth at t = i step [s]: the joint's body mass [kg] (COM kept, rotational inertia "
         "scaled), a point mass [kg] at `point`, the friction's normal forces [N], the disturbance [N m].")
    .def_prop_rw("integrates_active", &ClosedChainPlant::integrates_active, &ClosedChainPlant::integrate_active,
                 "Whether a sampled step integrates the actuated (alpha, alpha_dot), (q, v) completed at every "
                 "stage (True), or the whole x = [q, v] (False).")
    .def("set_failure_tolerance", &ClosedChainPlant::set_failure_tolerance, nb::arg("tolerance"), nb::arg("unit"),
         "The closure gap [m or rad] above which a step stops the run instead of a projection (inf: none), "
         "`unit` its unit in the message.")
    .def_prop_ro("failure_tolerance", &ClosedChainPlant::failure_tolerance)
    .def_prop_ro("stage", &ClosedChainPlant::stage, "'axis_tree' or 'constraint_dynamics': what gives ddq")
    .def("use_axis_tree", &ClosedChainPlant::use_axis_tree, nb::arg("use"),
         "The axis-tree stage where it applies (True), or Pinocchio's constraintDynamics (False).")
    .def(
      "accelerations",
      [](ClosedChainPlant & self, const Eigen::VectorXd & q, const Eigen::VectorXd & v, const Eigen::VectorXd & tau,
         double row)
      {
        check_finite(q, "q");
        check_finite(v, "v");
        check_finite(tau, "tau");
        check_finite(row, "row");
        return Eigen::VectorXd(self.accelerations(q, v, tau, row));
      },
      nb::arg("q"), nb::arg("v"), nb::arg("tau"), nb::arg("row"),
      "ddq at (q, v) under the actuated torques, the truth at the table's row position `row`.")
    .def(
      "derivative", &checked_derivative<ClosedChainPlant>, nb::arg("x"), nb::arg("tau"), nb::arg("row"),
      "dx/dt of the whole state x = [q, v] (configuration rates, ddq) under the actuated torques, the truth at "
      "the table's row position `row`.");
  nb::class_<AnalyticDeltaPlant, CorePlant>(m, "AnalyticDeltaPlant")
    .def(
      "__init__",
      [](AnalyticDeltaPlant * self, double R, double r, double l_a, double l_b, double arm_inertia, double arm_gravity,
         double g, const Eigen::Vector3d & cos_phi, const Eigen::Vector3d & sin_phi, double arm_mass_share,
         double platform_mass)
      {
        const double constants[] = {R, r, l_a, l_b, arm_inertia, arm_gravity, g, arm_mass_share, platform_mass};
        const char * names[] = {"R", "r", "l_a", "l_b", "arm_inertia", "arm_gravity", "g", "arm_mass_share", "platform_mass"};
        for (int i = 0; i < 9; ++i)
          check_finite(constants[i], names[i]);
        check_finite(cos_phi, "cos_phi");
        check_finite(sin_phi, "sin_phi");
        new (self) AnalyticDeltaPlant(
          delta_geometry(R, r, l_a, l_b, arm_inertia, arm_gravity, g, 0.0, cos_phi, sin_phi), arm_mass_share,
          platform_mass);
      },
      nb::arg("R"), nb::arg("r"), nb::arg("l_a"), nb::arg("l_b"), nb::arg("arm_inertia"), nb::arg("arm_gravity"),
      nb::arg("g"), nb::arg("cos_phi"), nb::arg("sin_phi"), nb::arg("arm_mass_share"), nb::arg("platform_mass"),
      "The paper's reduced Delta (eq. 13; lengths [m], the arm's inertia [kg m^2] and gravity torque [N m], "
      "g [m/s^2], the chain azimuths' cos and sin, 3/2 m_b and the nominal m_o [kg]).")
    .def(
      "set_friction",
      [](AnalyticDeltaPlant & self, const delta_pin::FrictionSpec & friction) { self.set_friction(switched_on(friction)); },
      nb::arg("friction"))
    .def(
      "set_truth",
      [](AnalyticDeltaPlant & self, double step, const Eigen::VectorXd & platform_masses,
         const RowMatrix & normal_forces, const RowMatrix & disturbances)
      { self.set_truth_table(delta_pin::TruthTable{step, platform_masses, Eigen::VectorXd(), normal_forces, disturbances}); },
      nb::arg("step"), nb::arg("platform_masses"), nb::arg("normal_forces"), nb::arg("disturbances"),
      "The time-varying truth at t = i step [s]: m_o [kg], F_n [N], F [N m] (empty: nominal).")
    .def(
      "derivative", &checked_derivative<AnalyticDeltaPlant>, nb::arg("x"), nb::arg("tau"), nb::arg("row"), "dx/dt at x under tau, the truth at the row position `row`.");
}
