// Python bindings: module weft._solver. Arrays cross as numpy (N, 3) float64 / int32.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.h"
#include "weft/integrator.h"

namespace py = pybind11;
using namespace weft;

namespace {
py::array_t<std::uint8_t> uint8_array(const std::vector<std::uint8_t>& values) {
  return py::array_t<std::uint8_t>(static_cast<py::ssize_t>(values.size()), values.data());
}
}  // namespace

PYBIND11_MODULE(_solver, m) {
  m.doc() = "weft implicit cloth solver (C++ core)";

  py::register_exception<SolverDivergence>(m, "SolverDivergence", PyExc_RuntimeError);
  py::register_exception<MeshError>(m, "MeshError", PyExc_ValueError);

  py::enum_<ForceTerm>(m, "ForceTerm", py::arithmetic())
      .value("STRETCH", kStretch)
      .value("SHEAR", kShear)
      .value("BEND", kBend)
      .value("DAMPING", kDamping)
      .value("GRAVITY", kGravity)
      .value("DRAG", kDrag)
      .value("ALL", kAllForces);

  py::class_<Environment>(m, "Environment")
      .def(py::init<>())
      .def_readwrite("gravity", &Environment::gravity)
      .def_readwrite("air_drag", &Environment::air_drag)
      .def_readwrite("wind_velocity", &Environment::wind_velocity)
      .def_readwrite("gust_amplitude", &Environment::gust_amplitude)
      .def_readwrite("gust_frequency", &Environment::gust_frequency)
      .def("wind_at", &Environment::wind_at);

  bind_linear_system(m);

  py::class_<SolverSettings>(m, "SolverSettings")
      .def(py::init<>())
      .def_readwrite("cg_tolerance", &SolverSettings::cg_tolerance)
      .def_readwrite("cg_max_iterations", &SolverSettings::cg_max_iterations)
      .def_readwrite("max_substep_halvings", &SolverSettings::max_substep_halvings)
      .def_readwrite("max_step_strain", &SolverSettings::max_step_strain)
      .def_readwrite("threads", &SolverSettings::threads)
      .def_readwrite("linear_system", &SolverSettings::linear_system)
      .def_readwrite("matrix_precision", &SolverSettings::matrix_precision)
      .def_readwrite("preconditioner", &SolverSettings::preconditioner);

  py::class_<SimulationSetup>(m, "SimulationSetup")
      .def(py::init<>())
      .def_readwrite("positions", &SimulationSetup::positions)
      .def_readwrite("velocities", &SimulationSetup::velocities)
      .def_readwrite("faces", &SimulationSetup::faces)
      .def_readwrite("face_uv", &SimulationSetup::face_uv)
      .def_readwrite("rest_positions", &SimulationSetup::rest_positions)
      .def_readwrite("face_density", &SimulationSetup::face_density)
      .def_readwrite("face_stretch_warp", &SimulationSetup::face_stretch_warp)
      .def_readwrite("face_stretch_weft", &SimulationSetup::face_stretch_weft)
      .def_readwrite("face_shear", &SimulationSetup::face_shear)
      .def_readwrite("face_bend", &SimulationSetup::face_bend)
      .def_readwrite("face_damping", &SimulationSetup::face_damping)
      .def_readwrite("face_stretch_knee", &SimulationSetup::face_stretch_knee)
      .def_readwrite("face_stretch_ratio", &SimulationSetup::face_stretch_ratio)
      .def_readwrite("environment", &SimulationSetup::environment)
      .def_readwrite("fixed_pin_vertices", &SimulationSetup::fixed_pin_vertices)
      .def_readwrite("body_pin_vertices", &SimulationSetup::body_pin_vertices)
      .def_readwrite("body_pin_bodies", &SimulationSetup::body_pin_bodies)
      .def_readwrite("body_faces", &SimulationSetup::body_faces)
      .def_readwrite("body_positions", &SimulationSetup::body_positions)
      .def_readwrite("solver", &SimulationSetup::solver);

  py::class_<FrameTelemetry>(m, "FrameTelemetry")
      .def_readonly("build_seconds", &FrameTelemetry::build_seconds)
      .def_readonly("solve_seconds", &FrameTelemetry::solve_seconds)
      .def_readonly("collision_seconds", &FrameTelemetry::collision_seconds)
      .def_readonly("gia_seconds", &FrameTelemetry::gia_seconds)
      .def_readonly("total_seconds", &FrameTelemetry::total_seconds)
      .def_readonly("cg_iterations", &FrameTelemetry::cg_iterations)
      .def_readonly("final_residual", &FrameTelemetry::final_residual)
      .def_readonly("substeps", &FrameTelemetry::substeps)
      .def_readonly("unconverged_substeps", &FrameTelemetry::unconverged_substeps)
      .def_readonly("kinetic_energy", &FrameTelemetry::kinetic_energy)
      .def_readonly("potential_energy", &FrameTelemetry::potential_energy)
      .def_readonly("max_edge_strain", &FrameTelemetry::max_edge_strain)
      .def_readonly("subdivided_substeps", &FrameTelemetry::subdivided_substeps)
      .def_readonly("motion_halvings", &FrameTelemetry::motion_halvings)
      .def_readonly("threads", &FrameTelemetry::threads)
      .def_readonly("setup_seconds", &FrameTelemetry::setup_seconds);

  py::class_<Energies>(m, "Energies")
      .def_readonly("kinetic", &Energies::kinetic)
      .def_readonly("gravity", &Energies::gravity)
      .def_readonly("elastic", &Energies::elastic)
      .def_property_readonly("total", &Energies::total);

  py::class_<Simulation>(m, "Simulation")
      .def(py::init<const SimulationSetup&>(), py::arg("setup"))
      .def("advance_frame", &Simulation::advance_frame, py::arg("frame_start_time"), py::arg("frame_duration"),
           py::arg("substeps"), py::call_guard<py::gil_scoped_release>())
      .def("set_body_keyframes", &Simulation::set_body_keyframes, py::arg("body"), py::arg("frame_start"),
           py::arg("frame_end"))
      .def_property(
          "threads", [](const Simulation& s) { return s.settings().threads; }, &Simulation::set_threads,
          "threads of the coming frames (at least 1); results are bitwise the same for any count")
      .def("release_pins", &Simulation::release_pins, py::arg("vertices"))
      .def("set_pin_targets", &Simulation::set_pin_targets, py::arg("vertices"), py::arg("frame_start"),
           py::arg("frame_end"))
      .def_property_readonly("positions", &Simulation::positions)
      .def_property_readonly("velocities", &Simulation::velocities)
      .def("set_state", &Simulation::set_state, py::arg("positions"), py::arg("velocities"),
           py::arg("warm_start") = VectorX(), py::arg("contact_flags") = std::vector<std::uint8_t>(),
           py::arg("collision_flags") = std::vector<std::uint8_t>())
      .def_property_readonly(
          "collision_flags", [](const Simulation& s) { return uint8_array(s.collision_flags()); },
          "What the collision stage's next analysis is due to do (GIA due, cloth/cloth analysis due, every body, "
          "contacts set aside, then one entry per body watched), each 0 or 1; empty without collisions. Part of a "
          "resumable state.")
      .def_property_readonly("warm_start", &Simulation::warm_start)
      .def_property_readonly(
          "contact_flags", [](const Simulation& s) { return uint8_array(s.contact_flags()); },
          "Per cloth vertex, what the last step's contact constraints decided: 1 held, 3 held and sticking, 2 released, 0 "
          "neither (empty before the first step or without collisions); part of a resumable state.")
      .def("energies", &Simulation::energies)
      .def_property_readonly("vertex_mass", &Simulation::vertex_mass)
      .def_property_readonly("hinge_count", [](const Simulation& s) { return s.mesh().hinges.size(); })
      .def_property_readonly("nonmanifold_edge_count", [](const Simulation& s) { return s.mesh().nonmanifold_edge_count; })
      .def(
          "evaluate_forces",
          [](const Simulation& s, const Positions& x, const Positions& v, double time, unsigned terms, bool project_spd) {
            if (x.rows() != s.positions().rows() || v.rows() != s.positions().rows())
              throw std::invalid_argument("x and v must have one row per vertex");
            ElementBuffers buffers;
            s.force_model().compute(x, v, time, terms, project_spd, s.settings().threads, buffers);
            GlobalJacobians g = assemble_jacobians(s.mesh(), buffers);
            return py::make_tuple(g.force, g.force_dx, g.force_dv);
          },
          py::arg("x"), py::arg("v"), py::arg("time") = 0.0, py::arg("terms") = static_cast<unsigned>(kAllForces),
          py::arg("project_spd") = false,
          "Global force (3N) and the sparse Jacobians dF/dx, dF/dv for the selected force terms.")
      .def(
          "elastic_energy",
          [](const Simulation& s, const Positions& x, unsigned terms) { return s.force_model().elastic_energy(x, terms); },
          py::arg("x"), py::arg("terms") = static_cast<unsigned>(kAllForces))
      .def(
          "gravity_energy", [](const Simulation& s, const Positions& x) { return s.force_model().gravity_energy(x); },
          py::arg("x"));

  m.def("hinge_angle", &hinge_angle, py::arg("x0"), py::arg("x1"), py::arg("x2"), py::arg("x3"));
  bind_gia(m);
  bind_collision(m);
  weft::bind_pinch(m);
}
