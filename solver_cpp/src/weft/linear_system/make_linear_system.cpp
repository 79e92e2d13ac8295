#include "weft/linear_system/make_linear_system.h"

#include "weft/linear_system/fast_linear_system.h"
#include "weft/linear_system/linear_system.h"

namespace weft {

std::unique_ptr<LinearSystemPath> make_linear_system(const ClothMesh& mesh, const ForceModel& model,
                                                     const LinearSystemOptions& options, int pinned_vertices) {
  if (options.kind == LinearSystemKind::kReference)
    return std::make_unique<ReferenceLinearSystem>(mesh, model, options);
  if (options.precision == MatrixPrecision::kFloat64)
    return std::make_unique<FastLinearSystem<double>>(mesh, model, options, pinned_vertices);
  return std::make_unique<FastLinearSystem<float>>(mesh, model, options, pinned_vertices);
}

}  // namespace weft
