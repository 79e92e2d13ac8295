// Python bindings of module weft._solver, one file per stage folder of src/weft: module.cpp
// (the simulation: integrator, forces, bodies), linear_system.cpp, collision.cpp, gia.cpp
// (intersection analysis and body/body pinch states). module.cpp calls these in a fixed order.
#pragma once

#include <pybind11/pybind11.h>

void bind_collision(pybind11::module_& m);      // collision.cpp
void bind_linear_system(pybind11::module_& m);  // linear_system.cpp
namespace weft {
void bind_gia(pybind11::module_& m);    // gia.cpp: intersection analysis
void bind_pinch(pybind11::module_& m);  // gia.cpp: body/body pinch states
}  // namespace weft
