// Simulation state and the implicit integrator: one linearized backward-Euler step per substep
// (Baraff & Witkin 1998),
//   (M - h dF/dv - h^2 dF/dx) dv = h (F + h dF/dx v),   v += dv,   x += h v,
// with pins as prescribed velocity changes in the pre-filtered PCG.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>

#include "weft/collision_system.h"
#include "weft/bodies/constraints.h"
#include "weft/forces/forces.h"
#include "weft/linear_system/linear_system.h"
#include "weft/linear_system/linear_system_path.h"
#include "weft/substep_level.h"

namespace weft {

struct SolverSettings {
  double cg_tolerance = 1e-5;  // the library's (tests'); a shot's default is 1e-3 (api_schemas/shot.py)
  int cg_max_iterations = 500;
  int threads = 1;
  LinearSystemKind linear_system = LinearSystemKind::kFast;  // fast | reference (linear_system_path.h)
  MatrixPrecision matrix_precision = MatrixPrecision::kFloat32;  // fast path's matrix values
  Preconditioner preconditioner = Preconditioner::kAuto;  // fast path's CG preconditioner (multigrid.h)
  // Adaptive substepping: a substep whose collision stage leaves colliding pairs unresolved is
  // redone as two halves, at most this many halvings deep (0: never). Before the deepest level
  // the impact-zone fail-safe gets a quarter of its pass budget, so a hard step is split
  // instead of spinning.
  int max_substep_halvings = 2;
  // ...and one that takes an edge from within the collision stage's strain limit at its start
  // to more than this many times its rest length at its end, where no GIA recovery or pinch is
  // under way (0: never). The impulses act per vertex after the solve; on a limb moving metres
  // per second they stretched single edges to 3.7x in one step, where two half steps keep the
  // cloth within the strain limit (docs/collisions.md). 1.5: no edge beyond one and a half
  // times its rest length at a step's end unless a pin or a body forces it there over steps.
  double max_step_strain = 1.5;
};

// Everything needed to build a simulation, as flat arrays (cloth pieces concatenated).
struct SimulationSetup {
  Positions positions;
  Positions velocities;  // empty: at rest
  Faces faces;
  FaceUVs face_uv;
  Positions rest_positions;  // empty: flat rest shape
  VectorX face_density, face_stretch_warp, face_stretch_weft, face_shear, face_bend, face_damping;
  VectorX face_stretch_knee, face_stretch_ratio;  // biphasic stretch (forces.h); both empty: linear
  Environment environment;
  std::vector<int> fixed_pin_vertices;  // held at their initial positions
  std::vector<int> body_pin_vertices;   // attached to the closest point of body_pin_bodies[k]
  std::vector<int> body_pin_bodies;
  std::vector<Faces> body_faces;
  std::vector<Positions> body_positions;  // at the first frame
  SolverSettings solver;
  CollisionSettings collision;  // collision_response.h; disabled by default
};

struct FrameTelemetry {
  double build_seconds = 0.0;
  double solve_seconds = 0.0;
  double setup_seconds = 0.0;  // of solve_seconds: the preconditioner's (multigrid hierarchy values)
  double collision_seconds = 0.0;
  double gia_seconds = 0.0;
  double total_seconds = 0.0;
  int cg_iterations = 0;
  double final_residual = 0.0;  // relative residual of the last substep's solve
  int substeps = 0;               // implicit steps taken (more than asked when halved)
  int subdivided_substeps = 0;    // steps redone as two halves (adaptive substepping)
  int motion_halvings = 0;        // halvings every substep started at for the bodies' motion (body_motion.h)
  int threads = 0;                // threads the frame ran on (settings().threads)
  int unconverged_substeps = 0;
  double kinetic_energy = 0.0;
  double potential_energy = 0.0;  // gravity + elastic
  double max_edge_strain = 0.0;   // longest edge over its rest length at frame end (mesh.h)
  CollisionTelemetry collision;   // split of collision_seconds and counts (collision_response.h)
};

struct Energies {
  double kinetic = 0.0;
  double gravity = 0.0;
  double elastic = 0.0;
  double total() const { return kinetic + gravity + elastic; }
};

// The solver produced non-finite state; the message says where.
struct SolverDivergence : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Simulation {
 public:
  explicit Simulation(const SimulationSetup& setup);
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // Advances one frame [t, t + duration] in `substeps` equal substeps. Bodies move linearly
  // from their frame-start to frame-end keyframes across the frame.
  FrameTelemetry advance_frame(double frame_start_time, double frame_duration, int substeps);
  void set_body_keyframes(int body, const Positions& frame_start, const Positions& frame_end);
  // Threads of the coming frames (at least 1; settings().threads). Every result is bitwise the
  // same for any count, so a run may change it between frames (weft/thread_governor.py does
  // when other processes want the cores).
  void set_threads(int threads);

  const Positions& positions() const { return x_; }
  const Positions& velocities() const { return v_; }
  // The last velocity change seeds the next CG solve; restoring it with the state makes a
  // resumed run bitwise identical to an uninterrupted one.
  const VectorX& warm_start() const { return dv_; }
  // The contact constraints' decisions of the last step, which carry over into the next frame
  // (ContactConstraints::flags; empty without collisions or before the first step): restored
  // with the state for the same reason.
  std::vector<std::uint8_t> contact_flags() const;
  // The collision stage's analysis flags (CollisionSystem::analysis_flags; empty without
  // collisions): restored with the state for the same reason.
  std::vector<std::uint8_t> collision_flags() const;
  void set_state(const Positions& x, const Positions& v, const VectorX& warm_start,
                 const std::vector<std::uint8_t>& contact_flags = {},
                 const std::vector<std::uint8_t>& collision_flags = {});
  Energies energies() const;

  const ClothMesh& mesh() const { return mesh_; }
  const ForceModel& force_model() const { return *force_model_; }
  const std::vector<double>& vertex_mass() const { return force_model_->materials().vertex_mass; }
  const PinSet& pins() const { return pins_; }
  // Pins released (a sheet held until a time): these vertices move freely from the next step
  // on and collide as any other. Vertices not pinned are ignored.
  void release_pins(const std::vector<int>& vertices);
  // Prescribed pin paths: over the next frame each listed fixed pin's target moves linearly from
  // its row of start to its row of end (throws for a vertex no fixed pin holds).
  void set_pin_targets(const std::vector<int>& vertices, const Positions& start, const Positions& end);
  int body_count() const { return static_cast<int>(bodies_.size()); }
  const SolverSettings& settings() const { return settings_; }
  const CollisionSystem* collision_system() const { return collisions_.get(); }
  CollisionSystem* collision_system() { return collisions_.get(); }
  const std::vector<KinematicBody>& bodies() const { return bodies_; }
  LinearSystemPath& linear_system() { return *linear_; }
  const ConstraintFilter& constraint_filter() const { return filter_; }  // of the last step

 private:
  struct StepTimings {
    double build = 0.0, solve = 0.0, setup = 0.0;
    int iterations = 0;
    double residual = 0.0;
    bool converged = true;
    double collision = 0.0;
  };
  StepTimings step(double time, double h, double alpha_end);
  // One substep from frame fraction alpha0 to alpha1, halved while its collision stage leaves
  // pairs unresolved or overstretches an edge (SolverSettings::max_step_strain) and depth <
  // max_substep_halvings; adds to the frame's telemetry. Returns the deepest halving a piece of
  // it was taken at (depth when it was not halved).
  int substep(double time, double h, double alpha0, double alpha1, int depth, FrameTelemetry& telemetry);
  void build_filter(double h, double alpha_end);

  SolverSettings settings_;
  ClothMesh mesh_;
  std::unique_ptr<ForceModel> force_model_;
  std::unique_ptr<LinearSystemPath> linear_;
  std::vector<KinematicBody> bodies_;
  std::vector<Positions> body_scratch_;
  PinSet pins_;
  Positions x_, v_;
  VectorX dv_;  // last velocity change, warm start for the next solve
  VectorX residual_;  // b - A dv after a solve with contact constraints
  ConstraintFilter filter_;
  // Collision stage (collision_system.h): null when the scene has collisions switched off.
  std::unique_ptr<CollisionSystem> collisions_;
  double step_alpha_start_ = 0.0;  // frame fraction at the start of the current substep
  double friction_response_seconds_ = 0.0;  // of the current step's collision stage: solve_response
};

}  // namespace weft
