// Python bindings of the body/body pinch states (body_pinch.h): the exact body/body query used
// by the shot's GIA switch, a stand-alone tracker for tests, and the simulation's pair states.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "weft/gia/body_pinch.h"
#include "weft/integrator.h"

namespace py = pybind11;

namespace weft {
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
  PyPinchTracker(std::vector<Faces> f, int threads)
      : faces(std::move(f)), tracker(all_ids(faces.size()), threads) {}
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
      .def(py::init<std::vector<Faces>, int>(), py::arg("faces"), py::arg("threads") = 0)
      .def("update", &PyPinchTracker::update, py::arg("start"), py::arg("end"),
           "Positions of every body at the step's start and end; returns per body pair a dict with a, b, "
           "state (free, becoming_pinched, pinched, becoming_unpinched), start, end, region.");

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
