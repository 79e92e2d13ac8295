// Python bindings of the linear-system choice and the solver benchmark helpers
// (registered into weft._solver by bindings.cpp).
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bench_support.h"
#include "bindings.h"
#include "weft/integrator.h"

namespace py = pybind11;
using namespace weft;

void bind_linear_system(py::module_& m) {
  py::enum_<LinearSystemKind>(m, "LinearSystemKind")
      .value("FAST", LinearSystemKind::kFast)
      .value("REFERENCE", LinearSystemKind::kReference);
  py::enum_<MatrixPrecision>(m, "MatrixPrecision")
      .value("FLOAT32", MatrixPrecision::kFloat32)
      .value("FLOAT64", MatrixPrecision::kFloat64);

  py::class_<LinearSystemInfo>(m, "LinearSystemInfo")
      .def_readonly("path", &LinearSystemInfo::path)
      .def_readonly("precision", &LinearSystemInfo::precision)
      .def_readonly("force_elements", &LinearSystemInfo::force_elements)
      .def_readonly("per_force_elements", &LinearSystemInfo::per_force_elements)
      .def_readonly("bandwidth_natural", &LinearSystemInfo::bandwidth_natural)
      .def_readonly("bandwidth", &LinearSystemInfo::bandwidth)
      .def_readonly("narrow_columns", &LinearSystemInfo::narrow_columns)
      .def_readonly("blocks", &LinearSystemInfo::blocks)
      .def_readonly("transient_blocks", &LinearSystemInfo::transient_blocks)
      .def_readonly("bytes_per_multiply", &LinearSystemInfo::bytes_per_multiply);

  m.def("linear_system_info", [](Simulation& s) { return s.linear_system().info(); }, py::arg("simulation"));
  m.def("stream_triad_bandwidth", &stream_triad_bandwidth, py::arg("elements") = 40'000'000LL,
        py::arg("repeats") = 5, py::arg("threads") = 1, py::call_guard<py::gil_scoped_release>(),
        "STREAM triad bandwidth in bytes/s (best of repeats, 24 bytes per element).");
  m.def(
      "time_spmv",
      [](Simulation& s, int repeats) {
        SpmvTiming t;
        {
          py::gil_scoped_release release;
          t = time_spmv(s.linear_system(), repeats, s.settings().threads);
        }
        return py::make_tuple(t.seconds, t.bytes);
      },
      py::arg("simulation"), py::arg("repeats") = 20,
      "(seconds per multiply (median), bytes per multiply) of the fast path's last built matrix.");
  m.def(
      "compare_with_eigen_cg",
      [](Simulation& s, double tolerance) {
        const SolveComparison c = compare_with_eigen_cg(s.linear_system(), s.constraint_filter(), tolerance,
                                                        s.settings().cg_max_iterations, s.settings().threads);
        py::dict d;
        d["fast_seconds"] = c.fast_seconds;
        d["fast_iterations"] = c.fast_iterations;
        d["fast_residual"] = c.fast_residual;
        d["eigen_seconds"] = c.eigen_seconds;
        d["eigen_iterations"] = c.eigen_iterations;
        d["eigen_residual"] = c.eigen_residual;
        return d;
      },
      py::arg("simulation"), py::arg("tolerance"),
      "The last step's system solved from zero by the fast PCG and by Eigen's CG (double) to the same residual.");
  m.def(
      "add_transient_spring",
      [](Simulation& s, int i, int j, const Vec3& force_on_i, const Mat3& k, const Mat3& d) {
        TransientElements* t = s.linear_system().transient();
        if (!t) throw std::invalid_argument("the reference linear system has no transient elements");
        t->add_spring(i, j, force_on_i, k, d);
      },
      py::arg("simulation"), py::arg("i"), py::arg("j"), py::arg("force_on_i"), py::arg("k"), py::arg("d"),
      "Adds a transient spring to the next step (fast path); cleared with clear_transient.");
  m.def(
      "clear_transient",
      [](Simulation& s) {
        if (TransientElements* t = s.linear_system().transient()) t->clear();
      },
      py::arg("simulation"));
}
