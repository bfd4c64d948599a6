// A robot's Pinocchio model from its text archive (model_text.hpp): Boost's serialisation of every
// joint type, a unit of its own because it takes as long to compile as the rest of the model.

#include "model_text.hpp"

#include <pinocchio/serialization.hpp>

namespace delta_pin
{
  void model_from_text(const std::string & text, pinocchio::Model & model)
  {
    model.loadFromString(text);
  }
} // namespace delta_pin
