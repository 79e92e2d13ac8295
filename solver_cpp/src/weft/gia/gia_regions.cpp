#include "weft/gia/gia_regions.h"

#include <algorithm>

namespace weft {

std::vector<double> lumped_vertex_area(const Positions& x, const Faces& f) {
  std::vector<double> area(x.rows(), 0.0);
  for (int t = 0; t < f.rows(); ++t) {
    const Vec3 a = row3(x, f(t, 0)), b = row3(x, f(t, 1)), c = row3(x, f(t, 2));
    const double third = (b - a).cross(c - a).norm() / 6.0;
    for (int k = 0; k < 3; ++k) area[f(t, k)] += third;
  }
  return area;
}

std::vector<int> odd_crossed_edges(const GiaResult& r, const std::vector<int>& hits, int m) {
  std::vector<int> crossed;
  for (int h : hits)
    if (r.hits[h].edge_mesh == m) crossed.push_back(r.hits[h].edge);
  std::sort(crossed.begin(), crossed.end());
  std::vector<int> walls;
  for (size_t i = 0; i < crossed.size();) {
    size_t j = i;
    while (j < crossed.size() && crossed[j] == crossed[i]) ++j;
    if ((j - i) % 2 == 1) walls.push_back(crossed[i]);
    i = j;
  }
  return walls;
}

}  // namespace weft
