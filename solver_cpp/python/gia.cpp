// Python bindings of the intersection analysis (results cross as plain dicts of numpy arrays)
// and of the body/body pinch states (below).
#include "bindings.h"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <optional>

#include "weft/geometry/exact_predicates.h"
#include "weft/gia/body_pinch.h"
#include "weft/gia/intersection_analysis.h"
#include "weft/integrator.h"

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

// ---------------------------------------------------------------------------------------------
// Python bindings of the body/body pinch states (body_pinch.h): the exact body/body query used
// by the shot's GIA switch, a stand-alone tracker for tests, and the simulation's pair states.
namespace {

const char* state_name(PinchState s) {
  switch (s) {
    case PinchState::kFree: return "free";
    case PinchState::kBecomingPinched: return "becoming_pinched";
    case PinchState::kPinched: return "pinched";
    case PinchState::kBecomingUnpinched: return "becoming_unpinched";
  }
  return "?";
}

py::object box_or_none(const Aabb& box) {
  if (!(box.lo.array() <= box.hi.array()).all()) return py::none();
  return py::make_tuple(box.lo, box.hi);
}

py::list pair_list(const BodyPinchTracker& tracker) {
  py::list out;
  for (const BodyPairPinch& p : tracker.pairs()) {
    py::dict d;
    d["a"] = p.a;
    d["b"] = p.b;
    d["parts"] = p.parts;
    d["yields"] = p.yields;
    d["state"] = state_name(p.state());
    d["start"] = p.start;
    d["end"] = p.end;
    d["region"] = box_or_none(p.region());
    out.append(d);
  }
  return out;
}

// Owns the bodies' faces and positions between calls (the tracker keeps pointers only during update).
struct PyPinchTracker {
  std::vector<Faces> faces;
  BodyPinchTracker tracker;
  PyPinchTracker(std::vector<Faces> f, int threads, std::vector<int> group, double part_gap)
      : faces(std::move(f)), tracker(all_ids(faces.size()), threads, tracking(std::move(group), part_gap)) {}
  static PinchTracking tracking(std::vector<int> group, double part_gap) {
    if (!(part_gap >= 0.0)) throw std::invalid_argument("part_gap must be >= 0");
    PinchTracking t;
    t.group = std::move(group);
    t.part_gap = part_gap;
    return t;
  }
  static std::vector<int> all_ids(size_t n) {
    std::vector<int> ids(n);
    for (size_t i = 0; i < n; ++i) ids[i] = static_cast<int>(i);
    return ids;
  }
  py::list update(const std::vector<Positions>& start, const std::vector<Positions>& end) {
    if (start.size() != faces.size() || end.size() != faces.size())
      throw std::invalid_argument("update needs one start and one end position array per body");
    std::vector<const Positions*> s, e;
    std::vector<const Faces*> f;
    for (size_t b = 0; b < faces.size(); ++b) {
      const int used = faces[b].size() ? faces[b].maxCoeff() + 1 : 0;
      if (start[b].rows() < used || end[b].rows() < used)
        throw std::invalid_argument("body " + std::to_string(b) + ": faces index past the positions");
      s.push_back(&start[b]);
      e.push_back(&end[b]);
      f.push_back(&faces[b]);
    }
    tracker.update(s, e, f);
    return pair_list(tracker);
  }
};

}  // namespace

void bind_pinch(py::module_& m) {
  m.def(
      "body_intersection",
      [](const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb, int threads) {
        const BodyIntersection r = body_intersection(xa, fa, xb, fb, threads);
        py::dict d;
        d["intersecting"] = r.intersecting;
        d["hits"] = r.hits;
        d["paths"] = r.paths;
        d["region"] = box_or_none(r.region);
        return d;
      },
      py::arg("positions_a"), py::arg("faces_a"), py::arg("positions_b"), py::arg("faces_b"), py::arg("threads") = 0,
      "Exact body/body intersection (bounding-box prefilter, then GIA without colouring and, for closed\n"
      "bodies, the inside test): dict with intersecting, hits, paths and region ((lo, hi) box of the\n"
      "intersection volume, or None).");

  py::class_<PyPinchTracker>(m, "BodyPinchTracker",
                             "Body/body pinch states over steps (body_pinch.h); the end of each update is kept for "
                             "the next.")
      .def(py::init<std::vector<Faces>, int, std::vector<int>, double>(), py::arg("faces"), py::arg("threads") = 0,
           py::arg("group") = std::vector<int>{}, py::arg("part_gap") = 0.0,
           "group: per body, the character it is a part of (-1: none); pairs of parts are tracked by their facing "
           "gap (part_gap.h) when part_gap > 0, else not at all.")
      .def("update", &PyPinchTracker::update, py::arg("start"), py::arg("end"),
           "Positions of every body at the step's start and end; returns per body pair a dict with a, b, "
           "parts (a pair of parts of one character), yields (of parts: the one CCD gives way to, -1 before the first "
           "test), state (free, becoming_pinched, pinched, becoming_unpinched), start, end, region.");

  auto simulation = py::reinterpret_borrow<py::class_<Simulation>>(m.attr("Simulation"));
  simulation.def(
      "pinch_states",
      [](const Simulation& s) {
        const CollisionSystem* c = s.collision_system();
        if (!c || !c->pinch()) return py::list();
        return pair_list(*c->pinch());
      },
      "Body pair pinch states over the last substep (empty when pinch tracking is off: GIA off or fewer "
      "than two collidable bodies).");
}

}  // namespace weft
