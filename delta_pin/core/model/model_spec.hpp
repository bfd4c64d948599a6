// A robot's Pinocchio model as the core rebuilds it (issue 38, item 4: no Boost serialisation in
// the core's build): what Pinocchio's algorithms read of ClosedChainRobot.model -- each joint's
// type and axes, its parent and placement, the bodies' inertias, every frame, gravity and the
// rotor armature -- written by delta_pin/model/core_model.py and rebuilt with Model::addJoint;
// the joints' names too, for the core's messages. Limits, friction and damping are not handed
// over: no algorithm the core calls reads them. This header includes no Pinocchio (closed_chain.hpp includes it).
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace pinocchio
{
  template<typename Scalar, int Options, template<typename, int> class JointCollectionTpl>
  struct ModelTpl;
  template<typename Scalar, int Options>
  struct JointCollectionDefaultTpl;
} // namespace pinocchio

namespace delta_pin
{
  // A placement (rotation, translation) as 12 numbers: the rotation's rows, then the translation [m].
  typedef Eigen::Matrix<double, Eigen::Dynamic, 12, Eigen::RowMajor> Placements;

  // One joint: Pinocchio's shortname() ("JointModelRX", "JointModelRevoluteUnaligned", ...), its
  // axis (unaligned revolute, prismatic, helical; Universal's first), Universal's second axis, a
  // helical joint's pitch [m/rad], and a JointModelComposite's parts with their placements.
  struct JointSpec
  {
    std::string type;
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    Eigen::Vector3d axis2 = Eigen::Vector3d::Zero();
    double pitch = 0.0;
    std::vector<JointSpec> parts;
    Placements part_placements;
  };

  // Joints 1 .. njoints-1 (the universe is implied) with their names, parents and placements in the
  // parent's frame; inertias: one row per joint, the universe first (mass [kg], the centre of mass
  // in the joint's frame [m], the rotational inertia about it [kg m^2] by rows); frames
  // 1 .. nframes-1 (the universe frame is implied): name, parent joint, parent frame, placement
  // in the parent joint's frame, Pinocchio's FrameType as its integer; gravity [m/s^2] as a spatial
  // motion (linear, angular); armature [kg m^2] per entry of v.
  struct ModelSpec
  {
    std::vector<JointSpec> joints;
    std::vector<std::string> joint_names;
    Eigen::VectorXi parents;
    Placements placements;
    Eigen::Matrix<double, Eigen::Dynamic, 13, Eigen::RowMajor> inertias;
    std::vector<std::string> frame_names;
    Eigen::VectorXi frame_joints, frame_parents, frame_types;
    Placements frame_placements;
    Eigen::Matrix<double, 6, 1> gravity = Eigen::Matrix<double, 6, 1>::Zero();
    Eigen::VectorXd armature;
  };

  // model = the model `spec` describes; throws std::invalid_argument naming the first field that
  // does not fit (a count, an index, a non-finite number, a joint type the core does not rebuild)
  void build_model(
    const ModelSpec & spec, pinocchio::ModelTpl<double, 0, pinocchio::JointCollectionDefaultTpl> & model);
} // namespace delta_pin
