// Compiled laws that bind themselves (issue 38, item 3): a law in core/laws/NAME.cpp defines its
// class, its gains struct and a binder, and registers the binder with a namespace-scope
// RegisterLaw; module.cpp runs every registered binder after binding ProjectedLaw, and CMake
// compiles every core/laws/*.cpp. Adding such a law edits no other C++ file.
#pragma once

#include <nanobind/nanobind.h>

#include <vector>

namespace delta_pin
{
  using LawBinder = void (*)(nanobind::module_ & module);

  inline std::vector<LawBinder> & law_binders()
  {
    static std::vector<LawBinder> binders;
    return binders;
  }

  // `static const RegisterLaw registered(&bind_my_law);` in the law's file
  struct RegisterLaw
  {
    explicit RegisterLaw(LawBinder binder) { law_binders().push_back(binder); }
  };
} // namespace delta_pin
