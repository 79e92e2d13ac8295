// Transient force elements (the seed's TFEs): two-particle elements that come and go between
// steps (contact springs, toggled user springs). Callers add them each step through this API;
// the fast linear system assembles them with per-thread row accumulators, reduces each touched
// row in parallel in a fixed order (element order, so the sums do not depend on the thread
// count), moves entries that land on the fixed pattern into it, and keeps the rest in the
// transient part of the block matrix (32-bit columns).
#pragma once

#include <vector>

#include "weft/common/types.h"

namespace weft {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

struct TransientElement {
  int i, j;           // particles (original numbering), i != j
  Vec6 force;         // on i (0..2) and j (3..5)
  Mat6 stiffness;     // -dF/dx, symmetric
  Mat6 damping;       // -dF/dv, symmetric
};

class TransientElements {
 public:
  void clear() { elements_.clear(); }
  void add(int i, int j, const Vec6& force, const Mat6& stiffness, const Mat6& damping);
  // A spring between i and j: force f on i (-f on j), stiffness block k and damping block d
  // (3x3, symmetric) so that -dF/dx = [k -k; -k k] and -dF/dv = [d -d; -d d].
  void add_spring(int i, int j, const Vec3& force_on_i, const Mat3& k, const Mat3& d);
  const std::vector<TransientElement>& elements() const { return elements_; }
  bool empty() const { return elements_.empty(); }

 private:
  std::vector<TransientElement> elements_;
};

// The reduced transient contributions to A = M + h D + h^2 K and b = h (f - h K v), by row of the
// system numbering (new_of_old maps particles to rows).
struct TransientRows {
  std::vector<int> rows;      // touched rows, ascending
  std::vector<int> start;     // rows.size() + 1 ranges into columns/blocks
  std::vector<int> columns;   // ascending within a row
  std::vector<Mat3> blocks;
  std::vector<Vec3> rhs;      // one per touched row
  std::vector<int> slot;      // row -> index into rows, or -1 (size: row count, once any were touched)
};

void reduce_transient(const TransientElements& elements, const std::vector<int>& new_of_old, const Positions& v,
                      double h, int threads, TransientRows& out);

}  // namespace weft
