// Python bindings of the collision module (part of weft._solver): collision settings and
// telemetry, the two CCD queries as plain functions (single and batched), and the exact
// intersection counter.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>

#include "bindings.h"
#include "weft/collision/ccd.h"
#include "weft/integrator.h"
#include "weft/geometry/intersection_count.h"

namespace py = pybind11;
using namespace weft;

namespace {

using Points4 = Eigen::Matrix<double, 4, 3, Eigen::RowMajor>;
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

std::array<Vec3, 4> points(const Points4& m) {
  return {m.row(0).transpose(), m.row(1).transpose(), m.row(2).transpose(), m.row(3).transpose()};
}

CcdOptions make_options(double minimum_separation, double relative_tolerance, int max_boxes) {
  CcdOptions o;
  o.minimum_separation = minimum_separation;
  o.relative_tolerance = relative_tolerance;
  o.max_boxes = max_boxes;
  return o;
}

template <bool kEdgeEdge>
py::tuple ccd_single(const Points4& start, const Points4& end, double minimum_separation, double relative_tolerance,
                     int max_boxes) {
  const CcdOptions o = make_options(minimum_separation, relative_tolerance, max_boxes);
  const CcdResult r = kEdgeEdge ? edge_edge_ccd(points(start), points(end), o)
                                : vertex_triangle_ccd(points(start), points(end), o);
  return py::make_tuple(r.hit, r.toi);
}

template <bool kEdgeEdge>
py::tuple ccd_batch(const DoubleArray& start, const DoubleArray& end, double minimum_separation,
                    double relative_tolerance, int max_boxes, int threads) {
  if (start.ndim() != 3 || start.shape(1) != 4 || start.shape(2) != 3 || end.ndim() != 3 ||
      end.shape(0) != start.shape(0) || end.shape(1) != 4 || end.shape(2) != 3)
    throw std::invalid_argument("start and end must both have shape (N, 4, 3)");
  const py::ssize_t n = start.shape(0);
  py::array_t<bool> hit(n);
  py::array_t<double> toi(n);
  py::array_t<int> boxes(n);
  const double* s = start.data();
  const double* e = end.data();
  bool* hit_out = hit.mutable_data();
  double* toi_out = toi.mutable_data();
  int* boxes_out = boxes.mutable_data();
  const CcdOptions o = make_options(minimum_separation, relative_tolerance, max_boxes);
  {
    py::gil_scoped_release release;
#pragma omp parallel for schedule(dynamic, 256) num_threads(std::max(threads, 1))
    for (py::ssize_t q = 0; q < n; ++q) {
      std::array<Vec3, 4> a, b;
      for (int i = 0; i < 4; ++i) {
        a[i] = Vec3(s[12 * q + 3 * i], s[12 * q + 3 * i + 1], s[12 * q + 3 * i + 2]);
        b[i] = Vec3(e[12 * q + 3 * i], e[12 * q + 3 * i + 1], e[12 * q + 3 * i + 2]);
      }
      const CcdResult r = kEdgeEdge ? edge_edge_ccd(a, b, o) : vertex_triangle_ccd(a, b, o);
      hit_out[q] = r.hit;
      toi_out[q] = r.toi;
      boxes_out[q] = r.boxes;
    }
  }
  return py::make_tuple(hit, toi, boxes);
}

// std::vector<char> flags cross as lists of bools.
using Flags = std::vector<char> CollisionSettings::*;
auto bool_list_getter(Flags member) {
  return [member](const CollisionSettings& s) { return std::vector<bool>((s.*member).begin(), (s.*member).end()); };
}
auto bool_list_setter(Flags member) {
  return [member](CollisionSettings& s, const std::vector<bool>& flags) {
    s.*member = std::vector<char>(flags.begin(), flags.end());
  };
}

}  // namespace

void bind_collision(py::module_& m) {
  py::class_<CollisionSettings>(m, "CollisionSettings")
      .def(py::init<>())
      .def_readwrite("enabled", &CollisionSettings::enabled)
      .def_readwrite("ccd", &CollisionSettings::ccd)
      .def_property("face_collide", bool_list_getter(&CollisionSettings::face_collide),
                    bool_list_setter(&CollisionSettings::face_collide))
      .def_property("face_self_collide", bool_list_getter(&CollisionSettings::face_self_collide),
                    bool_list_setter(&CollisionSettings::face_self_collide))
      .def_property("body_collide", bool_list_getter(&CollisionSettings::body_collide),
                    bool_list_setter(&CollisionSettings::body_collide))
      .def_readwrite("face_thickness", &CollisionSettings::face_thickness)
      .def_readwrite("face_friction", &CollisionSettings::face_friction)
      .def_readwrite("ccd_iterations", &CollisionSettings::ccd_iterations)
      .def_readwrite("zone_iterations", &CollisionSettings::zone_iterations)
      .def_readwrite("count_intersections", &CollisionSettings::count_intersections)
      .def_readwrite("contact_constraints", &CollisionSettings::contact_constraints)
      .def_readwrite("gia", &CollisionSettings::gia)
      .def_readwrite("body_pinch", &CollisionSettings::body_pinch)
      .def_readwrite("part_pinch", &CollisionSettings::part_pinch)
      .def_readwrite("local_aside", &CollisionSettings::local_aside)
      .def_readwrite("spread_friction", &CollisionSettings::spread_friction)
      .def_readwrite("self_culling", &CollisionSettings::self_culling)
      .def_readwrite("body_group", &CollisionSettings::body_group)
      .def_readwrite("body_offset", &CollisionSettings::body_offset)
      .def_readwrite("max_strain", &CollisionSettings::max_strain);

  auto setup = py::reinterpret_borrow<py::class_<SimulationSetup>>(m.attr("SimulationSetup"));
  setup.def_readwrite("collision", &SimulationSetup::collision);

  // Flat per-frame collision telemetry on FrameTelemetry (names as in api_schemas.telemetry).
  auto telemetry = py::reinterpret_borrow<py::class_<FrameTelemetry>>(m.attr("FrameTelemetry"));
  telemetry
      .def_property_readonly("collision_broad_phase_seconds",
                             [](const FrameTelemetry& t) { return t.collision.broad_phase_seconds; })
      .def_property_readonly("collision_proximity_seconds",
                             [](const FrameTelemetry& t) { return t.collision.proximity_seconds; })
      .def_property_readonly("collision_ccd_seconds", [](const FrameTelemetry& t) { return t.collision.ccd_seconds; })
      .def_property_readonly("collision_response_seconds",
                             [](const FrameTelemetry& t) { return t.collision.response_seconds; })
      .def_property_readonly("intersection_seconds",
                             [](const FrameTelemetry& t) { return t.collision.intersection_seconds; })
      .def_property_readonly("self_collision_seconds",
                             [](const FrameTelemetry& t) { return t.collision.self_collision_seconds; })
      .def_property_readonly("contact_constraints_seconds",
                             [](const FrameTelemetry& t) { return t.collision.contact_constraints_seconds; })
      .def_property_readonly("broad_phase_pairs", [](const FrameTelemetry& t) { return t.collision.broad_phase_pairs; })
      .def_property_readonly("proximity_pairs", [](const FrameTelemetry& t) { return t.collision.proximity_pairs; })
      .def_property_readonly("contact_constraints",
                             [](const FrameTelemetry& t) { return t.collision.contact_constraints; })
      .def_property_readonly("released_contacts", [](const FrameTelemetry& t) { return t.collision.released_contacts; })
      .def_property_readonly("strain_limited_edges",
                             [](const FrameTelemetry& t) { return t.collision.strain_limited_edges; })
      .def_property_readonly("friction_spreads", [](const FrameTelemetry& t) { return t.collision.friction_spreads; })
      .def_property_readonly("ccd_candidates", [](const FrameTelemetry& t) { return t.collision.ccd_candidates; })
      .def_property_readonly("ccd_hits", [](const FrameTelemetry& t) { return t.collision.ccd_hits; })
      .def_property_readonly("impact_zones", [](const FrameTelemetry& t) { return t.collision.impact_zones; })
      .def_property_readonly("collision_iterations", [](const FrameTelemetry& t) { return t.collision.iterations; })
      .def_property_readonly("unresolved_collisions", [](const FrameTelemetry& t) { return t.collision.unresolved; })
      .def_property_readonly("intersections", [](const FrameTelemetry& t) { return t.collision.intersections; })
      .def_property_readonly("gia_coloured_vertices",
                             [](const FrameTelemetry& t) { return t.collision.gia_coloured_vertices; })
      .def_property_readonly("gia_pushed_vertices",
                             [](const FrameTelemetry& t) { return t.collision.gia_pushed_vertices; })
      .def_property_readonly("gia_paths", [](const FrameTelemetry& t) { return t.collision.gia_paths; })
      .def_property_readonly("gia_body_coloured_faces",
                             [](const FrameTelemetry& t) { return t.collision.gia_body_coloured_faces; })
      .def_property_readonly("gia_pinched_body_pairs",
                             [](const FrameTelemetry& t) { return t.collision.gia_pinched_body_pairs; })
      .def_property_readonly("gia_pinched_part_pairs",
                             [](const FrameTelemetry& t) { return t.collision.gia_pinched_part_pairs; })
      .def_property_readonly("gia_gripped_vertices",  // diagnostic, not a cache column
                             [](const FrameTelemetry& t) { return t.collision.gia_gripped_vertices; })
      .def_property_readonly("gia_self_coloured_vertices",
                             [](const FrameTelemetry& t) { return t.collision.gia_self_coloured_vertices; })
      .def_property_readonly("gia_self_paths", [](const FrameTelemetry& t) { return t.collision.gia_self_paths; });

  auto simulation = py::reinterpret_borrow<py::class_<Simulation>>(m.attr("Simulation"));
  simulation.def_property_readonly("collisions_enabled", [](const Simulation& s) { return s.collision_system() != nullptr; })
      .def(
          "count_intersections",
          [](Simulation& s) {
            if (s.collision_system()) return s.collision_system()->count_intersections(s.positions(), s.bodies());
            return count_self_intersections(s.positions(), s.mesh().faces);
          },
          "Exact count of intersecting triangle pairs now (cloth/body and cloth/cloth as switched on; "
          "without collisions: cloth/cloth over all faces).")
      .def(
          "cloth_tree_quality",
          [](const Simulation& s) {
            if (!s.collision_system()) throw std::runtime_error("the simulation has no collision stage");
            return s.collision_system()->cloth_tree_quality(s.positions());
          },
          "(refitted, fresh): the surface-area cost of the collision stage's cloth tree refitted at the current "
          "positions and of one built afresh there (the tree is built once and refitted).");

  const char* vt_doc =
      "Conservative CCD of a vertex against a triangle, all moving linearly over t in [0, 1].\n"
      "start, end: (4, 3) positions of (p, a, b, c). Returns (hit, toi): toi is a lower bound of\n"
      "the earliest contact time (1.0 when no hit). No false negatives.";
  const char* ee_doc =
      "Conservative CCD of edge (a0, a1) against edge (b0, b1), moving linearly over t in [0, 1].\n"
      "start, end: (4, 3) positions of (a0, a1, b0, b1). Returns (hit, toi).";
  m.def("vertex_triangle_ccd", &ccd_single<false>, py::arg("start"), py::arg("end"),
        py::arg("minimum_separation") = 0.0, py::arg("relative_tolerance") = 1e-6, py::arg("max_boxes") = 20000,
        vt_doc);
  m.def("edge_edge_ccd", &ccd_single<true>, py::arg("start"), py::arg("end"), py::arg("minimum_separation") = 0.0,
        py::arg("relative_tolerance") = 1e-6, py::arg("max_boxes") = 20000, ee_doc);
  m.def("vertex_triangle_ccd_batch", &ccd_batch<false>, py::arg("start"), py::arg("end"),
        py::arg("minimum_separation") = 0.0, py::arg("relative_tolerance") = 1e-6, py::arg("max_boxes") = 20000,
        py::arg("threads") = 1, "Batched vertex_triangle_ccd over (N, 4, 3) arrays: (hit, toi, boxes).");
  m.def("edge_edge_ccd_batch", &ccd_batch<true>, py::arg("start"), py::arg("end"), py::arg("minimum_separation") = 0.0,
        py::arg("relative_tolerance") = 1e-6, py::arg("max_boxes") = 20000, py::arg("threads") = 1,
        "Batched edge_edge_ccd over (N, 4, 3) arrays: (hit, toi, boxes).");

  m.def(
      "count_self_intersections",
      [](const Positions& x, const Faces& faces) { return count_self_intersections(x, faces); }, py::arg("positions"),
      py::arg("faces"), "Exact number of intersecting triangle pairs within one mesh.");
  m.def(
      "count_mesh_intersections",
      [](const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb) {
        return count_intersections(xa, fa, xb, fb);
      },
      py::arg("positions_a"), py::arg("faces_a"), py::arg("positions_b"), py::arg("faces_b"),
      "Exact number of intersecting triangle pairs between two meshes.");
  m.def(
      "triangles_intersect",
      [](const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>& a, const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>& b) {
        return triangles_intersect({a.row(0).transpose(), a.row(1).transpose(), a.row(2).transpose()},
                                   {b.row(0).transpose(), b.row(1).transpose(), b.row(2).transpose()});
      },
      py::arg("a"), py::arg("b"), "Exact test of two triangles sharing no vertex.");
}
