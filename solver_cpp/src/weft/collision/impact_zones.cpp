#include "weft/collision/impact_zones.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "weft/common/timer.h"
#include "weft/common/union_find.h"

namespace weft {

namespace {
// The largest stretch of the map I + A: its largest singular value.
double largest_stretch(const Eigen::Matrix3d& a) {
  const Eigen::Matrix3d map = Eigen::Matrix3d::Identity() + a;
  const double largest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(map.transpose() * map,
                                                                          Eigen::EigenvaluesOnly).eigenvalues().maxCoeff();
  return std::sqrt(std::max(largest, 0.0));
}

// The largest s in [0, upper] (to bisection's precision) with largest_stretch(s a) <= limit. The
// norm of I + s a is convex in s and 1 at s = 0, so the s that satisfy it form an interval.
double stretch_scale(const Eigen::Matrix3d& a, double upper, double limit) {
  if (largest_stretch(upper * a) <= limit) return upper;
  double low = 0.0, high = upper;
  for (int k = 0; k < 40; ++k) {
    const double mid = 0.5 * (low + high);
    (largest_stretch(mid * a) <= limit ? low : high) = mid;
  }
  return low;
}
}  // namespace

int ImpactZones::resolve(CollisionStep& step, const ContactProperties& props, std::vector<int>& hits, int iterations,
                         const std::function<void(std::vector<int>&)>& redetect, CollisionTelemetry& frame) const {
  const int vertex_count = static_cast<int>(step.x->rows());
  const Positions& x = *step.x;
  Positions& v = *step.v;
  UnionFind zones(vertex_count);
  std::vector<char> in_zone(vertex_count, 0);
  // Body points the zones touched: (a cloth vertex of the pair, body point start, velocity).
  struct BodyReference {
    int cloth_vertex;
    Vec3 x, v;
  };
  std::vector<BodyReference> body_references;
  int zone_count = 0;
  // A zone that must move with two bodies moving apart (cloth caught between two legs) cannot
  // be made collision-free by any rigid or affine motion: its passes find as many colliding
  // pairs pass after pass. Once kStallPasses passes in a row found no fewer than the fewest so
  // far, the rest of the budget would be spent the same way: the pairs left are unresolved (the
  // caller halves the step, or GIA recovers what stays in intersection).
  size_t fewest = hits.size();
  int since_fewest = 0;
  for (int iteration = 0; iteration < iterations && !hits.empty() && since_fewest < kStallPasses; ++iteration) {
    const Timer timer;
    ++frame.iterations;
    for (int k : hits) {
      const FeaturePair& pair = step.pairs[k];
      int first = -1;
      for (int p : pair.point) {
        if (p < 0) continue;
        in_zone[p] = 1;
        step.changed[p] = 1;  // tested again whether or not its velocity changes
        if (first < 0) first = p; else zones.unite(first, p);
      }
      for (int p : pair.point)
        if (p < 0 && first >= 0)
          body_references.push_back({first, step.start_of(p, pair.body), step.velocity_of(p, pair.body)});
    }
    // Zone velocities. A zone held by kinematic references (its pinned vertices, and the body
    // velocities at the cloth vertices that touched a body) moves with the affine velocity field
    // that fits them best (least squares; minimum norm when they are fewer than four or
    // coplanar): one reference gives a translation, several on a rotating limb give its
    // rotation, so a zone pinned along a swinging limb can follow it. The body references are
    // the body vertices of the colliding pairs (their start positions and velocities), so a
    // zone caught on a rigidly moving body moves exactly with it. Other zones translate,
    // keeping their momentum.
    std::vector<Vec3> momentum(vertex_count, Vec3::Zero()), ref_sum(vertex_count, Vec3::Zero()),
        ref_point(vertex_count, Vec3::Zero());
    std::vector<double> mass(vertex_count, 0.0);
    std::vector<int> ref_count(vertex_count, 0);
    auto for_each_reference = [&](auto&& visit) {
      for (int i = 0; i < vertex_count; ++i) {
        if (!in_zone[i]) continue;
        const int r = zones.find(i);
        if (props.inverse_mass[i] == 0.0) visit(r, row3(x, i), Vec3(row3(v, i)));
      }
      for (const BodyReference& ref : body_references) visit(zones.find(ref.cloth_vertex), ref.x, ref.v);
    };
    for (int i = 0; i < vertex_count; ++i) {
      if (!in_zone[i] || props.inverse_mass[i] == 0.0) continue;
      const int r = zones.find(i);
      mass[r] += 1.0 / props.inverse_mass[i];
      momentum[r] += row3(v, i) / props.inverse_mass[i];
    }
    for_each_reference([&](int r, const Vec3& p, const Vec3& vp) {
      ref_point[r] += p;
      ref_sum[r] += vp;
      ++ref_count[r];
    });
    std::vector<Eigen::Matrix3d> spread(vertex_count, Eigen::Matrix3d::Zero()),
        moment(vertex_count, Eigen::Matrix3d::Zero());
    for_each_reference([&](int r, const Vec3& p, const Vec3& vp) {
      const Vec3 d = p - ref_point[r] / ref_count[r];
      spread[r] += d * d.transpose();
      moment[r] += (vp - ref_sum[r] / ref_count[r]) * d.transpose();
    });
    // The references' widest velocity spread about their mean, per zone: the affine field is
    // not extrapolated beyond it (a zone caught between two bodies that move differently, an arm
    // closing on the torso, has references millimetres apart with different velocities; their
    // fit's gradient, carried across centimetres of cloth, tore an edge to 9x its rest length).
    std::vector<double> reach(vertex_count, 0.0);
    for_each_reference([&](int r, const Vec3&, const Vec3& vp) {
      reach[r] = std::max(reach[r], (vp - ref_sum[r] / ref_count[r]).norm());
    });
    std::vector<Eigen::Matrix3d> gradient(vertex_count, Eigen::Matrix3d::Zero());
    zone_count = 0;
    for (int i = 0; i < vertex_count; ++i) {
      if (!in_zone[i] || zones.find(i) != i) continue;
      ++zone_count;
      if (ref_count[i] < 2) continue;
      // Pseudo-inverse of the references' spread (directions with no spread get no gradient).
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(spread[i]);
      const double cutoff = 1e-10 * std::max(eigen.eigenvalues().maxCoeff(), 1e-300);
      Eigen::Matrix3d inverse = Eigen::Matrix3d::Zero();
      for (int k = 0; k < 3; ++k)
        if (eigen.eigenvalues()[k] > cutoff)
          inverse += eigen.eigenvectors().col(k) * eigen.eigenvectors().col(k).transpose() / eigen.eigenvalues()[k];
      gradient[i] = moment[i] * inverse;
    }
    // The field stays affine: where it would carry a zone point faster than the references'
    // spread, the whole gradient is scaled down (not each point's deviation clipped, which bends
    // the field and moves the zone's points against each other). And h |G| <= 1/2, so the
    // step's map x -> x + t h (c + G (x - p)) keeps every orientation for t in [0, 1]: no
    // pair of the zone's own free cloth points can cross (gtest ABoundedZoneFieldStaysAffine).
    // And the map stretches no direction by more than kMaxZoneStretch: a zone whose references
    // move apart (cloth caught between two faces scissoring apart) would otherwise stretch all
    // of its cloth by up to half in each step (gtest AZoneFieldStretchesItsClothByATenthAtMost);
    // a rotating limb's field (skew: sqrt(1 + (h |omega|)^2), a thousandth at 5 rad/s and
    // 96 steps a second) passes.
    std::vector<double> largest(vertex_count, 0.0);
    for (int i = 0; i < vertex_count; ++i) {
      if (!in_zone[i] || props.inverse_mass[i] == 0.0) continue;
      const int r = zones.find(i);
      if (ref_count[r] < 2) continue;
      largest[r] = std::max(largest[r], (gradient[r] * (row3(x, i) - ref_point[r] / ref_count[r])).norm());
    }
    for (int i = 0; i < vertex_count; ++i) {
      if (!in_zone[i] || zones.find(i) != i || ref_count[i] < 2) continue;
      double scale = largest[i] > reach[i] ? reach[i] / largest[i] : 1.0;
      const double size = step.h * scale * gradient[i].norm();
      if (size > 0.5) scale *= 0.5 / size;
      scale = stretch_scale(step.h * gradient[i], scale, 1.0 + kMaxZoneStretch);
      if (scale < 1.0) gradient[i] *= scale;
    }
    for (int i = 0; i < vertex_count; ++i) {
      if (!in_zone[i] || props.inverse_mass[i] == 0.0) continue;
      const int r = zones.find(i);
      Vec3 vz;
      if (ref_count[r] > 0) {
        vz = ref_sum[r] / ref_count[r] + gradient[r] * (row3(x, i) - ref_point[r] / ref_count[r]);
      } else
        vz = momentum[r] / mass[r];
      // Only a velocity that changed (or a point of a pair that collided, above) makes its pairs
      // worth testing again: a pair whose points all kept their velocities since it was last
      // found clear is clear still. A zone that neither grew nor merged keeps its velocity
      // field, so its points are not re-queried pass after pass.
      if (vz == Vec3(row3(v, i))) continue;
      v.row(i) = vz.transpose();
      step.moved(i);
      step.changed[i] = 1;
    }
    frame.response_seconds += timer.seconds();
    hits.clear();
    redetect(hits);
    if (hits.size() < fewest) {
      fewest = hits.size();
      since_fewest = 0;
    } else {
      ++since_fewest;
    }
  }
  frame.impact_zones += zone_count;
  frame.unresolved += static_cast<int>(hits.size());
  return zone_count;
}

}  // namespace weft
