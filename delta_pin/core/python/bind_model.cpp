// The closed chain's model in Python (issue 38, item 2: one binding file per part): ChainDescription,
// what the core needs of a robot, and ClosedChainModel, its kinematics and projected dynamics.

#include "binding.hpp"
#include "interrupt.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/function.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

namespace nb = nanobind;
using namespace delta_pin::binding;
using delta_pin::RowMatrix;
using delta_pin::check_finite;

namespace
{
  // rows of states (alpha, alpha_dot, alpha_ddot: one row per state, one column per actuated joint,
  // the three alike; the rates finite) and a configuration to assemble the first from
  void check_states(
    const delta_pin::ClosedChainModel & model, const RowMatrix & alpha, const RowMatrix & alpha_dot,
    const RowMatrix & alpha_ddot, const Eigen::VectorXd & guess, const char * rate = "alpha_dot",
    const char * acceleration = "alpha_ddot")
  {
    const Eigen::Index n = alpha.rows(), dof = model.dof();
    for (const auto & [table, name] : {std::pair{&alpha, "alpha"}, {&alpha_dot, rate}, {&alpha_ddot, acceleration}})
      if (table->rows() != n || table->cols() != dof)
        throw std::invalid_argument(
          std::string(name) + " has shape (" + std::to_string(table->rows()) + ", " + std::to_string(table->cols())
          + "), expected (" + std::to_string(n) + ", " + std::to_string(dof) + ")");
    check_finite(alpha_dot, rate);
    check_finite(alpha_ddot, acceleration);
    if (guess.size() != model.nq())
      throw std::invalid_argument(
        "guess has " + std::to_string(guess.size()) + " entries, expected " + std::to_string(model.nq()));
  }

  // each row of alpha assembled from the one before (from q, which ends as the last configuration),
  // then at_state(i, q) with the GIL released: the first row whose loops do not close, -1 for none
  template<typename AtState>
  long along_states(delta_pin::ClosedChainModel & model, const RowMatrix & alpha, Eigen::VectorXd & q, AtState at_state)
  {
    nb::gil_scoped_release release;
    Eigen::VectorXd closed;
    for (Eigen::Index i = 0; i < alpha.rows(); ++i)
    {
      if (!model.configuration(alpha.row(i).transpose(), q, closed))
        return (long)i;
      q = closed;
      at_state(i, q);
    }
    return -1;
  }
} // namespace

void bind_model(nb::module_ & m)
{
  using delta_pin::ClosedChainModel;
  using delta_pin::ClosedChainPlant;
  using delta_pin::ChainDescription;
  using delta_pin::JointSpec;
  using delta_pin::ModelSpec;
  using delta_pin::JointSprings;
  nb::class_<JointSpec>(m, "JointSpec", "One joint of a ModelSpec (model_spec.hpp), by name.")
    .def(nb::init<>())
    .def_rw("type", &JointSpec::type, "Pinocchio's shortname(), e.g. 'JointModelRX'.")
    .def_rw("axis", &JointSpec::axis, "The unit axis of an unaligned or universal joint.")
    .def_rw("axis2", &JointSpec::axis2, "A universal joint's second unit axis.")
    .def_rw("pitch", &JointSpec::pitch, "A helical joint's pitch [m/rad].")
    .def_rw("parts", &JointSpec::parts, "A composite joint's parts (JointSpec).")
    .def_rw("part_placements", &JointSpec::part_placements, "Their placements, (parts, 12): rotation rows, translation.");
  nb::class_<ModelSpec>(
    m, "ModelSpec",
    "A robot's Pinocchio model as the core rebuilds it (model_spec.hpp): what its algorithms read, by name.")
    .def(nb::init<>())
    .def_rw("joints", &ModelSpec::joints, "Joints 1 .. njoints-1 (JointSpec).")
    .def_rw("joint_names", &ModelSpec::joint_names, "Their names.")
    .def_rw("parents", &ModelSpec::parents, "Each joint's parent joint (0: the universe).")
    .def_rw("placements", &ModelSpec::placements, "Each joint's placement in its parent's, (joints, 12).")
    .def_rw("inertias", &ModelSpec::inertias,
            "(njoints, 13): mass [kg], centre of mass [m], rotational inertia about it by rows [kg m^2].")
    .def_rw("frame_names", &ModelSpec::frame_names, "Frames 1 .. nframes-1: names.")
    .def_rw("frame_joints", &ModelSpec::frame_joints, "Their parent joints.")
    .def_rw("frame_parents", &ModelSpec::frame_parents, "Their parent frames.")
    .def_rw("frame_types", &ModelSpec::frame_types, "Their Pinocchio FrameType values.")
    .def_rw("frame_placements", &ModelSpec::frame_placements, "Their placements in the parent joint's, (frames, 12).")
    .def_rw("gravity", &ModelSpec::gravity, "Gravity as a spatial motion (linear, angular) [m/s^2].")
    .def_rw("armature", &ModelSpec::armature, "Rotor armature per entry of v [kg m^2].");
  nb::class_<JointSprings>(m, "JointSprings", "The robot's joint springs and dampers (closed_chain.hpp).")
    .def(nb::init<>())
    .def_rw("q_index", &JointSprings::q_index, "Each spring's entry of q (1-DOF joints).")
    .def_rw("v_index", &JointSprings::v_index, "Its entry of v.")
    .def_rw("k", &JointSprings::k, "Its stiffness [N m/rad or N/m].")
    .def_rw("ref", &JointSprings::ref, "Its rest position [rad or m].")
    .def_rw("d", &JointSprings::d, "Its damping [N m s/rad or N s/m].")
    .def_rw("damper_v", &JointSprings::damper_v, "The other dampers' entries of v.")
    .def_rw("damper_d", &JointSprings::damper_d, "Their damping.");
  nb::class_<ChainDescription>(m, "ChainDescription", "What the core needs of a closed-chain robot (closed_chain.hpp).")
    .def(
      "__init__",
      [](
        ChainDescription * self, const ModelSpec & model,
        const std::vector<std::tuple<size_t, size_t, int>> & closures,
        const std::vector<std::tuple<int, int, int, int, double, double, Eigen::VectorXd>> & couplings,
        const Eigen::VectorXi & actuated_q, const Eigen::VectorXi & actuated_v, const Eigen::VectorXi & dependent_v,
        int idle_dof, size_t end_effector, const JointSprings & springs)
      {
        std::vector<delta_pin::JointCouplingSpec> specs;
        for (const auto & [q1, v1, q2, v2, reference1, reference2, coefficients] : couplings)
          specs.push_back({q1, v1, q2, v2, reference1, reference2, coefficients});
        new (self) ChainDescription{
          model, frames_of(closures), specs, actuated_q, actuated_v, dependent_v, idle_dof, end_effector, springs};
      },
      nb::arg("model"), nb::arg("closures"), nb::arg("couplings"), nb::arg("actuated_q"), nb::arg("actuated_v"),
      nb::arg("dependent_v"), nb::arg("idle_dof"), nb::arg("end_effector"), nb::arg("springs") = JointSprings(),
      "The robot's Pinocchio model (ModelSpec, closure frames included), its closures (frame 1, frame 2, 3 or 6 "
      "rows), its joint couplings (q1, v1, q2, v2 entries -- -1 without joint 2 --, reference1, reference2, the "
      "polynomial's coefficients), the actuated joints' entries in q and v, the dependent joints' entries in v, "
      "the number of idle motions, the end-effector frame and the joint springs and dampers (JointSprings).")
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
      "inverse_kinematics",
      [](ClosedChainModel & self, const Eigen::Vector3d & target, size_t frame, const Eigen::VectorXi & rows,
         const Eigen::VectorXd & alpha_start, const Eigen::VectorXd & q_start, double tolerance, int iterations)
      {
        check_finite(target, "target");
        check_finite(alpha_start, "alpha");
        check_finite(q_start, "q");
        if (q_start.size() != self.nq())
          throw std::invalid_argument(
            "q has " + std::to_string(q_start.size()) + " entries, expected " + std::to_string(self.nq()));
        if (!(tolerance > 0.0) || iterations < 1)
          throw std::invalid_argument("tolerance must be > 0 and iterations >= 1");
        Eigen::VectorXd alpha = alpha_start, q = q_start;
        const bool reached = self.inverse_kinematics(target, frame, rows, alpha, q, tolerance, iterations);
        return std::make_tuple(reached, alpha, q);
      },
      nb::arg("target"), nb::arg("frame"), nb::arg("rows"), nb::arg("alpha"), nb::arg("q"), nb::arg("tolerance") = 1e-12,
      nb::arg("iterations") = 60,
      "(reached, alpha, q): Newton on alpha putting the frame's origin at target along rows (task coordinates), "
      "each iterate assembled from the previous q; alpha and q where it stopped otherwise.")
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
      "actuated_torques",
      [](ClosedChainModel & self, const RowMatrix & alpha, const RowMatrix & alpha_dot, const RowMatrix & alpha_ddot,
         const Eigen::VectorXd & guess)
      {
        check_states(self, alpha, alpha_dot, alpha_ddot, guess);
        const Eigen::Index n = alpha.rows(), dof = self.dof();
        RowMatrix tau(n, dof);
        Eigen::VectorXd q = guess;
        const long failed = along_states(
          self, alpha, q,
          [&](Eigen::Index i, const Eigen::VectorXd & q_i)
          {
            tau.row(i) =
              self.actuated_torque(q_i, alpha_dot.row(i).transpose(), alpha_ddot.row(i).transpose()).transpose();
          });
        return std::make_tuple(failed, q, tau);
      },
      nb::arg("alpha"), nb::arg("alpha_dot"), nb::arg("alpha_ddot"), nb::arg("guess"),
      "(failed, q, tau): tau = M alpha_ddot + C alpha_dot + G (N, dof) [N m] along rows of states, each "
      "assembled from the one before (from guess), by one RNEA pass each; failed the first row whose loops "
      "do not close (-1: none), q the last configuration.")
    .def(
      "path_coefficients",
      [](ClosedChainModel & self, const RowMatrix & alpha, const RowMatrix & d1, const RowMatrix & d2,
         const Eigen::VectorXd & guess)
      {
        check_states(self, alpha, d1, d2, guess, "d1", "d2");
        const Eigen::Index n = alpha.rows(), dof = self.dof();
        RowMatrix a(n, dof), b(n, dof), c0(n, dof), damping(n, dof);
        Eigen::VectorXd q = guess, a_i, b_i, c0_i, damping_i;
        const long failed = along_states(
          self, alpha, q,
          [&](Eigen::Index i, const Eigen::VectorXd & q_i)
          {
            self.path_coefficients(q_i, d1.row(i).transpose(), d2.row(i).transpose(), a_i, b_i, c0_i, damping_i);
            a.row(i) = a_i.transpose();
            b.row(i) = b_i.transpose();
            c0.row(i) = c0_i.transpose();
            damping.row(i) = damping_i.transpose();
          });
        return std::make_tuple(failed, q, a, b, c0, damping);
      },
      nb::arg("alpha"), nb::arg("d1"), nb::arg("d2"), nb::arg("guess"),
      "(failed, q, a, b, c0, damping): a path's torque coefficients (N, dof) each at rows of alpha with "
      "alpha' = d1 and alpha'' = d2 (ClosedChainModel::path_coefficients), each state assembled from the one "
      "before (from guess); failed the first row whose loops do not close (-1: none).")
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
}
