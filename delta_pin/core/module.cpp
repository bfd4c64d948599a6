// delta_pin.compiled._core: the Python face of delta-pin's compiled core (nanobind).
//
// The plants (plant.hpp) -- ClosedChainPlant (closed_chain.hpp), the constrained plant of any
// fully actuated closed-chain robot, and AnalyticDeltaPlant (analytic_plant.hpp), the paper's
// reduced Delta -- share the sampled loop, which runs a compiled law or calls back into Python
// once per sample for the torque (delta_pin/sim/compiled_plant.py builds them).
//
// Nothing here is compiled at run time: scikit-build-core builds this module when the package
// is installed (CMakeLists.txt).

#include "analytic_plant.hpp"
#include "checks.hpp"
#include "closed_chain.hpp"
#include "controller.hpp"
#include "failure.hpp"
#include "interrupt.hpp"
#include "law_registry.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/function.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>



namespace nb = nanobind;

namespace
{
  // the gains of the two laws whose C++ constructors take their vectors one by one
  struct ComputedTorqueGains
  {
    Eigen::VectorXd D, T_p, T_v;  // [1/s], [N m/rad], [N m s/rad]
  };
  struct PDGravityGains
  {
    Eigen::VectorXd K_p, K_d;  // [N m/rad], [N m s/rad]
  };

  // the interrupt hook (interrupt.hpp): runs Python's signal handlers, in the main thread only
  // (elsewhere PyErr_CheckSignals does nothing); true when one of them raised
  bool python_signal_pending()
  {
    nb::gil_scoped_acquire acquire;
    return PyErr_CheckSignals() != 0;
  }

  using delta_pin::RowMatrix;
  using delta_pin::check_finite;
  typedef nb::ndarray<double, nb::ndim<2>, nb::c_contig, nb::device::cpu> Table;
  typedef nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu> Column;

  Eigen::Map<RowMatrix> rows(Table & table)
  {
    return Eigen::Map<RowMatrix>(table.data(), (Eigen::Index)table.shape(0), (Eigen::Index)table.shape(1));
  }

  // eq. 12's Stribeck friction as Python gives it (StribeckFriction, by name), switched on
  delta_pin::FrictionSpec switched_on(delta_pin::FrictionSpec friction)
  {
    friction.enabled = true;
    return friction;
  }

  // the Delta's constants (lengths [m], the arm's inertia [kg m^2] and gravity torque [N m], g
  // [m/s^2], m_eq [kg]) and its chain azimuths (cos, sin: 3 each)
  delta_pin::DeltaGeometry delta_geometry(
    double R, double r, double l_a, double l_b, double arm_inertia, double arm_gravity, double g, double m_eq,
    const Eigen::Vector3d & cos_phi, const Eigen::Vector3d & sin_phi)
  {
    delta_pin::DeltaGeometry geometry;
    for (int i = 0; i < 3; ++i)
    {
      geometry.cos_phi[i] = cos_phi[i];
      geometry.sin_phi[i] = sin_phi[i];
    }
    geometry.R = R;
    geometry.r = r;
    geometry.l_a = l_a;
    geometry.l_b = l_b;
    geometry.arm_inertia = arm_inertia;
    geometry.arm_gravity = arm_gravity;
    geometry.g = g;
    geometry.m_eq = m_eq;
    return geometry;
  }

  std::vector<delta_pin::ClosureFrames> frames_of(const std::vector<std::tuple<size_t, size_t, int>> & closures)
  {
    std::vector<delta_pin::ClosureFrames> frames;
    for (const auto & [f1, f2, size] : closures)
      frames.push_back({f1, f2, size});
    return frames;
  }

} // namespace

void bind_continuous(nb::module_ & m);  // continuous_binding.cpp
void bind_python_plant(nb::module_ & m);  // python_plant.cpp

NB_MODULE(_core, m)
{
  m.doc() = "delta-pin's compiled core (see delta_pin/compiled/core.py)";
  m.attr("pinocchio_version") = DELTA_PIN_PINOCCHIO_VERSION;
  using delta_pin::ClosedChainModel;
  using delta_pin::ClosedChainPlant;
  using delta_pin::ChainDescription;
  nb::class_<ChainDescription>(m, "ChainDescription", "What the core needs of a closed-chain robot (closed_chain.hpp).")
    .def(
      "__init__",
      [](
        ChainDescription * self, const std::string & model_text,
        const std::vector<std::tuple<size_t, size_t, int>> & closures,
        const std::vector<std::tuple<int, int, int, int, double, double, Eigen::VectorXd>> & couplings,
        const Eigen::VectorXi & actuated_q, const Eigen::VectorXi & actuated_v, const Eigen::VectorXi & dependent_v,
        int idle_dof, size_t end_effector)
      {
        std::vector<delta_pin::JointCouplingSpec> specs;
        for (const auto & [q1, v1, q2, v2, reference1, reference2, coefficients] : couplings)
          specs.push_back({q1, v1, q2, v2, reference1, reference2, coefficients});
        new (self) ChainDescription{
          model_text, frames_of(closures), specs, actuated_q, actuated_v, dependent_v, idle_dof, end_effector};
      },
      nb::arg("model_text"), nb::arg("closures"), nb::arg("couplings"), nb::arg("actuated_q"), nb::arg("actuated_v"),
      nb::arg("dependent_v"), nb::arg("idle_dof"), nb::arg("end_effector"),
      "The robot's Pinocchio model as text (closure frames included), its closures (frame 1, frame 2, 3 or 6 "
      "rows), its joint couplings (q1, v1, q2, v2 entries -- -1 without joint 2 --, reference1, reference2, the "
      "polynomial's coefficients), the actuated joints' entries in q and v, the dependent joints' entries in v, "
      "the number of idle motions and the end-effector frame.")
    .def_ro("idle_dof", &ChainDescription::idle_dof)
    .def_ro("end_effector", &ChainDescription::end_effector);
  nb::class_<ClosedChainModel>(m, "ClosedChainModel")
    .def(nb::init<const ChainDescription &>(), nb::arg("chain"))
    .def_prop_ro("dof", &ClosedChainModel::dof)
    .def_prop_ro("unactuated", &ClosedChainModel::unactuated,
                 "Whether the robot moves in ways the actuated joints do not determine (idle motions, passive joints).")
    .def("closure_gap", &ClosedChainModel::closure_gap)
    .def(
      "configuration",
      [](ClosedChainModel & self, const Eigen::VectorXd & alpha, const Eigen::VectorXd & guess, double tolerance,
         int iterations)
      {
        Eigen::VectorXd q;
        const bool closed = self.configuration(alpha, guess, q, tolerance, iterations);
        return std::make_tuple(closed, q);
      },
      nb::arg("alpha"), nb::arg("guess"), nb::arg("tolerance") = 1e-12, nb::arg("iterations") = 60,
      "(closed, q): Newton on the closures from guess with the actuated joints at alpha.")
    .def(
      "velocity_map",
      [](ClosedChainModel & self, const Eigen::VectorXd & q)
      {
        check_finite(q, "q");
        return self.velocity_map(q);
      },
      nb::arg("q"), "S = dq/dalpha (nv, dof) at a closed q.")
    .def(
      "project_state",
      [](ClosedChainModel & self, const Eigen::VectorXd & q, const Eigen::VectorXd & v)
      {
        check_finite(v, "v");  // a non-finite q: Newton does not close (closed False)
        Eigen::VectorXd q_out = q, v_out = v;
        const bool closed = self.project_state(q_out, v_out);
        return std::make_tuple(closed, q_out, v_out);
      },
      nb::arg("q"), nb::arg("v"),
      "(closed, q, v): the nearest closure-consistent state keeping the actuated and passive joints and the idle "
      "motions (ClosedChainRobot.project_state).")
    .def(
      "reduced_terms",
      [](ClosedChainModel & self, const Eigen::VectorXd & q, const Eigen::VectorXd & alpha_dot)
      {
        check_finite(q, "q");
        check_finite(alpha_dot, "alpha_dot");
        Eigen::MatrixXd M, C;
        Eigen::VectorXd G, C_alpha_dot;
        self.reduced_terms(q, alpha_dot, M, C, G, C_alpha_dot);
        return std::make_tuple(M, C, G, C_alpha_dot);
      },
      nb::arg("q"), nb::arg("alpha_dot"), "(M, C, G, C alpha_dot) on the actuated joints by projection at a closed q.")
    .def(
      "end_effector_position",
      [](ClosedChainModel & self, const Eigen::VectorXd & q)
      {
        check_finite(q, "q");
        return self.end_effector_position(q);
      },
      nb::arg("q"))
    .def(
      "end_effector_positions",
      [](ClosedChainModel & self, const RowMatrix & alpha, const Eigen::VectorXd & guess)
      {
        // rows assembled in turn, each warm-started from the one before, up to the first that
        // does not close (its index, or -1)
        delta_pin::check_shape(alpha, -1, self.dof(), "alpha");  // one column per actuated joint
        delta_pin::check_size(guess, self.nq(), "guess");
        RowMatrix xyz = RowMatrix::Zero(alpha.rows(), 3);
        Eigen::VectorXd q = guess, next;
        long failed = -1;
        {
          nb::gil_scoped_release release;
          for (Eigen::Index k = 0; k < alpha.rows(); ++k)
          {
            delta_pin::poll_interrupt();
            if (!self.configuration(alpha.row(k).transpose(), q, next))
            {
              failed = (long)k;
              break;
            }
            q = next;
            xyz.row(k) = self.end_effector_position(q).transpose();
          }
        }
        return std::make_tuple(failed, q, xyz);
      },
      nb::arg("alpha"), nb::arg("guess"),
      "(first row that does not close or -1, the last closed q, end-effector positions (N, 3)) along the "
      "rows of alpha (N, dof), each assembled from the one before.")
    .def(
      "frame_jacobian",
      [](ClosedChainModel & self, const Eigen::VectorXd & q, size_t frame)
      {
        check_finite(q, "q");
        return self.frame_jacobian(q, frame);
      },
      nb::arg("q"), nb::arg("frame"), "The closed-loop Jacobian (6, dof) of a frame, J_frame S (LOCAL_WORLD_ALIGNED).")
    .def(
      "frame_acceleration_drift",
      [](ClosedChainModel & self, const Eigen::VectorXd & q, const Eigen::VectorXd & alpha_dot, size_t frame)
      {
        check_finite(q, "q");
        check_finite(alpha_dot, "alpha_dot");
        return self.frame_acceleration_drift(q, alpha_dot, frame);
      },
      nb::arg("q"), nb::arg("alpha_dot"), nb::arg("frame"),
      "The frame's classical linear acceleration at zero actuated acceleration [m/s^2].")
    .def(
      "joint_reference",
      [](ClosedChainModel & self, size_t frame, const Eigen::VectorXi & rows, const Eigen::VectorXd & times,
         const RowMatrix & xyz, const RowMatrix & xyz_dot, const RowMatrix & xyz_ddot, const Eigen::VectorXd & alpha0,
         const Eigen::VectorXd & q_start)
      {
        Eigen::VectorXd q = q_start;
        RowMatrix alpha, alpha_dot, alpha_ddot, actual;
        const long failed =
          self.joint_reference(frame, rows, times, xyz, xyz_dot, xyz_ddot, alpha0, q, alpha, alpha_dot, alpha_ddot, actual);
        return std::make_tuple(failed, q, alpha, alpha_dot, alpha_ddot, actual);
      },
      nb::arg("frame"), nb::arg("rows"), nb::arg("times"), nb::arg("xyz"), nb::arg("xyz_dot"), nb::arg("xyz_ddot"),
      nb::arg("alpha0"), nb::arg("q_start"),
      "(failed sample or -1, last q, alpha, alpha_dot, alpha_ddot, reached xyz) of a frame's path.");

  nb::exception<delta_pin::SimulationFailure>(m, "SimulationFailure", PyExc_RuntimeError);
  // Ctrl-C within the loops (interrupt.hpp): Python's signal handlers run at the poll, and the
  // exception they raise (KeyboardInterrupt, or the CLI's) is what the interrupted call raises
  delta_pin::interrupt_hook() = &python_signal_pending;
  nb::register_exception_translator(
    [](const std::exception_ptr & error, void *)
    {
      try
      {
        std::rethrow_exception(error);
      }
      catch (const delta_pin::Interrupted &)
      {
        if (!PyErr_Occurred())  // a handler that asked to stop without raising
          PyErr_SetNone(PyExc_KeyboardInterrupt);
      }
    });
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
  nb::class_<delta_pin::DriveSettings>(
    m, "DriveSettings", "The encoder (resolution [rad], noise per sample [rad], exact velocity) and the drive "
    "(delay [samples], torque limit [N m] per actuated joint, or empty) between a plant and a law.")
    .def(nb::init<>())
    .def_rw("sensor", &delta_pin::DriveSettings::sensor)
    .def_rw("resolution", &delta_pin::DriveSettings::resolution)
    .def_rw("noise", &delta_pin::DriveSettings::noise)
    .def_rw("exact_velocity", &delta_pin::DriveSettings::exact_velocity)
    .def_rw("drive", &delta_pin::DriveSettings::drive)
    .def_rw("delay", &delta_pin::DriveSettings::delay)
    .def_rw("torque_limit", &delta_pin::DriveSettings::torque_limit);
  bind_continuous(m);
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
    .def_prop_ro("failure_time", &CorePlant::failure_time)
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
      [](CorePlant & self, const Eigen::VectorXd & x, const Eigen::VectorXd & tau, long stage, double h)
      {
        delta_pin::check_size(x, self.nq() + self.nv(), "x");
        delta_pin::check_size(tau, self.dof(), "tau");
        check_finite(x, "x");
        check_finite(tau, "tau");
        delta_pin::check_positive(h, "h");
        Eigen::VectorXd y = x;
        const double gap = self.step(y, tau, stage, h);
        return std::make_tuple(y, gap);
      },
      nb::arg("x"), nb::arg("tau"), nb::arg("stage"), nb::arg("h"),
      "One RK4 step of length h [s] under tau from the truth's row `stage`: (x, closure gap).")
    .def(
      "run_sampled",
      [](CorePlant & self, const Eigen::VectorXd & x, long steps, int substeps, double dt,
         delta_pin::ProjectedLaw & controller, Table q, Table v, Table xyz, Column gap)
      {
        Eigen::Map<Eigen::VectorXd> gaps(gap.data(), (Eigen::Index)gap.shape(0));
        nb::gil_scoped_release release;  // nothing in the loop touches Python
        return self.run_sampled(x, steps, substeps, dt, controller, rows(q), rows(v), rows(xyz), gaps);
      },
      nb::arg("x"), nb::arg("steps"), nb::arg("substeps"), nb::arg("dt"), nb::arg("controller"),
      nb::arg("q").noconvert(), nb::arg("v").noconvert(), nb::arg("xyz").noconvert(), nb::arg("gap").noconvert(),
      "The sampled loop with a compiled law (its records stay in the controller).")
    .def(
      "run_sampled",
      [](CorePlant & self, const Eigen::VectorXd & x, long steps, int substeps, double dt,
         const std::function<Eigen::VectorXd(long, const Eigen::VectorXd &)> & control, Table q, Table v, Table xyz,
         Column gap)
      {
        Eigen::Map<Eigen::VectorXd> gaps(gap.data(), (Eigen::Index)gap.shape(0));
        delta_pin::FunctionController controller(control);
        return self.run_sampled(x, steps, substeps, dt, controller, rows(q), rows(v), rows(xyz), gaps);
      },
      nb::arg("x"), nb::arg("steps"), nb::arg("substeps"), nb::arg("dt"), nb::arg("control"), nb::arg("q").noconvert(),
      nb::arg("v").noconvert(), nb::arg("xyz").noconvert(), nb::arg("gap").noconvert(),
      "The sampled loop with a Python law: control(k, x) -> the torque held over sample k.");
  bind_python_plant(m);
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
    .def("set_springs", &ClosedChainPlant::set_springs)
    .def(
      "set_friction",
      [](ClosedChainPlant & self, const delta_pin::FrictionSpec & friction) { self.set_friction(switched_on(friction)); },
      nb::arg("friction"), "The actuated joints' friction (StribeckFriction).")
    .def("set_truth", &ClosedChainPlant::set_truth, nb::arg("joint"), nb::arg("point"), nb::arg("step"),
         nb::arg("body_masses"), nb::arg("point_masses"), nb::arg("normal_forces"), nb::arg("disturbances"),
         "The time-varying truth at t = i step [s]: the joint's body mass [kg] (COM kept, rotational inertia "
         "scaled), a point mass [kg] at `point`, the friction's normal forces [N], the disturbance [N m].")
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
      "ddq at (q, v) under the actuated torques, the truth at the table's row position `row`.");
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
      "derivative",
      [](AnalyticDeltaPlant & self, const Eigen::VectorXd & x, const Eigen::VectorXd & tau, double row)
      {
        delta_pin::check_size(x, 6, "x");  // [alpha, alpha_dot]
        delta_pin::check_size(tau, 3, "tau");
        check_finite(x, "x");
        check_finite(tau, "tau");
        check_finite(row, "row");
        Eigen::VectorXd dx;
        self.derivative(x, tau, row, dx);
        return dx;
      },
      nb::arg("x"), nb::arg("tau"), nb::arg("row"), "dx/dt at x under tau, the truth at the row position `row`.");
  nb::class_<delta_pin::ProjectedLaw>(m, "ProjectedLaw")
    .def(
      "set_friction",
      [](delta_pin::ProjectedLaw & self, const delta_pin::FrictionSpec & friction) { self.set_friction(switched_on(friction)); },
      nb::arg("friction"),
      "The nominal friction the law compensates (eq. 12).")
    .def(
      "use_delta_model",
      [](delta_pin::ProjectedLaw & self, double R, double r, double l_a, double l_b, double arm_inertia,
         double arm_gravity, double g, double m_eq, const Eigen::Vector3d & cos_phi, const Eigen::Vector3d & sin_phi)
      { self.use_delta_model(delta_geometry(R, r, l_a, l_b, arm_inertia, arm_gravity, g, m_eq, cos_phi, sin_phi)); },
      nb::arg("R"), nb::arg("r"), nb::arg("l_a"), nb::arg("l_b"), nb::arg("arm_inertia"), nb::arg("arm_gravity"),
      nb::arg("g"), nb::arg("m_eq"), nb::arg("cos_phi"), nb::arg("sin_phi"),
      "The Delta's analytic M, C, G (eqs. 7-10; lengths [m], the arm's inertia [kg m^2] and gravity torque "
      "[N m], g [m/s^2], m_eq [kg], the chain azimuths' cos and sin) as the nominal model instead of the projection (DeltaNominalModel).")
    .def("start", &delta_pin::ProjectedLaw::start,
         "The reference table, the period [s], the initial state, the samples to record, the speed limit.")
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
        self.evaluate(alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, state, tau, state_dot);
        return std::make_tuple(tau, state_dot);
      },
      nb::arg("alpha"), nb::arg("alpha_dot"), nb::arg("ref_alpha"), nb::arg("ref_alpha_dot"), nb::arg("ref_alpha_ddot"),
      nb::arg("state"), "(tau, the state's derivative) at one state.")
    .def("set_drive", &delta_pin::ProjectedLaw::set_drive, nb::arg("settings"),
         "The encoder and the drive between the plant and the law (DriveSettings), before start().")
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
    .def_ro("tau", &delta_pin::ProjectedLaw::tau)
    .def_ro("tau_command", &delta_pin::ProjectedLaw::tau_command)
    .def_ro("hits", &delta_pin::ProjectedLaw::hits)
    .def_ro("state", &delta_pin::ProjectedLaw::state);
  for (const delta_pin::LawBinder bind_law : delta_pin::law_binders())  // core/laws/*.cpp
    bind_law(m);
  // gains cross the binding by name (issue 38, item 3): one struct per law, each field bound, and
  // each law's constructor takes (chain, reference_configuration, disturbance, name, gains)
  nb::class_<ComputedTorqueGains>(m, "ComputedTorqueGains", "Computed torque's gains by name (SI units).")
    .def(nb::init<>())
    .def_rw("D", &ComputedTorqueGains::D)
    .def_rw("T_p", &ComputedTorqueGains::T_p)
    .def_rw("T_v", &ComputedTorqueGains::T_v);
  nb::class_<delta_pin::ComputedTorqueLaw, delta_pin::ProjectedLaw>(m, "ComputedTorque")
    .def(
      "__init__",
      [](delta_pin::ComputedTorqueLaw * self, const ChainDescription & chain, const Eigen::VectorXd & reference_configuration,
         const Eigen::VectorXd & disturbance, const std::string & name, const ComputedTorqueGains & g)
      { new (self) delta_pin::ComputedTorqueLaw(chain, reference_configuration, disturbance, name, g.D, g.T_p, g.T_v); },
      nb::arg("chain"), nb::arg("reference_configuration"), nb::arg("disturbance"), nb::arg("name"),
      nb::arg("gains"));
  nb::class_<PDGravityGains>(m, "PDGravityGains", "PD + gravity's gains by name (SI units).")
    .def(nb::init<>())
    .def_rw("K_p", &PDGravityGains::K_p)
    .def_rw("K_d", &PDGravityGains::K_d);
  nb::class_<delta_pin::PDGravityLaw, delta_pin::ProjectedLaw>(m, "PDGravity")
    .def(
      "__init__",
      [](delta_pin::PDGravityLaw * self, const ChainDescription & chain, const Eigen::VectorXd & reference_configuration,
         const Eigen::VectorXd & disturbance, const std::string & name, const PDGravityGains & g)
      { new (self) delta_pin::PDGravityLaw(chain, reference_configuration, disturbance, name, g.K_p, g.K_d); },
      nb::arg("chain"), nb::arg("reference_configuration"), nb::arg("disturbance"), nb::arg("name"),
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
      [](delta_pin::AdaptiveRobust * self, const ChainDescription & chain, const Eigen::VectorXd & reference_configuration,
         const Eigen::VectorXd & disturbance, const std::string & name, const AdaptiveRobustGains & gains)
      { new (self) delta_pin::AdaptiveRobust(chain, reference_configuration, disturbance, name, gains); },
      nb::arg("chain"), nb::arg("reference_configuration"), nb::arg("disturbance"), nb::arg("name"),
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
      [](delta_pin::TimeDelayControlLaw * self, const ChainDescription & chain, const Eigen::VectorXd & reference_configuration,
         const Eigen::VectorXd & disturbance, const std::string & name, const delta_pin::TimeDelayGains & g)
      { new (self) delta_pin::TimeDelayControlLaw(chain, reference_configuration, disturbance, name, g); },
      nb::arg("chain"), nb::arg("reference_configuration"), nb::arg("disturbance"), nb::arg("name"),
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
      [](delta_pin::DigitalRobustLaw * self, const ChainDescription & chain, const Eigen::VectorXd & reference_configuration,
         const Eigen::VectorXd & disturbance, const std::string & name, const DigitalRobustGains & gains)
      {
        const Eigen::Index size = gains.transition.rows();
        if (size < 3 || size > delta_pin::observer_max || gains.transition.cols() != size)
          throw std::invalid_argument(
            "transition has shape " + delta_pin::shape_text(gains.transition.rows(), gains.transition.cols())
            + ", expected the observer's Phi (S, S) with 3 <= S <= " + std::to_string(delta_pin::observer_max));
        DigitalRobustGains g = gains;
        g.has_limit = g.torque_limit.size() > 0;  // empty: no limit
        new (self) delta_pin::DigitalRobustLaw(chain, reference_configuration, disturbance, name, g);
      },
      nb::arg("chain"), nb::arg("reference_configuration"), nb::arg("disturbance"), nb::arg("name"),
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
    [](delta_pin::LqrLaw * self, const ChainDescription & chain, const Eigen::VectorXd & reference_configuration,
       const Eigen::VectorXd & disturbance, const std::string & name, const LqrGains & g)
    { new (self) delta_pin::LqrLaw(chain, reference_configuration, disturbance, name, g); },
    nb::arg("chain"), nb::arg("reference_configuration"), nb::arg("disturbance"), nb::arg("name"),
    nb::arg("gains"));
}
