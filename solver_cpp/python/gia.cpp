// Python bindings of the intersection analysis: results cross as plain dicts of numpy arrays.
#include "gia.h"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <optional>

#include "weft/geometry/exact_predicates.h"
#include "weft/gia/intersection_analysis.h"

namespace py = pybind11;

namespace weft {
namespace {

template <typename T>
py::array_t<T> to_array(const std::vector<T>& v) {
  py::array_t<T> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

const char* end_kind_name(GiaEndKind k) {
  switch (k) {
    case GiaEndKind::kClosed: return "closed";
    case GiaEndKind::kBoundary: return "boundary";
    case GiaEndKind::kSharedVertex: return "shared_vertex";
    case GiaEndKind::kNonManifold: return "nonmanifold";
    case GiaEndKind::kDangling: return "dangling";
  }
  return "?";
}

py::dict mesh_dict(const GiaMeshColouring& m) {
  py::dict d;
  d["edges"] = m.edges;
  d["vertex_colour"] = to_array(m.vertex_colour);
  d["vertex_path"] = to_array(m.vertex_path);
  d["edge_colour"] = to_array(m.edge_colour);
  d["face_colour"] = to_array(m.face_colour);
  d["vertex_parity_colour"] = to_array(m.vertex_parity_colour);
  d["parity_conflicts"] = m.parity_conflicts;
  d["inside_other"] = m.inside_other.empty() ? py::object(py::none()) : py::object(to_array(m.inside_other));
  d["coloured_vertex_count"] = m.coloured_vertex_count;
  d["boundary_edge_count"] = m.boundary_edge_count;
  d["closed"] = m.closed;
  return d;
}

py::dict result_dict(const GiaResult& r) {
  const size_t n = r.hits.size();
  std::vector<int> edge_mesh(n), edge(n), tri_mesh(n), tri(n);
  std::vector<double> t(n);
  Positions point(static_cast<Eigen::Index>(n), 3);
  for (size_t i = 0; i < n; ++i) {
    const GiaHit& h = r.hits[i];
    edge_mesh[i] = h.edge_mesh;
    edge[i] = h.edge;
    tri_mesh[i] = h.tri_mesh;
    tri[i] = h.tri;
    t[i] = h.edge_t;
    point.row(static_cast<Eigen::Index>(i)) = h.point.transpose();
  }
  py::dict hits;
  hits["edge_mesh"] = to_array(edge_mesh);
  hits["edge"] = to_array(edge);
  hits["tri_mesh"] = to_array(tri_mesh);
  hits["tri"] = to_array(tri);
  hits["edge_t"] = to_array(t);
  hits["point"] = point;
  py::list paths;
  for (const GiaPath& p : r.paths) {
    py::dict d;
    d["hits"] = to_array(p.hits);
    d["closed"] = p.closed;
    d["vertices"] = to_array(p.vertices);
    d["end_kinds"] = py::make_tuple(end_kind_name(p.end_kind[0]), end_kind_name(p.end_kind[1]));
    d["end_meshes"] = py::make_tuple(p.end_mesh[0], p.end_mesh[1]);
    d["separates"] = py::make_tuple(p.separates[0], p.separates[1]);
    d["coloured_vertices"] = py::make_tuple(p.coloured_vertices[0], p.coloured_vertices[1]);
    paths.append(d);
  }
  py::dict d;
  d["self"] = r.self;
  d["hits"] = hits;
  d["paths"] = paths;
  d["a"] = mesh_dict(r.mesh[0]);
  d["b"] = r.self ? py::object(py::none()) : py::object(mesh_dict(r.mesh[1]));
  d["hit_count"] = n;
  d["path_count"] = r.paths.size();
  d["closed_path_count"] = r.closed_path_count;
  d["open_path_count"] = r.open_path_count;
  d["intersecting"] = r.intersecting;
  d["candidate_pairs"] = r.candidate_pairs;
  d["intersecting_pairs"] = r.intersecting_pairs;
  d["inconsistent_pairs"] = r.inconsistent_pairs;
  d["seconds"] = r.seconds;
  return d;
}

}  // namespace

void bind_gia(py::module_& m) {
  m.def(
      "intersection_analysis",
      [](const Positions& x_a, const Faces& faces_a, std::optional<Positions> x_b, std::optional<Faces> faces_b,
         bool colour, bool inside_test, int threads) {
        if (x_b.has_value() != faces_b.has_value())
          throw std::invalid_argument("give both x_b and faces_b, or neither (self intersection)");
        GiaOptions options;
        options.colour = colour;
        options.inside_test = inside_test;
        options.threads = threads;
        GiaResult r;
        {
          py::gil_scoped_release release;
          r = x_b ? analyse_intersections(x_a, faces_a, *x_b, *faces_b, options)
                  : analyse_self_intersections(x_a, faces_a, options);
        }
        return result_dict(r);
      },
      py::arg("x_a"), py::arg("faces_a"), py::arg("x_b") = py::none(), py::arg("faces_b") = py::none(),
      py::arg("colour") = true, py::arg("inside_test") = true, py::arg("threads") = 0,
      "Global intersection analysis of mesh A against mesh B (or A against itself when B is not given).\n"
      "Returns a dict: hits (edge_mesh, edge, tri_mesh, tri, edge_t, point), paths (hits in order, closed,\n"
      "end_kinds, end_meshes, separates, coloured_vertices), 'a'/'b' per-mesh colourings (edges,\n"
      "vertex_colour, vertex_path, edge_colour, face_colour with 0 free / 1 inside / 2 contour, inside_other\n"
      "when the other mesh is closed), counts and seconds. See docs/intersection-analysis.md.");
  m.def(
      "points_inside_closed_mesh",
      [](const Positions& points, const Positions& x, const Faces& faces, int threads) {
        std::vector<std::int8_t> inside;
        {
          py::gil_scoped_release release;
          inside = points_inside_closed_mesh(points, x, faces, threads);
        }
        return to_array(inside);
      },
      py::arg("points"), py::arg("x"), py::arg("faces"), py::arg("threads") = 0,
      "1 for points inside the closed (watertight) mesh, by ray parity with exact perturbed predicates.");
  m.def(
      "orient3d",
      [](const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
        return orient3d_exact_sign(a.data(), b.data(), c.data(), d.data());
      },
      py::arg("a"), py::arg("b"), py::arg("c"), py::arg("d"), "Exact sign of det[a-d; b-d; c-d].");
}

}  // namespace weft
