#include "weft/collision/strain_limit.h"

#include <algorithm>
#include <map>

namespace weft {

namespace {

// A held vertex's move without its part into the body whose outward normal is n (zero: none).
void along_body(Vec3& move, const Vec3& n) {
  const double into = move.dot(n);
  if (into < 0.0) move -= into * n;
}

}  // namespace

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

double StrainLimit::allowed_length(size_t k, const Positions& x) const {
  const double start_length = (row3(x, edges_[k][1]) - row3(x, edges_[k][0])).norm();
  return limit_[k] + kKeptExcess * std::max(start_length - limit_[k], 0.0);
}

bool StrainLimit::lengthened_beyond(const CollisionStep& step, const std::vector<Vec3>& end_change) const {
  const Positions& x = *step.x;
  for (size_t k = 0; k < edges_.size(); ++k) {
    const int i = edges_[k][0], j = edges_[k][1];
    const Vec3& ci = end_change[static_cast<size_t>(i)];
    const Vec3& cj = end_change[static_cast<size_t>(j)];
    if (ci == Vec3::Zero() && cj == Vec3::Zero()) continue;
    const Vec3 after = row3(step.x_end, j) - row3(step.x_end, i);
    const double length = after.norm();
    const double allowed = allowed_length(k, x);
    if (length > allowed && length > (after - cj + ci).norm()) return true;
  }
  return false;
}

int StrainLimit::apply(CollisionStep& step, const ContactProperties& props,
                       const std::vector<Vec3>* contact_normals) const {
  int corrections = 0;
  const Positions& x = *step.x;
  // Allowed length per edge: fixed for the step (it depends on the start positions only).
  std::vector<double> allowed(edges_.size());
  for (size_t k = 0; k < edges_.size(); ++k) allowed[k] = allowed_length(k, x);
  // The last pass in which each vertex moved (-1: not yet). After pass 0 an edge whose ends
  // did not move in this pass or the one before is as the previous pass left it: within limit.
  std::vector<int> moved_in_pass(static_cast<size_t>(x.rows()), -1);
  for (int pass = 0; pass < passes_; ++pass) {
    int pass_corrections = 0;
    for (size_t k = 0; k < edges_.size(); ++k) {
      const int i = edges_[k][0], j = edges_[k][1];
      if (pass > 0 && moved_in_pass[i] < pass - 1 && moved_in_pass[j] < pass - 1) continue;
      const double wi = props.inverse_mass[i], wj = props.inverse_mass[j];
      if (wi + wj == 0.0) continue;
      const Vec3 d = row3(step.x_end, j) - row3(step.x_end, i);
      const double length = d.norm();
      if (!(length > allowed[k])) continue;
      const Vec3 shift = (length - (1.0 - kStrainLimitSlack) * allowed[k]) / length * d;
      Vec3 move_i = (wi / (wi + wj)) * shift, move_j = -(wj / (wi + wj)) * shift;
      if (contact_normals) {
        along_body(move_i, (*contact_normals)[static_cast<size_t>(i)]);
        along_body(move_j, (*contact_normals)[static_cast<size_t>(j)]);
      }
      step.x_end.row(i) += move_i.transpose();
      step.x_end.row(j) += move_j.transpose();
      for (int p : {i, j}) {
        step.v->row(p) = (step.x_end.row(p) - x.row(p)) / step.h;
        step.moved(p);
        step.changed[p] = 1;
        moved_in_pass[p] = pass;
      }
      ++pass_corrections;
    }
    corrections += pass_corrections;
    if (pass_corrections == 0) break;
  }
  return corrections;
}

}  // namespace weft
