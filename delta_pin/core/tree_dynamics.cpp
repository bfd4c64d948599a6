// Constrained dynamics of a delta-pin tree, callable from compiled (numba) loops through a C ABI.
//
// The Python side (delta_pin/native/__init__.py) builds this file on first use against the headers
// and libraries of the installed `pin` wheel and hands it the very numbers of the Python
// PinocchioPlant: the kinematic tree (parents, 1-DOF joint types, placements, inertias, gravity)
// and the point closures (joints, anchor placements, Baumgarte gains). `dpn_dynamics` then calls
// the same explicitly instantiated pinocchio::constraintDynamics (in libpinocchio_default) that
// pin.constraintDynamics calls from Python, with the same proximal settings (mu = 0, one
// iteration: the exact KKT solve), so both give the same accelerations; without the ~3 us of
// Python binding per call.
//
// Only 1-DOF joints along the frame axes (RX, RY, RZ, PX, PY, PZ) are accepted: delta-pin's
// models are made of those (nq == nv).
//
// `dpn_dynamics_axis` gives the same accelerations from delta-pin's own recursive algorithms for
// trees of axis joints (axis_tree.hpp, built from the same numbers): equal to constraintDynamics to
// ~1e-13 relative at ~40 % of its cost; the compiled sampled loops call it by default
// (delta_pin.sim.batch.NATIVE_STAGE), constraintDynamics where the Python loop's arithmetic is
// wanted bit for bit.
//
// `dpn_active_dynamics` is the same plant in active coordinates (PinocchioPlant with
// coordinates="active"): q(alpha) completed by Newton on the passive coordinates from a
// first-order predictor off the previous completion, v = S alpha_dot with S = dq/dalpha from the
// closure Jacobian, then alpha_ddot from the recursive algorithms of dpn_dynamics_axis -- the loops
// closed to the tolerance at every evaluation, for implicit integrators on the small state
// [alpha, alpha_dot].

#include <pinocchio/algorithm/constrained-dynamics.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/multibody.hpp>

#include "axis_tree.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <vector>

namespace
{
  using namespace pinocchio;
  // std::allocator: the vectors of the explicit instantiation that the Python binding calls
  typedef std::vector<RigidConstraintModel> ConstraintModels;
  typedef std::vector<RigidConstraintData> ConstraintDatas;
  typedef Eigen::Matrix<double, 3, 3, Eigen::RowMajor> RowMatrix3;

  struct Tree
  {
    Model model;
    Data data;
    ConstraintModels constraint_models;
    ConstraintDatas constraint_datas;
    ProximalSettings settings{1e-12, 0.0, 1};
    Eigen::VectorXd q, v, tau;
    JointIndex platform_joint = 0;
    double platform_mass = 0.0;
    // active coordinates (dpn_set_active): indices, completion state and scratch
    std::vector<int> active, passive, platform;
    double tolerance = 1e-13;
    int max_iterations = 30;
    Eigen::VectorXd last_q;
    Eigen::MatrixXd last_S, jacobian, joint_jacobian, passive_jacobian, active_jacobian, passive_rates;
    Eigen::VectorXd residual, correction;
    Eigen::PartialPivLU<Eigen::MatrixXd> lu;
    // the same tree in delta-pin's own recursive algorithms (dpn_dynamics_axis), and its ddq
    std::unique_ptr<dpn::AxisTree> axis;
    Eigen::VectorXd ddq;
  };

  // A placement from 12 numbers: the rotation row by row, then the translation.
  SE3 placement_from(const double * numbers)
  {
    return SE3(Eigen::Map<const RowMatrix3>(numbers), Eigen::Map<const Eigen::Vector3d>(numbers + 9));
  }

  JointModel joint_from(int type)
  {
    switch (type)
    {
    case 0:
      return JointModelRX();
    case 1:
      return JointModelRY();
    case 2:
      return JointModelRZ();
    case 3:
      return JointModelPX();
    case 4:
      return JointModelPY();
    case 5:
      return JointModelPZ();
    }
    throw std::invalid_argument("joint type code " + std::to_string(type) + " is not in 0..5");
  }

  Eigen::Matrix3d skew(const Eigen::Vector3d & a)
  {
    Eigen::Matrix3d m;
    m << 0.0, -a[2], a[1], a[2], 0.0, -a[0], -a[1], a[0], 0.0;
    return m;
  }

  // Stacked world-frame closure gaps p_anchor1 - p_anchor2 at tree->q into tree->residual, and
  // with `with_jacobian` their Jacobian d(gap)/dq (3 n_closures x nv) into tree->jacobian.
  void closure_residual(Tree * tree, bool with_jacobian)
  {
    Model & model = tree->model;
    Data & data = tree->data;
    tree->residual.setZero();
    if (with_jacobian)
    {
      computeJointJacobians(model, data, tree->q);
      tree->jacobian.setZero();
    }
    else
      forwardKinematics(model, data, tree->q);
    for (size_t c = 0; c < tree->constraint_models.size(); ++c)
    {
      const RigidConstraintModel & constraint = tree->constraint_models[c];
      const JointIndex joints[2] = {constraint.joint1_id, constraint.joint2_id};
      const SE3 * anchors[2] = {&constraint.joint1_placement, &constraint.joint2_placement};
      for (int side = 0; side < 2; ++side)
      {
        const SE3 & oMi = data.oMi[joints[side]];
        const Eigen::Vector3d point = oMi.act(anchors[side]->translation());
        const double sign = side == 0 ? 1.0 : -1.0;
        tree->residual.segment<3>(3 * (Eigen::Index)c) += sign * point;
        if (with_jacobian && joints[side] > 0)
        {
          tree->joint_jacobian.setZero();
          getJointJacobian(model, data, joints[side], LOCAL_WORLD_ALIGNED, tree->joint_jacobian);
          // velocity of a point of the joint's body: v_o + omega x (p - o)
          tree->jacobian.middleRows<3>(3 * (Eigen::Index)c) +=
            sign
            * (tree->joint_jacobian.topRows<3>()
               - skew(point - oMi.translation()) * tree->joint_jacobian.bottomRows<3>());
        }
      }
    }
  }

  // ddq of the tree at (tree->q, tree->v) under tree->tau, the platform inertia set for `mass`
  // first (as PinocchioPlant._set_platform_mass: only when the mass changes).
  const Eigen::VectorXd & solve_tree(Tree * tree, double mass, const double * rotational)
  {
    if (mass != tree->platform_mass)
    {
      Inertia & inertia = tree->model.inertias[tree->platform_joint];
      inertia = Inertia(
        mass, inertia.lever(), Symmetric3(Eigen::Matrix3d(Eigen::Map<const RowMatrix3>(rotational))));
      tree->platform_mass = mass;
    }
    return constraintDynamics(
      tree->model, tree->data, tree->q, tree->v, tree->tau, tree->constraint_models,
      tree->constraint_datas, tree->settings);
  }

  double largest(const Eigen::VectorXd & values)
  {
    double result = 0.0;
    for (Eigen::Index i = 0; i < values.size(); ++i)
    {
      if (std::isnan(values[i]))
        return std::nan("");
      result = std::max(result, std::abs(values[i]));
    }
    return result;
  }

  void report(const std::exception & error, char * message, int size)
  {
    if (message != nullptr && size > 0)
    {
      std::strncpy(message, error.what(), (size_t)size - 1);
      message[size - 1] = '\0';
    }
  }
} // namespace

extern "C" {

// Build a tree. joints: number of joints after the universe; per joint: parent index, type code
// (0..5 = RX, RY, RZ, PX, PY, PZ), placement in its parent (12 numbers) and body inertia (13
// numbers: mass, COM in the joint frame (3), rotational inertia about the COM row by row (9)).
// closures: per closure the two joints and the anchor placements in their frames (12 numbers
// each), as a CONTACT_3D constraint in LOCAL frame with Baumgarte gains (kp, kd).
// Returns an opaque handle, or null with the reason in `message`.
void * dpn_create(
  int joints,
  const int * parents,
  const int * types,
  const double * placements,
  const double * inertias,
  const double * gravity,
  int closures,
  const int * closure_joints,
  const double * anchors,
  double kp,
  double kd,
  int platform_joint,
  char * message,
  int message_size)
{
  try
  {
    Tree * tree = new Tree();
    Model & model = tree->model;
    for (int i = 0; i < joints; ++i)
    {
      const double * inertia = inertias + 13 * i;
      const JointIndex id = model.addJoint(
        (JointIndex)parents[i], joint_from(types[i]), placement_from(placements + 12 * i),
        "joint_" + std::to_string(i + 1));
      model.appendBodyToJoint(
        id,
        Inertia(
          inertia[0], Eigen::Map<const Eigen::Vector3d>(inertia + 1),
          Symmetric3(Eigen::Matrix3d(Eigen::Map<const RowMatrix3>(inertia + 4)))),
        SE3::Identity());
    }
    model.gravity.linear(Eigen::Map<const Eigen::Vector3d>(gravity));
    for (int c = 0; c < closures; ++c)
    {
      RigidConstraintModel constraint(
        CONTACT_3D, model, (JointIndex)closure_joints[2 * c], placement_from(anchors + 24 * c),
        (JointIndex)closure_joints[2 * c + 1], placement_from(anchors + 24 * c + 12), LOCAL);
      constraint.setBaumgarteCorrectorParameters(RigidConstraintModel::BaumgarteCorrectorParameters(kp, kd));
      tree->constraint_models.push_back(constraint);
      tree->constraint_datas.push_back(RigidConstraintData(constraint));
    }
    tree->data = Data(model);
    initConstraintDynamics(model, tree->data, tree->constraint_models, tree->constraint_datas);
    tree->q = Eigen::VectorXd::Zero(model.nq);
    tree->v = Eigen::VectorXd::Zero(model.nv);
    tree->tau = Eigen::VectorXd::Zero(model.nv);
    tree->residual = Eigen::VectorXd::Zero(3 * closures);
    tree->axis.reset(new dpn::AxisTree(
      joints, parents, types, placements, inertias, gravity, closures, closure_joints, anchors, kp, kd,
      platform_joint));
    tree->platform_joint = (JointIndex)platform_joint;
    tree->platform_mass = model.inertias[tree->platform_joint].mass();
    return tree;
  }
  catch (const std::exception & error)
  {
    report(error, message, message_size);
    return nullptr;
  }
}

void dpn_destroy(void * handle)
{
  delete static_cast<Tree *>(handle);
}

int dpn_nv(void * handle)
{
  return static_cast<Tree *>(handle)->model.nv;
}

// ddq of the constrained tree at (q, v) under joint torques tau (all nv) with the platform body's
// mass set to `mass` [kg] and its rotational inertia about the COM to `rotational` (9 numbers, row
// by row) -- rewritten only when the mass changes, as PinocchioPlant._set_platform_mass does.
// Returns 0, or 1 where Pinocchio throws.
int dpn_dynamics(
  void * handle, const double * q, const double * v, const double * tau, double mass,
  const double * rotational, double * ddq)
{
  Tree * tree = static_cast<Tree *>(handle);
  const Eigen::Index n = tree->model.nv;
  try
  {
    tree->q = Eigen::Map<const Eigen::VectorXd>(q, n);
    tree->v = Eigen::Map<const Eigen::VectorXd>(v, n);
    tree->tau = Eigen::Map<const Eigen::VectorXd>(tau, n);
    Eigen::Map<Eigen::VectorXd>(ddq, n) = solve_tree(tree, mass, rotational);
    return 0;
  }
  catch (const std::exception &)
  {
    return 1;
  }
}

// The same ddq as dpn_dynamics from delta-pin's own recursive algorithms for trees of axis joints
// (axis_tree.hpp), equal to constraintDynamics' up to rounding (~1e-13 relative) at ~40 % of its
// cost. Returns 0, or 1 where M or the Delassus matrix J_c M^-1 J_c^T is not positive definite
// (a massless mechanism, dependent closures).
int dpn_dynamics_axis(
  void * handle, const double * q, const double * v, const double * tau, double mass,
  const double * rotational, double * ddq)
{
  Tree * tree = static_cast<Tree *>(handle);
  return tree->axis->dynamics(q, v, tau, mass, rotational, ddq) ? 0 : 1;
}

// Active coordinates: the indices of alpha in q (3), of the platform slides (3), the completion
// tolerance [m] and iteration limit; then start the completions from the closed configuration q0.
// Returns 0, or 1 where q0 does not close the loops to the tolerance.
int dpn_set_active(
  void * handle, const int * active, const int * platform, double tolerance, int max_iterations,
  const double * q0)
{
  Tree * tree = static_cast<Tree *>(handle);
  const int nv = tree->model.nv;
  tree->active.assign(active, active + 3);
  tree->platform.assign(platform, platform + 3);
  tree->passive.clear();
  for (int i = 0; i < nv; ++i)
    if (std::find(tree->active.begin(), tree->active.end(), i) == tree->active.end())
      tree->passive.push_back(i);
  tree->tolerance = tolerance;
  tree->max_iterations = max_iterations;
  const Eigen::Index rows = tree->residual.size();
  tree->jacobian.resize(rows, nv);
  tree->joint_jacobian.resize(6, nv);
  tree->passive_jacobian.resize(rows, (Eigen::Index)tree->passive.size());
  tree->active_jacobian.resize(rows, 3);
  tree->passive_rates.resize((Eigen::Index)tree->passive.size(), 3);
  tree->correction.resize((Eigen::Index)tree->passive.size());
  tree->lu = Eigen::PartialPivLU<Eigen::MatrixXd>((Eigen::Index)tree->passive.size());
  tree->last_q = Eigen::Map<const Eigen::VectorXd>(q0, nv);
  tree->last_S = Eigen::MatrixXd::Zero(nv, 3);  // no predictor for the first completion
  return 0;
}

// alpha_ddot (3) of the plant in active coordinates at (alpha, alpha_dot) under net active-joint
// torques `torque` (3: tau - F - M_f), platform mass and rotational inertia as dpn_dynamics; the
// platform position xyz (3) [m] and the closure gap [m] of the completed configuration go to
// `xyz` and `gap`. Returns 0; 2 where the loops do not close (Newton fails); 1 where Pinocchio
// throws or M or the Delassus matrix is not positive definite.
int dpn_active_dynamics(
  void * handle, const double * alpha, const double * alpha_dot, const double * torque, double mass,
  const double * rotational, double * alpha_ddot, double * xyz, double * gap)
{
  Tree * tree = static_cast<Tree *>(handle);
  const Eigen::Index passive = (Eigen::Index)tree->passive.size();
  try
  {
    // predictor: q = q_last + S_last (alpha - alpha_last)
    Eigen::Vector3d step;
    for (int i = 0; i < 3; ++i)
      step[i] = alpha[i] - tree->last_q[tree->active[i]];
    tree->q.noalias() = tree->last_q + tree->last_S * step;
    for (int i = 0; i < 3; ++i)
      tree->q[tree->active[i]] = alpha[i];
    // Newton on the passive coordinates (DeltaPinocchioModel.configuration)
    bool closed = false;
    for (int iteration = 0; iteration <= tree->max_iterations; ++iteration)
    {
      closure_residual(tree, true);
      for (Eigen::Index j = 0; j < passive; ++j)
        tree->passive_jacobian.col(j) = tree->jacobian.col(tree->passive[(size_t)j]);
      *gap = largest(tree->residual);
      if (*gap <= tree->tolerance)
      {
        closed = true;
        break;
      }
      if (iteration == tree->max_iterations || std::isnan(*gap))
        break;
      tree->lu.compute(tree->passive_jacobian);
      tree->correction = tree->lu.solve(tree->residual);
      for (Eigen::Index j = 0; j < passive; ++j)
        tree->q[tree->passive[(size_t)j]] -= tree->correction[j];
    }
    if (!closed)
      return 2;
    // S = dq/dalpha at the closed configuration: [I; -J_p^-1 J_a] (DeltaPinocchioModel.velocity_map)
    for (int i = 0; i < 3; ++i)
      tree->active_jacobian.col(i) = tree->jacobian.col(tree->active[i]);
    tree->lu.compute(tree->passive_jacobian);
    tree->passive_rates = tree->lu.solve(tree->active_jacobian);
    tree->last_S.setZero();
    for (int i = 0; i < 3; ++i)
      tree->last_S(tree->active[i], i) = 1.0;
    for (Eigen::Index j = 0; j < passive; ++j)
      tree->last_S.row(tree->passive[(size_t)j]) = -tree->passive_rates.row(j);
    tree->last_q = tree->q;
    tree->v.noalias() = tree->last_S * Eigen::Map<const Eigen::Vector3d>(alpha_dot);
    tree->tau.setZero();
    for (int i = 0; i < 3; ++i)
      tree->tau[tree->active[i]] = torque[i];
    // ddq by delta-pin's recursive algorithms (dpn_dynamics_axis): at a closed configuration
    // with v = S alpha_dot the Baumgarte terms vanish, and this is constraintDynamics' ddq to
    // rounding at ~40 % of its cost
    tree->ddq.resize(tree->model.nv);
    if (!tree->axis->dynamics(
          tree->q.data(), tree->v.data(), tree->tau.data(), mass, rotational, tree->ddq.data()))
      return 1;
    for (int i = 0; i < 3; ++i)
    {
      alpha_ddot[i] = tree->ddq[tree->active[i]];
      xyz[i] = tree->q[tree->platform[i]];
    }
    return 0;
  }
  catch (const std::exception &)
  {
    return 1;
  }
}

// Largest closure gap max |p_anchor1 - p_anchor2| [m] at q (NaN where a coordinate is NaN).
double dpn_closure_gap(void * handle, const double * q)
{
  Tree * tree = static_cast<Tree *>(handle);
  tree->q = Eigen::Map<const Eigen::VectorXd>(q, tree->model.nv);
  closure_residual(tree, false);
  return largest(tree->residual);
}

} // extern "C"
