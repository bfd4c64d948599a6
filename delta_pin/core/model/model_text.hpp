// A robot's Pinocchio model from the text archive Python hands over
// (pinocchio::Model::saveToString() of ClosedChainRobot.model, closure frames included).
#pragma once

#include <pinocchio/multibody.hpp>

#include <string>

namespace delta_pin
{
  // model = the model of `text` (throws where the archive cannot be read)
  void model_from_text(const std::string & text, pinocchio::Model & model);
} // namespace delta_pin
