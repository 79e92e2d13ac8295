#include "weft/collision_system.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "weft/bodies/body_motion.h"
#include "weft/collision/impact_zones.h"
#include "weft/collision/proximity_response.h"
#include "weft/common/timer.h"
#include "weft/geometry/intersection_count.h"
#include "weft/gia/gia_body_driver.h"
#include "weft/gia/pinch_driver.h"

namespace weft {

namespace {

// The settings' per-face and per-body lists must match the cloth and the bodies.
CollisionSettings checked(CollisionSettings s, int face_count, size_t body_count) {
  auto check_size = [face_count](size_t size, const char* name) {
    if (size != 0 && size != static_cast<size_t>(face_count))
      throw std::invalid_argument(std::string("collision.") + name + " has " + std::to_string(size) +
                                  " entries, expected one per face (" + std::to_string(face_count) + ")");
  };
  check_size(s.face_collide.size(), "face_collide");
  check_size(s.face_self_collide.size(), "face_self_collide");
  check_size(s.face_thickness.size(), "face_thickness");
  check_size(s.face_friction.size(), "face_friction");
  if (!s.body_collide.empty() && s.body_collide.size() != body_count)
    throw std::invalid_argument("collision.body_collide must have one entry per body");
  if (!s.body_group.empty() && s.body_group.size() != body_count)
    throw std::invalid_argument("collision.body_group must have one entry per body");
  if (!s.body_offset.empty() && s.body_offset.size() != body_count)
    throw std::invalid_argument("collision.body_offset must have one entry per body");
  for (double offset : s.body_offset)
    if (!(offset >= 0.0 && std::isfinite(offset))) throw std::invalid_argument("collision.body_offset must be >= 0");
  return s;
}

ContactDetection make_detection(const CollisionSettings& s, const Faces& cloth_faces, const Positions& x,
                                const std::vector<KinematicBody>& bodies, const ContactProperties& props) {
  const int face_count = static_cast<int>(cloth_faces.rows());
  std::vector<char> face_collide = s.face_collide.empty() ? std::vector<char>(face_count, 1) : s.face_collide;
  std::vector<char> face_self = s.face_self_collide.empty() ? std::vector<char>(face_count, 0) : s.face_self_collide;
  const bool cloth_collides = std::any_of(face_collide.begin(), face_collide.end(), [](char c) { return c != 0; });
  std::vector<char> body_collide(bodies.size(), 0);
  for (size_t b = 0; b < bodies.size(); ++b)
    body_collide[b] = cloth_collides && (s.body_collide.empty() || s.body_collide[b]);
  // The margin covers the largest body offset too (a scene without offsets pays nothing).
  const double widest_offset = props.body_offset.empty() ? 0.0
                                                         : *std::max_element(props.body_offset.begin(), props.body_offset.end());
  std::vector<double> face_margin(face_count, 0.0);
  for (int f = 0; f < face_count; ++f)
    for (int c = 0; c < 3; ++c)
      face_margin[f] = std::max(face_margin[f], props.thickness[cloth_faces(f, c)] + widest_offset);
  return ContactDetection(cloth_faces, x, std::move(face_collide), std::move(face_self), std::move(face_margin),
                          bodies, body_collide, s.self_culling);
}

}  // namespace

// The GIA membranes and pinch regions, as the contact detection asks for them.
class CollisionSystem::Filter : public ContactFilter {
 public:
  explicit Filter(const CollisionSystem& s) : s_(s) {}
  bool skip_cloth_pair(int a, int b) const override { return s_.untangle_.skip_triangle_pair(a, b); }
  bool coloured(int p, int body) const override { return s_.gia_bodies_ && s_.gia_bodies_->coloured(p, body); }
  int body_face_colour(int f, int body) const override {
    return s_.gia_bodies_ ? s_.gia_bodies_->body_face_colour(f, body) : 0;
  }
  bool cloth_face_contour(int f, int body) const override {
    return s_.gia_bodies_ && s_.gia_bodies_->cloth_face_contour(f, body);
  }
  bool pinched_face(int f, int body) const override { return s_.pinch_ && s_.pinch_->face_in_region(f, body); }
  bool contour_corner(int p, int body) const override {
    return s_.gia_bodies_ && s_.gia_bodies_->contour_corner(p, body);
  }
  bool pinch_region(int body) const override { return s_.pinch_ && !s_.pinch_->no_region(body); }
  bool skips_nothing(int body) const override {
    if (body < 0) return !s_.untangle_.any() && !s_.untangle_.interlocked();
    return (!s_.gia_bodies_ || s_.gia_bodies_->clean(body)) && (!s_.pinch_ || s_.pinch_->no_region(body));
  }

 private:
  const CollisionSystem& s_;
};

void CollisionSystem::set_threads(int threads) {
  threads_ = std::max(threads, 1);
  detection_.set_threads(threads_);
  ccd_.set_threads(threads_);
  if (pinch_) pinch_->set_threads(threads_);
}

void CollisionSystem::release_pins(const std::vector<int>& vertices, const std::vector<double>& vertex_mass) {
  for (int vertex : vertices) props_.inverse_mass[vertex] = 1.0 / vertex_mass[vertex];
}

CollisionSystem::CollisionSystem(const Faces& cloth_faces, const Positions& x, const std::vector<double>& vertex_mass,
                                 const std::vector<int>& pinned_vertices, const std::vector<KinematicBody>& bodies,
                                 CollisionSettings settings, int threads,
                                 const std::vector<std::array<double, 3>>& face_rest_lengths)
    : settings_(checked(std::move(settings), static_cast<int>(cloth_faces.rows()), bodies.size())),
      threads_(std::max(threads, 1)),
      props_(ContactProperties::from_faces(cloth_faces, settings_.face_thickness, settings_.face_friction, vertex_mass,
                                           pinned_vertices, settings_.body_offset)),
      detection_(make_detection(settings_, cloth_faces, x, bodies, props_)), ccd_(threads_) {
  detection_.set_threads(threads_);
  const int vertex_count = static_cast<int>(x.rows());
  step_.body_start.resize(bodies.size());
  step_.body_end.resize(bodies.size());
  // GIA switch: -1 (auto) is on wherever collisions are: GIA is the net that recovers cloth a
  // pinch or an exhausted fail-safe left in intersection, and it runs only in steps that may
  // start in intersection (gia_due_: the first, and after a frame or step that left some), so a
  // clean shot pays one analysis and moves bit for bit as without it. Body/body pinch tracking
  // (every step) only when asked for or when two bodies meet (settings.gia 1, decided by the
  // caller from the animation).
  gia_ = settings_.gia != 0;
  if (gia_ && detection_.any_self()) untangle_ = ClothUntangling(detection_.cloth_faces(), detection_.face_self(), vertex_count);
  if (gia_) gia_bodies_ = std::make_unique<GiaBodyDriver>(detection_, vertex_count);
  std::vector<int> pinch_bodies;
  for (size_t b = 0; b < detection_.bodies().size(); ++b)
    if (detection_.bodies()[b].collide) pinch_bodies.push_back(static_cast<int>(b));
  // Pairs of parts of one character are tracked by their facing gap (part_gap.h) whenever GIA
  // is on or auto: parts of a character move against each other in every shot that has one.
  PinchTracking tracking;
  tracking.group = settings_.body_group;
  tracking.body_pairs = settings_.gia > 0 && settings_.body_pinch;
  tracking.part_gap = gia_ && settings_.part_pinch ? 2.0 * props_.default_thickness : 0.0;
  tracking.body_offset = settings_.body_offset;
  if ((tracking.body_pairs || tracking.part_gap > 0.0) && pinch_bodies.size() >= 2) {
    pinch_ = std::make_unique<PinchDriver>(pinch_bodies, static_cast<int>(bodies.size()), vertex_count, threads_,
                                           tracking);
    if (pinch_->tracker().pairs().empty()) pinch_.reset();  // nothing to track
  }
  filter_ = std::make_unique<Filter>(*this);
  body_closed_.resize(bodies.size());
  for (size_t b = 0; b < bodies.size(); ++b) body_closed_[b] = closed_surface(bodies[b].faces());
  if (!face_rest_lengths.empty()) strain_limit_ = StrainLimit(cloth_faces, face_rest_lengths, settings_.max_strain);
  // A shot (or a resumed run) that starts in intersection starts with the impulses alone, as
  // after a frame whose exact count was not zero. The cloth/cloth analysis of the first step
  // runs only where the count found cloth/cloth intersections: with none it would colour
  // nothing and pull nothing (the count's culled candidates drop only patches that provably
  // cannot touch themselves), yet it costs a whole-mesh analysis (75 ms on a 4k sheet).
  if (gia_ && settings_.count_intersections) {
    int cloth_cloth = 0;
    const int found = count_intersections(x, bodies, &cloth_cloth);
    if (settings_.contact_constraints) contacts_aside_ = found > 0;
    self_due_ = cloth_cloth > 0;
  }
}

CollisionSystem::~CollisionSystem() = default;

std::vector<std::uint8_t> CollisionSystem::analysis_flags() const {
  const size_t bodies = detection_.bodies().size();
  std::vector<std::uint8_t> out{static_cast<std::uint8_t>(gia_due_), static_cast<std::uint8_t>(self_due_),
                                static_cast<std::uint8_t>(gia_all_bodies_), static_cast<std::uint8_t>(contacts_aside_)};
  for (size_t b = 0; b < bodies; ++b) out.push_back(b < gia_watch_.size() && gia_watch_[b] ? 1 : 0);
  return out;
}

void CollisionSystem::check_analysis_flags(const std::vector<std::uint8_t>& flags) const {
  if (flags.empty()) return;
  const size_t bodies = detection_.bodies().size();
  if (flags.size() != 4 + bodies)
    throw std::invalid_argument("collision_flags must be empty or have 4 + one entry per body (" +
                                std::to_string(4 + bodies) + "), not " + std::to_string(flags.size()));
  for (std::uint8_t f : flags)
    if (f > 1) throw std::invalid_argument("collision_flags entries must be 0 or 1");
}

void CollisionSystem::set_analysis_flags(const std::vector<std::uint8_t>& flags) {
  check_analysis_flags(flags);
  if (flags.empty()) return;
  gia_due_ = flags[0] != 0;
  self_due_ = flags[1] != 0;
  gia_all_bodies_ = flags[2] != 0;
  contacts_aside_ = flags[3] != 0;
  aside_local_ = false;  // what a frame end leaves (end_frame); aside_ is looked at only when set
  gia_watch_.assign(flags.begin() + 4, flags.end());
}

const BodyPinchTracker* CollisionSystem::pinch() const { return pinch_ ? &pinch_->tracker() : nullptr; }

void CollisionSystem::body_positions(const std::vector<KinematicBody>& bodies, double alpha0, double alpha1) {
  for (size_t b = 0; b < detection_.bodies().size(); ++b) {
    if (!detection_.bodies()[b].collide) continue;
    bodies[b].positions_at(alpha0, step_.body_start[b]);
    bodies[b].positions_at(alpha1, step_.body_end[b]);
  }
}

void CollisionSystem::constrain_contacts(const Positions& x, const Positions& v, double h,
                                         const std::vector<KinematicBody>& bodies, double alpha0, double alpha1,
                                         ConstraintFilter& filter) {
  constraints_.clear();
  if (!settings_.contact_constraints || !detection_.any_body()) return;
  // While the cloth is in intersection (the last analysis or frame-end count found some, a step
  // left pairs unresolved or ran pairs without CCD) or two bodies pinch it, GIA's membranes,
  // recovery and grip decide and CCD is off in places: a constraint holding cloth against a
  // body there (and its friction) could lock a tangle. The impulses take over until the state
  // is clean again.
  // Within a frame only the cloth at the trouble is set aside (aside_local_, mark_aside): a
  // pinch between parts of one character (an arm along the torso) squeezes a few vertices of a
  // garment held against the whole body by its constraints; a skirt's fold left tangled or
  // unresolved is a patch of a garment that rests on the body elsewhere. A pinch between two
  // bodies sets all cloth aside, and so does a frame that ended in intersection for the next
  // frame's first step (what a run resumed there sees).
  if ((contacts_aside_ || (pinch_ && pinch_->engaged_pairs() > 0)) && !aside_local_) {
    constraints_.forget();
    return;
  }
  body_positions(bodies, alpha0, alpha1);
  constraints_.constrain(x, v, h, step_, detection_, props_, filter, frame_, aside_local_ ? &aside_ : nullptr);
}

void CollisionSystem::mark_aside(const std::vector<int>& unresolved_vertices) {
  const Faces& faces = detection_.cloth_faces();
  const auto vertex_count = static_cast<size_t>(step_.x->rows());
  aside_.assign(vertex_count, 0);
  // The corners of the cloth faces in a pinch region or with a vertex coloured inside a body.
  // Around them, the faces with a vertex marked in `around`: faces piercing a body (a rim cutting
  // the cloth with every vertex outside it), tangled with other cloth, or a cloth vertex of a
  // pair left unresolved.
  std::vector<char> around(vertex_count, 0);
  bool any_around = false;
  for (int b : detection_.colliding()) {
    const bool no_region = !pinch_ || pinch_->no_region(b);
    if (no_region && (!gia_bodies_ || gia_bodies_->clean(b))) continue;  // nothing to set aside
    for (int f = 0; f < faces.rows(); ++f) {
      const bool pinched = !no_region && pinch_->face_in_region(f, b);
      bool coloured = false;
      for (int k = 0; k < 3 && gia_bodies_ && !coloured; ++k) coloured = gia_bodies_->coloured(faces(f, k), b);
      if (pinched || coloured)
        for (int k = 0; k < 3; ++k) aside_[faces(f, k)] = 1;
      if (gia_bodies_ && gia_bodies_->cloth_face_contour(f, b)) {
        for (int k = 0; k < 3; ++k) around[faces(f, k)] = 1;
        any_around = true;
      }
    }
  }
  if (untangle_.any())
    for (int f = 0; f < faces.rows(); ++f)
      if (untangle_.tangled_face(f)) {
        for (int k = 0; k < 3; ++k) around[faces(f, k)] = 1;
        any_around = true;
      }
  for (int p : unresolved_vertices) {
    around[p] = 1;
    any_around = true;
  }
  if (!any_around) return;
  for (int f = 0; f < faces.rows(); ++f)
    if (around[faces(f, 0)] || around[faces(f, 1)] || around[faces(f, 2)])
      for (int k = 0; k < 3; ++k) aside_[faces(f, k)] = 1;
}

void CollisionSystem::redetect(std::vector<int>& hits) {
  detection_.collect_changed(step_, *filter_, frame_);
  ccd_.pass(step_, props_, false, &hits, true, frame_);
}

void CollisionSystem::spread_friction(const Positions& x, Positions& v, double h) {
  // Only the friction of contacts sliding less than kSpreadSlide thicknesses over the step:
  // cloth carried by its body (a garment on a swinging leg). Friction from a body sweeping past
  // the cloth (a thin limb at metres per second) stays on the vertex, so the cloth slides round
  // the body instead of being carried by it (docs/collisions.md, twenty-fourth and thirty-fifth
  // sessions).
  const auto vertex_count = static_cast<size_t>(x.rows());
  friction_spread_.clear();
  for (const ContactConstraints::FrictionChange& c : constraints_.friction_changes())
    if (c.slide < kSpreadSlide * props_.thickness[c.vertex] && props_.inverse_mass[c.vertex] > 0.0)
      friction_spread_.push_back(&c);
  if (friction_spread_.empty()) return;
  friction_end_change_.assign(vertex_count, Vec3::Zero());
  for (const ContactConstraints::FrictionChange* c : friction_spread_)
    friction_end_change_[static_cast<size_t>(c->vertex)] += h * c->change;
  if (!strain_limit_.lengthened_beyond(step_, friction_end_change_)) return;
  // Undone on the vertices alone, passed to the cloth as the impulses they were.
  friction_impulse_.setZero(3 * x.rows());
  for (const ContactConstraints::FrictionChange* c : friction_spread_) {
    friction_impulse_.segment<3>(3 * c->vertex) += c->change / props_.inverse_mass[c->vertex];
    v.row(c->vertex) -= c->change.transpose();
  }
  friction_response_(friction_impulse_, friction_velocity_);
  if (friction_velocity_.size() != 3 * x.rows() || !friction_velocity_.allFinite()) {
    // No usable response (a system the solve could not handle): friction on the vertices alone.
    for (const ContactConstraints::FrictionChange* c : friction_spread_) v.row(c->vertex) += c->change.transpose();
    return;
  }
  for (Eigen::Index i = 0; i < x.rows(); ++i) v.row(i) += friction_velocity_.segment<3>(3 * i).transpose();
  step_.x_end = x + h * v;
  ++frame_.friction_spreads;
}

void CollisionSystem::respond(const Positions& x, Positions& v, double h, const std::vector<KinematicBody>& bodies,
                              double alpha0, double alpha1) {
  step_.begin(x, v, h);
  step_.sharp_edges = constraints_.sharp_edges();
  abandoned_ = false;
  body_positions(bodies, alpha0, alpha1);
  constraints_.friction(step_, props_);
  if (friction_response_ && strain_limit_.enabled()) spread_friction(x, v, h);
  if (pinch_)
    pinch_->update(step_, detection_, props_.default_thickness, gia_due_, frame_,
                   gia_all_bodies_ ? nullptr : &gia_watch_);
  const int unresolved_before = frame_.unresolved;
  bool tangled = false;
  if (gia_ && gia_due_) {
    const std::vector<char>* only = nullptr;
    if (!gia_all_bodies_) {
      gia_only_.assign(detection_.bodies().size(), 0);
      for (size_t b = 0; b < gia_only_.size(); ++b)
        gia_only_[b] = gia_watch_[b] || (pinch_ && pinch_->marks_faces(static_cast<int>(b)));
      only = &gia_only_;
    }
    tangled = gia_bodies_->colour(step_, threads_, frame_, only);
    gia_bodies_->recover(step_, props_, pinch_.get(), frame_);
    if (detection_.any_self() && self_due_) {
      // Cloth/cloth GIA: analyse, then pull crossing edges back through.
      const Timer timer;
      untangle_.analyse(x, threads_);
      frame_.gia_self_coloured_vertices = std::max(frame_.gia_self_coloured_vertices, untangle_.coloured_count());
      frame_.gia_self_paths = std::max(frame_.gia_self_paths, untangle_.path_count());
      if (untangle_.pull(x, v, h, props_.inverse_mass, props_.thickness) > 0) step_.x_end = x + h * v;
      frame_.gia_seconds += timer.seconds();
      tangled = tangled || untangle_.any();
    } else {
      untangle_.clear();
    }
  } else if (gia_) {
    gia_bodies_->clear();
    untangle_.clear();
  }
  step_.clear_vertices = constraints_.clear_vertices();
  detection_.collect(step_, *filter_, frame_, false);
  step_.clear_vertices = nullptr;
  ProximityResponse().apply(step_, props_, frame_, threads_);
  if (strain_limit_.enabled()) {
    const Timer timer;
    const bool any_stuck = constraints_.any_stuck();
    if (any_stuck) velocity_before_limit_ = v;
    const std::vector<Vec3>* held_normals = nullptr;  // cloth the contact constraints held slides along the body
    if (!constraints_.empty()) {
      constraints_.contact_normals(static_cast<int>(x.rows()), contact_normals_);
      held_normals = &contact_normals_;
    }
    frame_.strain_limited_edges += strain_limit_.apply(step_, props_, held_normals);
    // Friction holds no cloth beyond the strain limit: a sticking vertex the limit moved slides.
    if (any_stuck) constraints_.unstick_changed(velocity_before_limit_, v);
    frame_.response_seconds += timer.seconds();
  }
  step_.pairs.clear();
  bool cloth_pairs_unresolved = false;
  std::vector<int> unresolved_vertices;  // cloth vertices of the pairs left unresolved
  if (settings_.ccd) {
    int& iteration = step_.ccd_iteration;
    for (iteration = 0; iteration < settings_.ccd_iterations; ++iteration) {
      // Later passes re-test only pairs with a vertex whose velocity changed: only those pairs
      // are looked for (collect_changed), around the changed faces.
      if (iteration == 0)
        detection_.collect(step_, *filter_, frame_, true);
      else
        detection_.collect_changed(step_, *filter_, frame_);
      ++frame_.iterations;
      if (ccd_.pass(step_, props_, true, nullptr, iteration > 0, frame_) == 0) break;
      if (abandon_test_ && abandon_test_(step_.x_end)) {
        abandoned_ = true;
        step_.end();
        return;
      }
    }
    if (iteration == settings_.ccd_iterations) {
      std::vector<int> hits;
      redetect(hits);
      if (!hits.empty())
        ImpactZones().resolve(step_, props_, hits,
                              zone_pass_limit_ > 0 ? std::min(zone_pass_limit_, settings_.zone_iterations)
                                                   : settings_.zone_iterations,
                              [this](std::vector<int>& found) { redetect(found); }, frame_);
      cloth_pairs_unresolved =
          std::any_of(hits.begin(), hits.end(), [this](int k) { return step_.pairs[k].body < 0; });
      for (int k : hits)
        for (int p : step_.pairs[k].point)
          if (p >= 0) unresolved_vertices.push_back(p);  // body vertices are numbered below zero
    }
  }
  auto skips_ccd = [](const std::vector<FeaturePair>& list) {
    return std::any_of(list.begin(), list.end(), [](const FeaturePair& p) { return !p.ccd; });
  };
  const bool ccd_skipped = !settings_.ccd || skips_ccd(step_.proximity_pairs) || skips_ccd(step_.pairs);
  const bool unresolved_now = frame_.unresolved > unresolved_before;
  contacts_aside_ = tangled || ccd_skipped || unresolved_now;
  // A pinch between two bodies (not parts of one character) still sets all aside: its squeezed
  // cloth spreads beyond the region's box (the regression box pinch ended in intersection when
  // the cloth around the region kept its constraints).
  const bool body_pinch = pinch_ && pinch_->engaged_pairs() > pinch_->engaged_part_pairs();
  aside_local_ = contacts_aside_ && settings_.local_aside && settings_.ccd && !body_pinch;
  if (aside_local_) mark_aside(unresolved_vertices);
  gia_due_ = contacts_aside_ || (pinch_ && pinch_->engaged_pairs() > 0);
  // Cloth/cloth intersection can only have been created where CCD did not vouch for a
  // cloth/cloth pair: none of them left unresolved, no untangling under way, CCD on.
  self_due_ = untangle_.any() || untangle_.interlocked() || cloth_pairs_unresolved || !settings_.ccd;
  gia_all_bodies_ = unresolved_now || !settings_.ccd || untangle_.any();
  gia_watch_.assign(detection_.bodies().size(), 0);
  if (gia_)
    for (size_t b = 0; b < gia_watch_.size(); ++b) {
      const int body = static_cast<int>(b);
      gia_watch_[b] = (pinch_ && pinch_->marks_faces(body)) || gia_bodies_->intersects(body);
    }
  step_.end();
}

int CollisionSystem::count_intersections(const Positions& x, const std::vector<KinematicBody>& bodies,
                                         int* cloth_cloth) {
  int total = 0;
  const Faces& faces = detection_.cloth_faces();
  // Self-candidates first: they refit the cloth tree without margin, which the body pairs use.
  if (detection_.any_self()) {
    const int self = count_self_intersections_among(x, faces, detection_.self_intersection_candidates(x),
                                                    detection_.face_self(), threads_);
    if (cloth_cloth) *cloth_cloth = self;
    total += self;
  } else
    detection_.refit_cloth(x, x, 0.0);
  for (size_t b = 0; b < detection_.bodies().size(); ++b) {
    if (!detection_.bodies()[b].collide) continue;
    const Positions& body_x = bodies[b].frame_end();
    total += count_intersections_among(x, faces, body_x, detection_.bodies()[b].faces,
                                       detection_.body_pairs(static_cast<int>(b), body_x, body_x),
                                       detection_.face_collide(), threads_);
  }
  return total;
}

int CollisionSystem::motion_halvings(const Positions& x, const Positions& v, const std::vector<KinematicBody>& bodies,
                                     int substeps, double frame_duration, int max_halvings) const {
  std::vector<BodyMotion> motions(bodies.size());
  for (size_t b = 0; b < bodies.size(); ++b) {
    if (!detection_.bodies()[b].collide || !body_closed_[b]) continue;
    motions[b] = {&bodies[b].frame_start(), &bodies[b].frame_end(),
                  body_thickness(bodies[b].frame_start(), bodies[b].faces())};
  }
  const double widest_offset =
      props_.body_offset.empty() ? 0.0 : *std::max_element(props_.body_offset.begin(), props_.body_offset.end());
  const double band = kContactBand * (props_.default_thickness + widest_offset);
  const Faces& faces = detection_.cloth_faces();
  double longest = 0.0;
  for (int f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      longest = std::max(longest, (Vec3(row3(x, faces(f, k))) - Vec3(row3(x, faces(f, (k + 1) % 3)))).squaredNorm());
  return weft::motion_halvings(x, v, band, std::sqrt(longest), motions, substeps, frame_duration, max_halvings);
}

CollisionTelemetry CollisionSystem::end_frame(const Positions& x, const std::vector<KinematicBody>& bodies) {
  if (settings_.count_intersections) {
    const Timer timer;
    int cloth_cloth = 0;
    frame_.intersections = count_intersections(x, bodies, &cloth_cloth);
    if (cloth_cloth > 0) self_due_ = true;
    if (frame_.intersections > 0) gia_due_ = gia_all_bodies_ = true;
    contacts_aside_ = frame_.intersections > 0;  // what a run resumed at this frame sees too
    aside_local_ = false;
    frame_.intersection_seconds += timer.seconds();
  }
  return frame_;
}

}  // namespace weft
