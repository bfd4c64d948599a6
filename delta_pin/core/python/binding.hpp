// What the binding files of the compiled core share (issue 38, item 2: one binding file per part):
// the array types Python hands over, the helpers that turn Python's numbers into the core's
// structs, and the binders module.cpp calls -- bind_model.cpp (the closed chain's model),
// bind_plants.cpp (the settings and the plants), python_plant.cpp (a plant written in Python),
// bind_run.cpp (the one run), bind_laws.cpp (the laws and their gains).
#pragma once

#include "analytic_plant.hpp"
#include "checks.hpp"
#include "closed_chain.hpp"
#include "controller.hpp"
#include "failure.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <memory>
#include <stdexcept>
#include <tuple>
#include <vector>

namespace delta_pin::binding
{
  namespace nb = nanobind;
  typedef nb::ndarray<double, nb::ndim<2>, nb::c_contig, nb::device::cpu> Table;
  typedef nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu> Column;

  inline Eigen::Map<RowMatrix> rows(Table & table)
  {
    return Eigen::Map<RowMatrix>(table.data(), (Eigen::Index)table.shape(0), (Eigen::Index)table.shape(1));
  }

  // eq. 12's Stribeck friction as Python gives it (StribeckFriction, by name), switched on
  inline FrictionSpec switched_on(FrictionSpec friction)
  {
    friction.enabled = true;
    return friction;
  }

  // the Delta's constants (lengths [m], the arm's inertia [kg m^2] and gravity torque [N m], g
  // [m/s^2], m_eq [kg]) and its chain azimuths (cos, sin: 3 each)
  inline DeltaGeometry delta_geometry(
    double R, double r, double l_a, double l_b, double arm_inertia, double arm_gravity, double g, double m_eq,
    const Eigen::Vector3d & cos_phi, const Eigen::Vector3d & sin_phi)
  {
    DeltaGeometry geometry;
    for (int i = 0; i < 3; ++i)
    {
      geometry.cos_phi[i] = cos_phi[i];
      geometry.sin_phi[i] = sin_phi[i];
    }
    geometry.R = R;
    geometry.r = r;
    geometry.l_a = l_a;
    geometry.l_b = l_b;
    geometry.arm_inertia = arm_inertia;
    geometry.arm_gravity = arm_gravity;
    geometry.g = g;
    geometry.m_eq = m_eq;
    return geometry;
  }

  // A Python error raised by a call-back inside a compiled run (a Python law or nominal model):
  // kept here while the run unwinds by CallbackError (the integrators turn other exceptions into
  // a SimulationFailure), then raised again unchanged by the binding that started the run
  inline std::unique_ptr<nb::python_error> & kept_python_error()
  {
    thread_local std::unique_ptr<nb::python_error> kept;
    return kept;
  }
  [[noreturn]] inline void keep_python_error(nb::python_error & error)
  {
    kept_python_error() = std::make_unique<nb::python_error>(std::move(error));
    throw CallbackError();
  }
  [[noreturn]] inline void raise_kept_python_error()
  {
    std::unique_ptr<nb::python_error> error = std::move(kept_python_error());
    if (!error)
      throw std::runtime_error("a Python call-back failed inside the run");
    throw *error;
  }

  inline std::vector<ClosureFrames> frames_of(const std::vector<std::tuple<size_t, size_t, int>> & closures)
  {
    std::vector<ClosureFrames> frames;
    for (const auto & [f1, f2, size] : closures)
      frames.push_back({f1, f2, size});
    return frames;
  }
} // namespace delta_pin::binding

// the binders, one per part (module.cpp calls them in this order)
void bind_model(nanobind::module_ & m);  // bind_model.cpp
void bind_plants(nanobind::module_ & m);  // bind_plants.cpp: the settings, CorePlant and the two plants
void bind_python_plant(nanobind::module_ & m);  // python_plant.cpp
void bind_run(nanobind::module_ & m);  // bind_run.cpp: the one run
void bind_laws(nanobind::module_ & m);  // bind_laws.cpp
