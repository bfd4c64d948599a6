// Argument checks and a reduction that the core's translation units share.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace delta_pin
{
  // std::invalid_argument naming `name` where `value` has not `size` entries
  inline void check_size(const Eigen::VectorXd & value, Eigen::Index size, const char * name)
  {
    if (value.size() != size)
      throw std::invalid_argument(
        std::string(name) + " has " + std::to_string(value.size()) + " entries, expected " + std::to_string(size));
  }

  // max |values_i|, NaN where one is NaN (0 for none)
  inline double largest(const Eigen::VectorXd & values)
  {
    double result = 0.0;
    for (Eigen::Index i = 0; i < values.size(); ++i)
    {
      if (std::isnan(values[i]))
        return std::numeric_limits<double>::quiet_NaN();
      result = std::max(result, std::abs(values[i]));
    }
    return result;
  }
} // namespace delta_pin
