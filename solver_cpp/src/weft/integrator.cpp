#include "weft/integrator.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <string>

#include "weft/common/ordered_sum.h"
#include "weft/common/timer.h"
#include "weft/linear_system/make_linear_system.h"

namespace weft {

namespace {
// Kinetic friction spread through the cloth (CollisionSystem::spread_friction_with): the
// response solve stops at this relative residual or after this many CG iterations. It only has
// to carry each held vertex's drag to its neighbours; what it leaves unconverged stays on the
// vertices, as friction without the spread would.
constexpr double kFrictionResponseTolerance = 1e-2;
constexpr int kFrictionResponseIterations = 8;

std::vector<double> to_std(const VectorX& v) { return {v.data(), v.data() + v.size()}; }

void require_rows(const VectorX& v, Eigen::Index n, const char* name) {
  if (v.size() != n)
    throw std::invalid_argument(std::string(name) + " has " + std::to_string(v.size()) + " entries, expected " +
                                std::to_string(n) + " (one per face)");
}
}  // namespace

Simulation::Simulation(const SimulationSetup& s)
    : settings_(s.solver), mesh_(build_cloth_mesh(static_cast<int>(s.positions.rows()), s.faces, s.face_uv,
                                                   s.rest_positions)) {
  const int n = mesh_.vertex_count;
  const Eigen::Index face_count = s.faces.rows();
  require_rows(s.face_density, face_count, "face_density");
  require_rows(s.face_stretch_warp, face_count, "face_stretch_warp");
  require_rows(s.face_stretch_weft, face_count, "face_stretch_weft");
  require_rows(s.face_shear, face_count, "face_shear");
  require_rows(s.face_bend, face_count, "face_bend");
  require_rows(s.face_damping, face_count, "face_damping");
  if (settings_.threads < 1) throw std::invalid_argument("solver.threads must be at least 1");
  if (!(settings_.max_step_strain == 0.0 || (settings_.max_step_strain > 1.0 && std::isfinite(settings_.max_step_strain))))
    throw std::invalid_argument("solver.max_step_strain must be 0 (off) or a finite number above 1");
  if (!(settings_.cg_tolerance > 0.0)) throw std::invalid_argument("solver.cg_tolerance must be positive");
  if (settings_.cg_max_iterations < 1) throw std::invalid_argument("solver.cg_max_iterations must be at least 1");

  ClothMaterials materials;
  materials.face_stretch_warp = to_std(s.face_stretch_warp);
  materials.face_stretch_weft = to_std(s.face_stretch_weft);
  materials.face_shear = to_std(s.face_shear);
  materials.face_damping = to_std(s.face_damping);
  if (s.face_stretch_knee.size() != 0 || s.face_stretch_ratio.size() != 0) {
    require_rows(s.face_stretch_knee, face_count, "face_stretch_knee");
    require_rows(s.face_stretch_ratio, face_count, "face_stretch_ratio");
    materials.face_stretch_knee = to_std(s.face_stretch_knee);
    materials.face_stretch_ratio = to_std(s.face_stretch_ratio);
  }
  materials.hinge_bend.resize(mesh_.hinges.size());
  for (size_t h = 0; h < mesh_.hinges.size(); ++h)
    materials.hinge_bend[h] = 0.5 * (s.face_bend[mesh_.hinge_faces[h][0]] + s.face_bend[mesh_.hinge_faces[h][1]]);
  materials.vertex_mass.assign(n, 0.0);
  for (Eigen::Index f = 0; f < face_count; ++f)
    for (int c = 0; c < 3; ++c) materials.vertex_mass[s.faces(f, c)] += s.face_density[f] * mesh_.rest_area[f] / 3.0;
  for (int i = 0; i < n; ++i)
    if (!(materials.vertex_mass[i] > 0.0))
      throw std::invalid_argument("vertex " + std::to_string(i) + " has no mass (it belongs to no face)");
  force_model_ = std::make_unique<ForceModel>(mesh_, std::move(materials), s.environment);

  if (s.body_faces.size() != s.body_positions.size())
    throw std::invalid_argument("body_faces and body_positions differ in length");
  for (size_t b = 0; b < s.body_faces.size(); ++b) bodies_.emplace_back(s.body_faces[b], s.body_positions[b]);
  body_scratch_.resize(bodies_.size());

  x_ = s.positions;
  v_ = s.velocities.rows() == 0 ? Positions(Positions::Zero(n, 3)) : s.velocities;
  if (v_.rows() != n) throw std::invalid_argument("velocities must have one row per vertex");
  if (!x_.allFinite() || !v_.allFinite()) throw std::invalid_argument("positions and velocities must be finite");

  for (int vertex : s.fixed_pin_vertices) {
    if (vertex < 0 || vertex >= n) throw std::invalid_argument("pinned vertex " + std::to_string(vertex) + " out of range");
    pins_.fixed.push_back({vertex, row3(x_, vertex), row3(x_, vertex)});
  }
  if (s.body_pin_vertices.size() != s.body_pin_bodies.size())
    throw std::invalid_argument("body_pin_vertices and body_pin_bodies differ in length");
  for (size_t k = 0; k < s.body_pin_vertices.size(); ++k) {
    const int vertex = s.body_pin_vertices[k], body = s.body_pin_bodies[k];
    if (vertex < 0 || vertex >= n) throw std::invalid_argument("pinned vertex " + std::to_string(vertex) + " out of range");
    if (body < 0 || body >= body_count()) throw std::invalid_argument("pin body " + std::to_string(body) + " out of range");
    pins_.attached.push_back(
        attach_to_body(vertex, row3(x_, vertex), body, bodies_[body].faces(), bodies_[body].frame_start()));
  }
  dv_.setZero(3 * n);
  filter_.reset(n);
  LinearSystemOptions linear{settings_.linear_system, settings_.matrix_precision, settings_.threads,
                             PcgSettings{settings_.cg_tolerance, settings_.cg_max_iterations}, settings_.preconditioner};
  linear_ = make_linear_system(mesh_, *force_model_, linear,
                               static_cast<int>(pins_.fixed.size() + pins_.attached.size()));
  if (s.collision.enabled) {
    std::vector<int> pinned;
    for (const FixedPin& pin : pins_.fixed) pinned.push_back(pin.vertex);
    for (const BodyPin& pin : pins_.attached) pinned.push_back(pin.vertex);
    collisions_ = std::make_unique<CollisionSystem>(mesh_.faces, x_, vertex_mass(), pinned, bodies_, s.collision,
                                                    settings_.threads, mesh_.rest_edge_length);
    // Friction impulses through the step's own system (the preconditioner of its solve, a few
    // CG iterations): timed as solve, not as collision.
    if (s.collision.spread_friction)
      collisions_->spread_friction_with([this](const VectorX& impulse, VectorX& change) {
        const Timer timer;
        linear_->solve_response(impulse, change,
                                PcgSettings{kFrictionResponseTolerance, kFrictionResponseIterations});
        friction_response_seconds_ += timer.seconds();
      });
  }
}

void Simulation::set_threads(int threads) {
  if (threads < 1) throw std::invalid_argument("solver.threads must be at least 1");
  settings_.threads = threads;
  linear_->set_threads(threads);
  if (collisions_) collisions_->set_threads(threads);
}

void Simulation::set_body_keyframes(int body, const Positions& frame_start, const Positions& frame_end) {
  if (body < 0 || body >= body_count()) throw std::invalid_argument("body " + std::to_string(body) + " out of range");
  bodies_[body].set_keyframes(frame_start, frame_end);
}

void Simulation::release_pins(const std::vector<int>& vertices) {
  std::vector<char> release(x_.rows(), 0);
  for (int vertex : vertices) {
    if (vertex < 0 || vertex >= x_.rows()) throw std::invalid_argument("vertex " + std::to_string(vertex) + " out of range");
    release[vertex] = 1;
  }
  const auto released = [&](const auto& pin) { return release[pin.vertex] != 0; };
  pins_.fixed.erase(std::remove_if(pins_.fixed.begin(), pins_.fixed.end(), released), pins_.fixed.end());
  pins_.attached.erase(std::remove_if(pins_.attached.begin(), pins_.attached.end(), released), pins_.attached.end());
  if (collisions_) collisions_->release_pins(vertices, vertex_mass());
}

void Simulation::set_pin_targets(const std::vector<int>& vertices, const Positions& start, const Positions& end) {
  if (start.rows() != static_cast<Eigen::Index>(vertices.size()) || end.rows() != start.rows())
    throw std::invalid_argument("pin targets need one row per vertex");
  if (!start.allFinite() || !end.allFinite()) throw std::invalid_argument("pin targets must be finite");
  for (size_t k = 0; k < vertices.size(); ++k) {
    auto pin = std::find_if(pins_.fixed.begin(), pins_.fixed.end(),
                            [&](const FixedPin& p) { return p.vertex == vertices[k]; });
    if (pin == pins_.fixed.end())
      throw std::invalid_argument("vertex " + std::to_string(vertices[k]) + " is not held by a fixed pin");
    pin->start = row3(start, static_cast<int>(k));
    pin->end = row3(end, static_cast<int>(k));
  }
}

std::vector<std::uint8_t> Simulation::contact_flags() const {
  return collisions_ ? collisions_->contact_flags() : std::vector<std::uint8_t>{};
}

std::vector<std::uint8_t> Simulation::collision_flags() const {
  return collisions_ ? collisions_->analysis_flags() : std::vector<std::uint8_t>{};
}

void Simulation::set_state(const Positions& x, const Positions& v, const VectorX& warm_start,
                           const std::vector<std::uint8_t>& contact_flags,
                           const std::vector<std::uint8_t>& collision_flags) {
  if (x.rows() != x_.rows() || v.rows() != v_.rows())
    throw std::invalid_argument("state must have one row per vertex (" + std::to_string(x_.rows()) + ")");
  if (warm_start.size() != 0 && warm_start.size() != 3 * x_.rows())
    throw std::invalid_argument("warm_start must be empty or have 3 entries per vertex");
  if (!x.allFinite() || !v.allFinite()) throw std::invalid_argument("state must be finite");
  if (collisions_) {
    collisions_->check_analysis_flags(collision_flags);  // both checked before any change
    collisions_->set_contact_flags(contact_flags, static_cast<int>(x_.rows()));
    collisions_->set_analysis_flags(collision_flags);
  } else if (!contact_flags.empty() && std::any_of(contact_flags.begin(), contact_flags.end(), [](auto f) { return f != 0; })) {
    throw std::invalid_argument("contact_flags given for a simulation without collisions");
  } else if (!collision_flags.empty()) {
    throw std::invalid_argument("collision_flags given for a simulation without collisions");
  }
  x_ = x;
  v_ = v;
  if (warm_start.size() == 0) dv_.setZero(); else dv_ = warm_start;
}

Energies Simulation::energies() const {
  // Fixed-order sums (ordered_sum.h): the same bits for any thread count.
  Energies e;
  const auto& mass = vertex_mass();
  const int threads = settings_.threads;
  e.kinetic = ordered_sums<1>(mesh_.vertex_count, threads, [&](std::int64_t begin, std::int64_t end) {
    double sum = 0.0;
    for (auto i = static_cast<int>(begin); i < end; ++i) sum += 0.5 * mass[i] * v_.row(i).squaredNorm();
    return std::array<double, 1>{sum};
  })[0];
  e.gravity = force_model_->gravity_energy(x_, threads);
  e.elastic = force_model_->elastic_energy(x_, kAllForces, threads);
  return e;
}

void Simulation::build_filter(double h, double alpha_end) {
  filter_.reset(mesh_.vertex_count);
  for (const FixedPin& pin : pins_.fixed)
    filter_.constrain_fully(pin.vertex, (pin.target(alpha_end) - row3(x_, pin.vertex)) / h - row3(v_, pin.vertex));
  if (pins_.attached.empty()) return;
  for (size_t b = 0; b < bodies_.size(); ++b) bodies_[b].positions_at(alpha_end, body_scratch_[b]);
  for (const BodyPin& pin : pins_.attached) {
    const Vec3 target = body_pin_target(pin, bodies_[pin.body].faces(), body_scratch_[pin.body]);
    filter_.constrain_fully(pin.vertex, (target - row3(x_, pin.vertex)) / h - row3(v_, pin.vertex));
  }
}

Simulation::StepTimings Simulation::step(double time, double h, double alpha_end) {
  StepTimings t;
  const Timer build_timer;
  linear_->build(x_, v_, time, h);
  build_filter(h, alpha_end);
  t.build = build_timer.seconds();
  if (collisions_)  // cloth/body contacts as prescribed normal velocities in the filtered solve
    collisions_->constrain_contacts(x_, v_, h, bodies_, step_alpha_start_, alpha_end, filter_);

  const Timer solve_timer;
  const PcgStats stats = linear_->solve(filter_, dv_);
  if (collisions_ && collisions_->has_contact_constraints()) {
    linear_->residual(dv_, residual_);
    collisions_->contact_impulses(residual_);
  }
  flat(v_) += dv_;
  if (collisions_) {  // collision stage: makes x + h v collision-free
    const Timer collision_timer;
    friction_response_seconds_ = 0.0;
    collisions_->respond(x_, v_, h, bodies_, step_alpha_start_, alpha_end);
    t.collision = collision_timer.seconds() - friction_response_seconds_;
  }
  flat(x_) += h * flat(v_);
  t.solve = solve_timer.seconds() - t.collision;
  t.setup = stats.preconditioner_setup_seconds;
  t.iterations = stats.iterations;
  t.residual = stats.relative_residual;
  t.converged = stats.converged;
  if (!x_.allFinite() || !v_.allFinite())
    throw SolverDivergence("non-finite positions or velocities after the linear solve (CG iterations " +
                           std::to_string(stats.iterations) + ", relative residual " +
                           std::to_string(stats.relative_residual) + ")");
  return t;
}

int Simulation::substep(double time, double h, double alpha0, double alpha1, int depth, FrameTelemetry& telemetry) {
  const bool can_halve = collisions_ && depth < settings_.max_substep_halvings;
  Positions x0, v0;
  VectorX dv0;
  std::vector<std::uint8_t> contact_flags0;
  int unresolved_before = 0;
  // A step is halved for the strain it creates only from a clean start: in a GIA recovery or a
  // pinch the cloth is pulled or squeezed on purpose. And only for an edge it takes from within
  // the strain limit to beyond max_step_strain: a stretch that pins or bodies force grows past
  // the limit over many steps (a sheet twisted by its handles), which half steps would not change.
  bool watch_strain = false;
  const double strain_limit = collisions_ ? collisions_->settings().max_strain : 0.0;
  const double start_bound = strain_limit > 1.0 ? std::min(strain_limit, settings_.max_step_strain)
                                                : settings_.max_step_strain;
  if (can_halve) {
    x0 = x_;
    v0 = v_;
    dv0 = dv_;
    contact_flags0 = collisions_->contact_flags();
    unresolved_before = collisions_->unresolved();
    watch_strain = settings_.max_step_strain > 0.0 && !collisions_->recovering();
    collisions_->limit_zone_passes(std::max(1, collisions_->settings().zone_iterations / 4));
    if (watch_strain)  // an attempt that tore an edge stops at the CCD pass that did
      collisions_->abandon_when([&](const Positions& x_end) {
        return edge_overstretched(mesh_, x0, x_end, start_bound, settings_.max_step_strain);
      });
  }
  step_alpha_start_ = alpha0;
  // The attempt's budget and test end with it, also when the step throws (the test refers to
  // this call's x0): a caller that catches the error may step again.
  struct AttemptScope {
    CollisionSystem* collisions;
    ~AttemptScope() {
      if (!collisions) return;
      collisions->limit_zone_passes(0);
      collisions->abandon_when(nullptr);
    }
  };
  StepTimings t;
  {
    const AttemptScope scope{can_halve ? collisions_.get() : nullptr};
    t = step(time, h, alpha1);
  }
  telemetry.build_seconds += t.build;
  telemetry.solve_seconds += t.solve;
  telemetry.setup_seconds += t.setup;
  telemetry.cg_iterations += t.iterations;
  const bool unresolved = can_halve && collisions_->unresolved() > unresolved_before;
  if (unresolved || (watch_strain && (collisions_->abandoned() ||
                                      edge_overstretched(mesh_, x0, x_, start_bound, settings_.max_step_strain)))) {
    // The fail-safe ran out, or the responses tore an edge: redo the step as two halves from
    // where it started (the attempt's cost stays in the timings; its unresolved pairs do not
    // count, the halves' do).
    collisions_->rewind_unresolved(unresolved_before);
    x_ = x0;
    v_ = v0;
    dv_ = dv0;
    // The contacts held or released are the start's too: the rejected attempt decided nothing.
    collisions_->set_contact_flags(contact_flags0, static_cast<int>(x_.rows()));
    ++telemetry.subdivided_substeps;
    const double mid = 0.5 * (alpha0 + alpha1);
    const int first = substep(time, 0.5 * h, alpha0, mid, depth + 1, telemetry);
    const int second = substep(time + 0.5 * h, 0.5 * h, mid, alpha1, depth + 1, telemetry);
    return std::max(first, second);
  }
  telemetry.final_residual = t.residual;
  telemetry.unconverged_substeps += t.converged ? 0 : 1;
  ++telemetry.substeps;
  return depth;
}

FrameTelemetry Simulation::advance_frame(double frame_start_time, double frame_duration, int substeps) {
  if (substeps < 1) throw std::invalid_argument("substeps must be at least 1");
  if (!(frame_duration > 0.0)) throw std::invalid_argument("frame duration must be positive");
  FrameTelemetry telemetry;
  telemetry.threads = settings_.threads;
  const Timer frame_timer;
  const double h = frame_duration / substeps;
  if (collisions_) collisions_->begin_frame();
  linear_->start_frame();
  // Each substep is taken as 2^level.start() pieces (SubstepLevel): one that had to be halved
  // makes the next start halved instead of trying, and abandoning, the full step again. Per
  // frame: a frame starts with whole substeps unless its bodies move faster than their
  // thickness through the cloth they reach in one substep; then no substep of it starts less
  // halved than that asks (body_motion.h; a halving short of the deepest level, so that the
  // frame's pieces can still be halved for what the motion estimate misses). Both are decided
  // from the frame's own state, so a run resumed at any frame takes the same steps.
  const int motion = collisions_ && settings_.max_substep_halvings > 1
                         ? collisions_->motion_halvings(x_, v_, bodies_, substeps, frame_duration,
                                                        settings_.max_substep_halvings - 1)
                         : 0;
  SubstepLevel level(settings_.max_substep_halvings, motion);
  telemetry.motion_halvings = level.start();
  for (int s = 0; s < substeps; ++s) {
    const int start = level.start();
    const int pieces = 1 << start;
    const double piece_h = h / pieces;
    int deepest = start;
    for (int p = 0; p < pieces; ++p) {
      const int k = s * pieces + p;  // piece k of the frame's substeps * pieces
      const double alpha0 = static_cast<double>(k) / (substeps * pieces);
      const double alpha1 = static_cast<double>(k + 1) / (substeps * pieces);
      deepest = std::max(deepest, substep(frame_start_time + s * h + p * piece_h, piece_h, alpha0, alpha1, start,
                                          telemetry));
    }
    level.finished(deepest);
  }
  if (collisions_) {
    telemetry.collision = collisions_->end_frame(x_, bodies_);
    telemetry.collision_seconds = telemetry.collision.total_seconds();
    telemetry.gia_seconds = telemetry.collision.gia_seconds;
  }
  const Energies e = energies();
  telemetry.kinetic_energy = e.kinetic;
  telemetry.potential_energy = e.gravity + e.elastic;
  telemetry.max_edge_strain = max_edge_strain(mesh_, x_, settings_.threads);
  telemetry.total_seconds = frame_timer.seconds();
  return telemetry;
}

}  // namespace weft
