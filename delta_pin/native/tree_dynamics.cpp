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

#include <pinocchio/algorithm/constrained-dynamics.hpp>
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
    if (mass != tree->platform_mass)
    {
      Inertia & inertia = tree->model.inertias[tree->platform_joint];
      inertia = Inertia(
        mass, inertia.lever(), Symmetric3(Eigen::Matrix3d(Eigen::Map<const RowMatrix3>(rotational))));
      tree->platform_mass = mass;
    }
    tree->q = Eigen::Map<const Eigen::VectorXd>(q, n);
    tree->v = Eigen::Map<const Eigen::VectorXd>(v, n);
    tree->tau = Eigen::Map<const Eigen::VectorXd>(tau, n);
    const Eigen::VectorXd & a = constraintDynamics(
      tree->model, tree->data, tree->q, tree->v, tree->tau, tree->constraint_models,
      tree->constraint_datas, tree->settings);
    Eigen::Map<Eigen::VectorXd>(ddq, n) = a;
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
  forwardKinematics(tree->model, tree->data, tree->q);
  double gap = 0.0;
  for (const RigidConstraintModel & constraint : tree->constraint_models)
  {
    const Eigen::Vector3d difference =
      (tree->data.oMi[constraint.joint1_id] * constraint.joint1_placement).translation()
      - (tree->data.oMi[constraint.joint2_id] * constraint.joint2_placement).translation();
    for (int i = 0; i < 3; ++i)
    {
      if (std::isnan(difference[i]))
        return std::nan("");
      gap = std::max(gap, std::abs(difference[i]));
    }
  }
  return gap;
}

} // extern "C"
