// A simulation that cannot go on, with the simulated time [s] at which it stopped (Python sees
// delta_pin.compiled._core.SimulationFailure and raises delta_pin's SimulationError from it).
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

namespace delta_pin
{
  struct SimulationFailure : std::runtime_error
  {
    explicit SimulationFailure(const std::string & message)
    : std::runtime_error(message)
    {
    }
    double time = std::nan("");
  };

  // An error raised by a caller's callback inside a compiled loop (a Python controller): the
  // loops let it pass unchanged, and the binding that called the loop re-raises the caller's own
  // error.
  struct CallbackError : std::runtime_error
  {
    CallbackError()
    : std::runtime_error("the callback raised")
    {
    }
  };
} // namespace delta_pin
