// What closed_chain.hpp keeps behind pointers: the Pinocchio model and data of ClosedChainModel,
// and the dynamics of ClosedChainPlant. Included by closed_chain_model.cpp and closed_chain.cpp
// only, the two units that call Pinocchio (docs/architecture.md section 8, build time).
#pragma once

#include "axis_tree.hpp"
#include "closed_chain.hpp"

#include "pinocchio_library.hpp"

#include <memory>
#include <vector>

namespace delta_pin
{
  struct ClosedChainModel::Multibody
  {
    pinocchio::Model model;
    pinocchio::Data data;
  };

  struct ClosedChainPlant::Dynamics
  {
    pinocchio::Model model;
    pinocchio::Data data;
    std::vector<pinocchio::RigidConstraintModel> constraint_models;
    std::vector<pinocchio::RigidConstraintData> constraint_datas;
    pinocchio::ProximalSettings settings;
    pinocchio::Inertia base_inertia = pinocchio::Inertia::Zero();  // the payload body's own
    std::unique_ptr<dpn::AxisTree> axis;  // the axis-tree stage; none: constraintDynamics

    Dynamics(const pinocchio::Model & model_, const pinocchio::ProximalSettings & settings_)
    : model(model_)
    , settings(settings_)
    {
    }
  };
} // namespace delta_pin
