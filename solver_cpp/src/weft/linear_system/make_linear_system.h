// The linear system path selected by LinearSystemOptions (linear_system_path.h): the fast path
// (fast_linear_system.h) in float32 or float64, or the reference path (linear_system.h).
#pragma once

#include <memory>

#include "weft/linear_system/linear_system_path.h"

namespace weft {

std::unique_ptr<LinearSystemPath> make_linear_system(const ClothMesh& mesh, const ForceModel& model,
                                                     const LinearSystemOptions& options, int pinned_vertices);

}  // namespace weft
