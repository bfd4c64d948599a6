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
// `dpn_dynamics_schur` gives the same accelerations with the KKT system solved by its Schur
// complement (constraintDynamics' own kinematic pass and closure right-hand side, then the
// tree-sparse factor of M and the small Delassus matrix instead of the generic sparse KKT
// factorisation and its residual evaluation): equal to constraintDynamics to ~1e-13 relative and
// ~1 us cheaper a call; the compiled sampled loops call it where delta_pin.sim.batch.NATIVE_STAGE
// says so (not by default: the Python loop's arithmetic is constraintDynamics').
//
// `dpn_active_dynamics` is the same plant in active coordinates (PinocchioPlant with
// coordinates="active"): q(alpha) completed by Newton on the passive coordinates from a
// first-order predictor off the previous completion, v = S alpha_dot with S = dq/dalpha from the
// closure Jacobian, then alpha_ddot from constraintDynamics -- the loops closed to the tolerance at
// every evaluation, for implicit integrators on the small state [alpha, alpha_dot].

#include <pinocchio/algorithm/constrained-dynamics.hpp>
#include <pinocchio/algorithm/cholesky.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/multibody.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
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
    // the Schur-complement stage (dpn_dynamics_schur): constraint Jacobian, its right-hand side,
    // M^-1 J^T, the Delassus matrix J M^-1 J^T and their factors
    Eigen::MatrixXd constraint_jacobian, minv_jt;
    Eigen::VectorXd constraint_rhs, ddq;
    std::vector<double> delassus_numbers, multiplier_numbers;  // D's Cholesky factor (row-major), y
    bool schur_ok = true;
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

  // The same constrained acceleration as solve_tree, the KKT system solved by its Schur complement.
  // The kinematic pass, the mass matrix (upper triangle), the nonlinear effects, the constraint
  // placements and the right-hand side of each point closure with its Baumgarte terms are
  // constraintDynamics' own (its two passes and the CONTACT_3D / LOCAL branch of its loop), so
  // those numbers are Pinocchio's. Where constraintDynamics then factorises the whole
  // (rows + nv)^2 KKT matrix with its generic sparse Cholesky and evaluates a residual, this
  // factorises M = U D U^T with the tree's sparsity (cholesky::decompose), forms
  // a_free = M^-1 (tau - nle), the Delassus matrix D = J M^-1 J^T (rows x rows) and solves
  // D y = rhs - J a_free, ddq = a_free + M^-1 J^T y: the exact solution of
  // M ddq = tau - nle + J^T y,  J ddq = rhs  (constraintDynamics with mu = 0 and one iteration),
  // equal to it up to rounding (tests/sim/test_native.py).
  const Eigen::VectorXd & solve_tree_schur(Tree * tree, double mass, const double * rotational)
  {
    Model & model = tree->model;
    Data & data = tree->data;
    if (mass != tree->platform_mass)
    {
      Inertia & inertia = model.inertias[tree->platform_joint];
      inertia = Inertia(
        mass, inertia.lever(), Symmetric3(Eigen::Matrix3d(Eigen::Map<const RowMatrix3>(rotational))));
      tree->platform_mass = mass;
    }
    data.oYcrb[0].setZero();
    data.of[0].setZero();
    data.oa[0].setZero();
    data.ov[0].setZero();
    typedef ContactAndImpulseDynamicsForwardStep<
      double, 0, JointCollectionDefaultTpl, Eigen::VectorXd, Eigen::VectorXd, true>
      Pass1;
    for (JointIndex i = 1; i < (JointIndex)model.njoints; ++i)
      Pass1::run(model.joints[i], data.joints[i], Pass1::ArgsType(model, data, tree->q, tree->v));
    typedef ContactAndImpulseDynamicsBackwardStep<double, 0, JointCollectionDefaultTpl, true> Pass2;
    for (JointIndex i = (JointIndex)(model.njoints - 1); i > 0; --i)
      Pass2::run(model.joints[i], Pass2::ArgsType(model, data));
    data.M.diagonal() += model.armature;
    calc(model, data, tree->constraint_models, tree->constraint_datas);

    const Eigen::Index rows = 3 * (Eigen::Index)tree->constraint_models.size();
    const Eigen::Index nv = model.nv;
    tree->constraint_jacobian.resize(rows, nv);
    tree->constraint_rhs.resize(rows);
    for (size_t c = 0; c < tree->constraint_models.size(); ++c)
    {
      const RigidConstraintModel & constraint = tree->constraint_models[c];
      RigidConstraintData & cdata = tree->constraint_datas[c];
      if (constraint.type != CONTACT_3D || constraint.reference_frame != LOCAL)
        throw std::invalid_argument("the Schur stage takes CONTACT_3D closures in LOCAL frames");
      const JointIndex joint1_id = constraint.joint1_id, joint2_id = constraint.joint2_id;
      const SE3 & oMc1 = cdata.oMc1;
      const SE3 & oMc2 = cdata.oMc2;
      const SE3 & c1Mc2 = cdata.c1Mc2;
      // the Jacobian of the anchors' relative velocity in frame c1 (what RigidConstraintModel's
      // jacobian gives: v_point = v_o + omega x p per world column of data.J, rotated into c1)
      const auto & support1 = model.sparsity_pattern_vector[joint1_id];
      const auto & support2 = model.sparsity_pattern_vector[joint2_id];
      const Eigen::Vector3d & p1 = oMc1.translation();
      const Eigen::Vector3d & p2 = oMc2.translation();
      for (Eigen::Index jj = 0; jj < nv; ++jj)
      {
        const bool on1 = joint1_id > 0 && support1[jj], on2 = joint2_id > 0 && support2[jj];
        Eigen::Vector3d column = Eigen::Vector3d::Zero();
        if (on1 != on2)
        {
          const Eigen::Vector3d linear = data.J.col(jj).head<3>();
          const Eigen::Vector3d angular = data.J.col(jj).tail<3>();
          column = on1 ? Eigen::Vector3d(linear + angular.cross(p1))
                       : Eigen::Vector3d(-(linear + angular.cross(p2)));
        }
        else if (on1)
        {
          const Eigen::Vector3d angular = data.J.col(jj).tail<3>();
          column = angular.cross(p1 - p2);
        }
        tree->constraint_jacobian.block<3, 1>(3 * (Eigen::Index)c, jj).noalias() =
          oMc1.rotation().transpose() * column;
      }
      // the right-hand side: constraintDynamics' CONTACT_3D / LOCAL branch, verbatim
      const RigidConstraintModel::BaumgarteCorrectorParameters & corrector =
        constraint.m_baumgarte_parameters;
      Motion & vc1 = cdata.contact1_velocity;
      Motion & vc2 = cdata.contact2_velocity;
      if (joint1_id > 0)
        vc1 = oMc1.actInv(data.ov[joint1_id]);
      else
        vc1.setZero();
      if (joint2_id > 0)
        vc2 = oMc2.actInv(data.ov[joint2_id]);
      else
        vc2.setZero();
      cdata.contact_placement_error.linear() = -c1Mc2.translation();
      cdata.contact_placement_error.angular().setZero();
      cdata.contact_velocity_error.linear() = vc1.linear() - c1Mc2.rotation() * vc2.linear();
      cdata.contact_velocity_error.angular().setZero();
      Motion & acceleration_error = cdata.contact_acceleration_error;
      if ((corrector.Kp == 0.0) && (corrector.Kd == 0.0))
        acceleration_error.setZero();
      else
      {
        acceleration_error.linear().noalias() =
          -(corrector.Kp * cdata.contact_placement_error.linear())
          - (corrector.Kd * cdata.contact_velocity_error.linear());
        acceleration_error.angular().setZero();
      }
      Motion & drift1 = cdata.contact1_acceleration_drift;
      Motion & drift2 = cdata.contact2_acceleration_drift;
      drift1 = oMc1.actInv(data.oa[joint1_id]);
      drift1.linear() += vc1.angular().cross(vc1.linear());
      drift1.angular().setZero();
      drift2.linear().noalias() =
        oMc1.rotation().transpose()
        * (data.oa[joint2_id].linear() + data.oa[joint2_id].angular().cross(oMc2.translation())
           + data.ov[joint2_id].angular().cross(
             data.ov[joint2_id].linear() + data.ov[joint2_id].angular().cross(oMc2.translation())));
      drift2.angular().setZero();
      tree->constraint_rhs.segment<3>(3 * (Eigen::Index)c) =
        -drift1.linear() + drift2.linear() + acceleration_error.linear()
        + cdata.contact_acceleration_desired.linear();
    }

    // M = U D U^T with the tree's sparsity (Pinocchio's cholesky::decompose of the upper triangle
    // Pass2 filled), then a_free = M^-1 (tau - nle) and M^-1 J^T, column by column
    cholesky::decompose(model, data);
    tree->ddq = tree->tau - data.nle;
    cholesky::solve(model, data, tree->ddq);  // a_free
    tree->minv_jt = tree->constraint_jacobian.transpose();
    cholesky::solve(model, data, tree->minv_jt);
    // D = J M^-1 J^T (rows x rows, symmetric positive definite where the closures are
    // independent), D y = rhs - J a_free by a plain Cholesky, ddq = a_free + M^-1 J^T y
    double * L = tree->delassus_numbers.data();
    double * y = tree->multiplier_numbers.data();
    const Eigen::Index k = rows;
    for (Eigen::Index i = 0; i < k; ++i)
    {
      for (Eigen::Index j = 0; j <= i; ++j)
        L[i * k + j] = tree->constraint_jacobian.row(i).dot(tree->minv_jt.col(j));
      y[i] = tree->constraint_rhs[i] - tree->constraint_jacobian.row(i).dot(tree->ddq);
    }
    tree->schur_ok = true;
    for (Eigen::Index j = 0; j < k; ++j)
    {
      double diagonal = L[j * k + j];
      for (Eigen::Index m = 0; m < j; ++m)
        diagonal -= L[j * k + m] * L[j * k + m];
      if (!(diagonal > 0.0))
      {
        tree->schur_ok = false;
        return tree->ddq;
      }
      diagonal = std::sqrt(diagonal);
      L[j * k + j] = diagonal;
      for (Eigen::Index i = j + 1; i < k; ++i)
      {
        double value = L[i * k + j];
        for (Eigen::Index m = 0; m < j; ++m)
          value -= L[i * k + m] * L[j * k + m];
        L[i * k + j] = value / diagonal;
      }
    }
    for (Eigen::Index i = 0; i < k; ++i)  // L z = y
    {
      double value = y[i];
      for (Eigen::Index m = 0; m < i; ++m)
        value -= L[i * k + m] * y[m];
      y[i] = value / L[i * k + i];
    }
    for (Eigen::Index i = k - 1; i >= 0; --i)  // L^T y = z
    {
      double value = y[i];
      for (Eigen::Index m = i + 1; m < k; ++m)
        value -= L[m * k + i] * y[m];
      y[i] = value / L[i * k + i];
    }
    for (Eigen::Index i = 0; i < k; ++i)
      tree->ddq.noalias() += y[i] * tree->minv_jt.col(i);
    return tree->ddq;
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
    tree->delassus_numbers.assign((size_t)(9 * closures * closures), 0.0);
    tree->multiplier_numbers.assign((size_t)(3 * closures), 0.0);
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

// dpn_dynamics with the KKT system solved by its Schur complement (solve_tree_schur): the same
// accelerations up to rounding, without constraintDynamics' generic sparse KKT factorisation and
// residual evaluation. Returns 0, or 1 where Pinocchio throws or M or J M^-1 J^T is not positive
// definite (a singular closure).
int dpn_dynamics_schur(
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
    const Eigen::VectorXd & result = solve_tree_schur(tree, mass, rotational);
    if (!tree->schur_ok)
      return 1;
    Eigen::Map<Eigen::VectorXd>(ddq, n) = result;
    return 0;
  }
  catch (const std::exception &)
  {
    return 1;
  }
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
// throws.
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
    const Eigen::VectorXd & ddq = solve_tree(tree, mass, rotational);
    for (int i = 0; i < 3; ++i)
    {
      alpha_ddot[i] = ddq[tree->active[i]];
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
