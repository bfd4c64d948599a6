// A robot's Pinocchio model rebuilt from its ModelSpec (model_spec.hpp) with Model::addJoint,
// whose double-precision instantiation the pin wheel's library holds: the unit compiles
// Pinocchio's model and joint headers only, not Boost's serialisation of every joint type.

#include "model_spec.hpp"

#include "checks.hpp"

#include <pinocchio/multibody.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace delta_pin
{
  using namespace pinocchio;

  namespace
  {
    SE3 placement_of(const Placements & rows, Eigen::Index k)
    {
      Eigen::Matrix3d rotation;
      rotation << rows(k, 0), rows(k, 1), rows(k, 2), rows(k, 3), rows(k, 4), rows(k, 5), rows(k, 6), rows(k, 7),
        rows(k, 8);
      return SE3(rotation, Eigen::Vector3d(rows(k, 9), rows(k, 10), rows(k, 11)));
    }

    void check_finite_rows(const Eigen::Ref<const Eigen::MatrixXd> & values, const std::string & name)
    {
      if (!values.allFinite())
        throw std::invalid_argument(name + " holds a NaN or an infinite number; expected finite numbers");
    }

    Eigen::Vector3d unit_axis(const Eigen::Vector3d & axis, const std::string & name)
    {
      const double norm = axis.norm();
      if (!std::isfinite(norm) || std::abs(norm - 1.0) > 1e-6)
        throw std::invalid_argument(
          name + " has norm " + std::to_string(norm) + "; expected a unit vector (Pinocchio's joint axis)");
      return axis;
    }

    JointModel joint_of(const JointSpec & joint, const std::string & name)
    {
      const std::string & t = joint.type;
      check_finite_rows(joint.axis, name + "'s axis");
      check_finite_rows(joint.axis2, name + "'s axis2");
      check_finite(joint.pitch, "a joint's pitch");
      if (t == "JointModelRX")
        return JointModelRX();
      if (t == "JointModelRY")
        return JointModelRY();
      if (t == "JointModelRZ")
        return JointModelRZ();
      if (t == "JointModelRUBX")
        return JointModelRUBX();
      if (t == "JointModelRUBY")
        return JointModelRUBY();
      if (t == "JointModelRUBZ")
        return JointModelRUBZ();
      if (t == "JointModelPX")
        return JointModelPX();
      if (t == "JointModelPY")
        return JointModelPY();
      if (t == "JointModelPZ")
        return JointModelPZ();
      if (t == "JointModelHX")
        return JointModelHX(joint.pitch);
      if (t == "JointModelHY")
        return JointModelHY(joint.pitch);
      if (t == "JointModelHZ")
        return JointModelHZ(joint.pitch);
      if (t == "JointModelRevoluteUnaligned")
        return JointModelRevoluteUnaligned(unit_axis(joint.axis, name + "'s axis"));
      if (t == "JointModelRevoluteUnboundedUnaligned")
        return JointModelRevoluteUnboundedUnaligned(unit_axis(joint.axis, name + "'s axis"));
      if (t == "JointModelPrismaticUnaligned")
        return JointModelPrismaticUnaligned(unit_axis(joint.axis, name + "'s axis"));
      if (t == "JointModelHelicalUnaligned")
        return JointModelHelicalUnaligned(unit_axis(joint.axis, name + "'s axis"), joint.pitch);
      if (t == "JointModelUniversal")
        return JointModelUniversal(unit_axis(joint.axis, name + "'s axis"), unit_axis(joint.axis2, name + "'s axis2"));
      if (t == "JointModelSpherical")
        return JointModelSpherical();
      if (t == "JointModelSphericalZYX")
        return JointModelSphericalZYX();
      if (t == "JointModelTranslation")
        return JointModelTranslation();
      if (t == "JointModelPlanar")
        return JointModelPlanar();
      if (t == "JointModelFreeFlyer")
        return JointModelFreeFlyer();
      if (t == "JointModelComposite")
      {
        if (joint.parts.empty() || (Eigen::Index)joint.parts.size() != joint.part_placements.rows())
          throw std::invalid_argument(
            name + " is a JointModelComposite of " + std::to_string(joint.parts.size()) + " parts and "
            + std::to_string(joint.part_placements.rows()) + " part placements; expected one placement per part, "
            + "at least one part");
        check_finite_rows(joint.part_placements, name + "'s part placements");
        JointModelComposite composite;
        for (size_t k = 0; k < joint.parts.size(); ++k)
          composite.addJoint(
            joint_of(joint.parts[k], name + "'s part " + std::to_string(k)),
            placement_of(joint.part_placements, (Eigen::Index)k));
        return composite;
      }
      throw std::invalid_argument(
        name + " is a " + (t.empty() ? std::string("joint of no type") : t)
        + ", a joint type the core does not rebuild; it takes Pinocchio's revolute, prismatic, helical, universal, "
          "spherical, translation, planar, free-flyer and composite joints");
    }
  } // namespace

  void build_model(const ModelSpec & spec, Model & model)
  {
    const Eigen::Index n = (Eigen::Index)spec.joints.size();
    if ((Eigen::Index)spec.joint_names.size() != n || spec.parents.size() != n || spec.placements.rows() != n)
      throw std::invalid_argument(
        "the model has " + std::to_string(n) + " joints, " + std::to_string(spec.joint_names.size()) + " joint names, "
        + std::to_string(spec.parents.size()) + " parents and " + std::to_string(spec.placements.rows())
        + " placements; expected one of each per joint");
    if (spec.inertias.rows() != n + 1)
      throw std::invalid_argument(
        "the model has " + std::to_string(spec.inertias.rows()) + " inertias; expected " + std::to_string(n + 1)
        + " (the universe's, then one per joint)");
    check_finite_rows(spec.placements, "the joints' placements");
    check_finite_rows(spec.inertias, "the inertias");
    check_finite_rows(spec.gravity, "gravity");
    model = Model();
    for (Eigen::Index j = 0; j < n; ++j)
    {
      const std::string & joint_name = spec.joint_names[(size_t)j];
      const std::string name = "joint " + std::to_string(j + 1) + " ('" + joint_name + "')";
      check_index(spec.parents[j], j + 1, name + "'s parent", "the joints before it (0 is the universe)");
      model.addJoint(
        (JointIndex)spec.parents[j], joint_of(spec.joints[(size_t)j], name), placement_of(spec.placements, j),
        joint_name);
    }
    for (Eigen::Index j = 0; j <= n; ++j)
    {
      const auto row = spec.inertias.row(j);
      Eigen::Matrix3d rotational;
      rotational << row(4), row(5), row(6), row(7), row(8), row(9), row(10), row(11), row(12);
      model.inertias[(size_t)j] = Inertia(row(0), Eigen::Vector3d(row(1), row(2), row(3)), rotational);
    }
    const Eigen::Index frames = (Eigen::Index)spec.frame_names.size();
    if (spec.frame_joints.size() != frames || spec.frame_parents.size() != frames || spec.frame_types.size() != frames
        || spec.frame_placements.rows() != frames)
      throw std::invalid_argument(
        "the model has " + std::to_string(frames) + " frame names, " + std::to_string(spec.frame_joints.size())
        + " parent joints, " + std::to_string(spec.frame_parents.size()) + " parent frames, "
        + std::to_string(spec.frame_types.size()) + " types and " + std::to_string(spec.frame_placements.rows())
        + " placements; expected one of each per frame");
    check_finite_rows(spec.frame_placements, "the frames' placements");
    for (Eigen::Index f = 0; f < frames; ++f)
    {
      const std::string name = "frame " + std::to_string(f + 1) + " ('" + spec.frame_names[(size_t)f] + "')";
      check_index(spec.frame_joints[f], model.njoints, name + "'s parent joint", "the model's joints");
      // Pinocchio's URDF parser makes some frames their own parent (Gepetto's digit_like_2legs_6D)
      check_index(spec.frame_parents[f], f + 2, name + "'s parent frame", "the frames before it or itself");
      const int type = spec.frame_types[f];
      if (type != OP_FRAME && type != JOINT && type != FIXED_JOINT && type != BODY && type != SENSOR)
        throw std::invalid_argument(
          name + " has type " + std::to_string(type) + "; expected one of Pinocchio's FrameType values 1, 2, 4, 8, 16");
      // pushed as they are, not through addFrame, which would merge two frames of one name and type
      model.frames.push_back(Frame(
        spec.frame_names[(size_t)f], (JointIndex)spec.frame_joints[f], (FrameIndex)spec.frame_parents[f],
        placement_of(spec.frame_placements, f), (FrameType)type));
      model.nframes += 1;
    }
    model.gravity = Motion(spec.gravity);
    if (spec.armature.size() != model.nv)
      throw std::invalid_argument(
        "the model's armature has " + std::to_string(spec.armature.size()) + " entries; expected "
        + std::to_string(model.nv) + " (one per entry of v)");
    check_finite_rows(spec.armature, "the armature");
    model.armature = spec.armature;
  }
} // namespace delta_pin
