#include "weft/collision/strain_limit.h"

#include <algorithm>
#include <map>

namespace weft {

StrainLimit::StrainLimit(const Faces& faces, const std::vector<std::array<double, 3>>& face_rest_lengths,
                         double max_strain, int passes)
    : passes_(passes) {
  if (!(max_strain > 1.0)) return;
  std::map<std::array<int, 2>, double> rest;  // ordered: a fixed edge order for Gauss-Seidel
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = faces(f, c), b = faces(f, (c + 1) % 3);
      const std::array<int, 2> key = {std::min(a, b), std::max(a, b)};
      const double length = face_rest_lengths[f][c];
      auto [it, inserted] = rest.emplace(key, length);
      if (!inserted) it->second = std::min(it->second, length);  // shared edge: the shorter rest
    }
  edges_.reserve(rest.size());
  limit_.reserve(rest.size());
  for (const auto& [edge, length] : rest) {
    if (!(length > 0.0)) continue;
    edges_.push_back(edge);
    limit_.push_back(max_strain * length);
  }
}

int StrainLimit::apply(CollisionStep& step, const ContactProperties& props) const {
  int corrections = 0;
  const Positions& x = *step.x;
  for (int pass = 0; pass < passes_; ++pass) {
    int pass_corrections = 0;
    for (size_t k = 0; k < edges_.size(); ++k) {
      const int i = edges_[k][0], j = edges_[k][1];
      const double wi = props.inverse_mass[i], wj = props.inverse_mass[j];
      if (wi + wj == 0.0) continue;
      const Vec3 d = row3(step.x_end, j) - row3(step.x_end, i);
      const double length = d.norm();
      const double start_length = (row3(x, j) - row3(x, i)).norm();
      const double allowed = limit_[k] + kKeptExcess * std::max(start_length - limit_[k], 0.0);
      if (!(length > allowed)) continue;
      const Vec3 shift = (length - allowed) / length * d;
      step.x_end.row(i) += (wi / (wi + wj)) * shift.transpose();
      step.x_end.row(j) -= (wj / (wi + wj)) * shift.transpose();
      for (int p : {i, j}) {
        step.v->row(p) = (step.x_end.row(p) - x.row(p)) / step.h;
        step.moved(p);
        step.changed[p] = 1;
      }
      ++pass_corrections;
    }
    corrections += pass_corrections;
    if (pass_corrections == 0) break;
  }
  return corrections;
}

}  // namespace weft
