// Argument checks and a reduction that the core's translation units share.
//
// Every check throws std::invalid_argument (Python: ValueError) naming the argument, what it got
// and what it needed, before the caller touches memory: a size, an index into the model's frames,
// joints or coordinates, a closure's rows, a table's shape, a finite value.
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

  // "(rows, cols)"
  inline std::string shape_text(Eigen::Index rows, Eigen::Index cols)
  {
    return "(" + std::to_string(rows) + ", " + std::to_string(cols) + ")";
  }

  // a table of exactly `cols` columns and at least `min_rows` rows (rows < 0: any number)
  template<typename Table>
  inline void check_shape(const Table & table, Eigen::Index min_rows, Eigen::Index cols, const char * name)
  {
    if (table.cols() != cols || (min_rows >= 0 && table.rows() < min_rows))
      throw std::invalid_argument(
        std::string(name) + " has shape " + shape_text(table.rows(), table.cols()) + ", expected "
        + (min_rows >= 0 ? "at least " + std::to_string(min_rows) : std::string("any number of")) + " rows and "
        + std::to_string(cols) + " columns");
  }

  // 0 <= index < size, `what` naming the range ("the model's 14 frames")
  inline void check_index(long long index, long long size, const std::string & name, const std::string & what)
  {
    if (index < 0 || index >= size)
      throw std::invalid_argument(
        name + " is " + std::to_string(index) + ", outside " + what + " (expected 0 to " + std::to_string(size - 1) + ")");
  }

  // every entry of `indices` within 0 <= i < size
  template<typename Indices>
  inline void check_indices(const Indices & indices, long long size, const char * name, const std::string & what)
  {
    for (Eigen::Index i = 0; i < indices.size(); ++i)
      check_index((long long)indices[i], size, std::string(name) + "[" + std::to_string(i) + "]", what);
  }

  // a loop closure's equations: 3 (a point) or 6 (a weld)
  inline void check_closure_rows(int rows, const std::string & name)
  {
    if (rows != 3 && rows != 6)
      throw std::invalid_argument(name + " has " + std::to_string(rows) + " rows, expected 3 (a point) or 6 (a weld)");
  }

  // every entry finite (NaN or inf would run through the arithmetic into a result reported as
  // success)
  template<typename Values>
  inline void check_finite(const Values & values, const char * name)
  {
    if (!values.allFinite())
      throw std::invalid_argument(std::string(name) + " holds a non-finite entry (NaN or inf)");
  }

  inline void check_finite(double value, const char * name)
  {
    if (!std::isfinite(value))
      throw std::invalid_argument(std::string(name) + " is " + std::to_string(value) + ", expected a finite number");
  }

  // a finite value > 0 (a period, a step length)
  inline void check_positive(double value, const char * name)
  {
    if (!(std::isfinite(value) && value > 0.0))
      throw std::invalid_argument(std::string(name) + " is " + std::to_string(value) + ", expected a finite number > 0");
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
