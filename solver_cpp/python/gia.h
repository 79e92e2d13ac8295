// Python bindings of the intersection analysis (weft._solver.intersection_analysis & co).
#pragma once

#include <pybind11/pybind11.h>

namespace weft {
void bind_gia(pybind11::module_& m);
}  // namespace weft
