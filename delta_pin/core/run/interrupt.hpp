// Ctrl-C inside a compiled loop (issue 36, item 3). The loops run with Python's GIL released, so
// Python's signal handlers cannot run until they return; each loop calls poll_interrupt() once a
// sample, which at most every kInterruptPollPeriod asks the host whether to stop, through a hook
// the bindings install (module.cpp: Python's PyErr_CheckSignals). The core itself stays free of
// Python: without a hook poll_interrupt() does nothing.
#pragma once

#include <chrono>

namespace delta_pin
{
  // Thrown by poll_interrupt() when the host asks the run to stop. Deliberately not a
  // std::exception, so that the loops' handlers of numerical failures (which turn a
  // std::exception into a SimulationFailure) let it through unchanged; the bindings translate it
  // back to the host's pending error (Python's KeyboardInterrupt or the CLI's own).
  struct Interrupted
  {
  };

  // true when the run is to stop; may run the host's signal handlers
  using InterruptHook = bool (*)();

  inline InterruptHook & interrupt_hook()
  {
    static InterruptHook hook = nullptr;
    return hook;
  }

  // the longest time between two questions to the host: a Ctrl-C ends a run within about this
  constexpr std::chrono::milliseconds kInterruptPollPeriod{20};

  // cheap (a clock read) between the questions; throws Interrupted when the host says stop
  inline void poll_interrupt()
  {
    const InterruptHook hook = interrupt_hook();
    if (hook == nullptr)
      return;
    using Clock = std::chrono::steady_clock;
    thread_local Clock::time_point next = Clock::now();
    const Clock::time_point now = Clock::now();
    if (now < next)
      return;
    next = now + kInterruptPollPeriod;
    if (hook())
      throw Interrupted{};
  }
} // namespace delta_pin
