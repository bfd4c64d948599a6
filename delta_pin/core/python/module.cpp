// delta_pin.compiled._core: the Python face of delta-pin's compiled core (nanobind).
//
// The plants (plant.hpp) -- ClosedChainPlant (closed_chain.hpp), the constrained plant of any
// fully actuated closed-chain robot, AnalyticDeltaPlant (analytic_plant.hpp), the paper's
// reduced Delta, and PythonPlant (python_plant.cpp), a plant written in Python -- share the one
// run (run.hpp, bind_run.cpp), which runs a compiled law or calls a Python one back
// (delta_pin/sim/compiled_plant.py builds the plants). One binding file per part (binding.hpp);
// this one registers the module, its exceptions and the Ctrl-C hook, and calls the binders.
//
// Nothing here is compiled at run time: scikit-build-core builds this module when the package
// is installed (CMakeLists.txt).

#include "failure.hpp"
#include "interrupt.hpp"

#include <nanobind/nanobind.h>

namespace nb = nanobind;

// the binders, one per part (binding.hpp declares them for the binding files; declared again here
// so that this unit parses neither Eigen nor the core's headers)
void bind_model(nb::module_ & m);
void bind_plants(nb::module_ & m);
void bind_python_plant(nb::module_ & m);
void bind_run(nb::module_ & m);
void bind_laws(nb::module_ & m);

namespace
{
  // the interrupt hook (interrupt.hpp): runs Python's signal handlers, in the main thread only
  // (elsewhere PyErr_CheckSignals does nothing); true when one of them raised
  bool python_signal_pending()
  {
    nb::gil_scoped_acquire acquire;
    return PyErr_CheckSignals() != 0;
  }
} // namespace

NB_MODULE(_core, m)
{
  m.doc() = "delta-pin's compiled core (see delta_pin/compiled/core.py)";
  m.attr("pinocchio_version") = DELTA_PIN_PINOCCHIO_VERSION;
  nb::exception<delta_pin::SimulationFailure>(m, "SimulationFailure", PyExc_RuntimeError);
  // Ctrl-C within the loops (interrupt.hpp): Python's signal handlers run at the poll, and the
  // exception they raise (KeyboardInterrupt, or the CLI's) is what the interrupted call raises
  delta_pin::interrupt_hook() = &python_signal_pending;
  nb::register_exception_translator(
    [](const std::exception_ptr & error, void *)
    {
      try
      {
        std::rethrow_exception(error);
      }
      catch (const delta_pin::Interrupted &)
      {
        if (!PyErr_Occurred())  // a handler that asked to stop without raising
          PyErr_SetNone(PyExc_KeyboardInterrupt);
      }
    });
  bind_model(m);
  bind_plants(m);
  bind_python_plant(m);
  bind_run(m);
  bind_laws(m);
}
