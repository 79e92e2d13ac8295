#include "weft/collision/sweep_frame.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace weft {

Vec3 SweepFrame::shift(const Positions& body_start, const Positions& body_end, const Aabb& reach, const Positions& x,
                       const Positions& x_end, double least) {
  near_.clear();
  for (int v = 0; v < static_cast<int>(x.rows()); ++v)
    if (reach.contains(row3(x, v))) near_.push_back(v);
  return median(&body_start, &body_end, x, x_end, least);
}

Vec3 SweepFrame::shift(const Positions& x, const Positions& x_end, double least) {
  near_.resize(static_cast<size_t>(x.rows()));
  std::iota(near_.begin(), near_.end(), 0);
  return median(nullptr, nullptr, x, x_end, least);
}

Vec3 SweepFrame::median(const Positions* body_start, const Positions* body_end, const Positions& x,
                        const Positions& x_end, double least) {
  const int body_count = body_start ? static_cast<int>(body_start->rows()) : 0;
  Vec3 shift;
  // Non-finite displacements (which the step reports elsewhere) take no part: the median is
  // over the finite ones, so no box is shifted by something that would fail every overlap test.
  auto add = [this](double d) {
    if (std::isfinite(d)) displaced_.push_back(d);
  };
  for (int axis = 0; axis < 3; ++axis) {
    displaced_.clear();
    for (int v = 0; v < body_count; ++v) add((*body_end)(v, axis) - (*body_start)(v, axis));
    for (int v : near_) add(x_end(v, axis) - x(v, axis));
    if (displaced_.empty()) return Vec3::Zero();
    const auto middle = displaced_.begin() + static_cast<std::ptrdiff_t>(displaced_.size() / 2);
    std::nth_element(displaced_.begin(), middle, displaced_.end());
    shift[axis] = *middle;
  }
  if (shift.cwiseAbs().maxCoeff() <= least) return Vec3::Zero();
  return shift;
}

}  // namespace weft
