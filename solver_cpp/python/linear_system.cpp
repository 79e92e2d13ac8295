// Python bindings of the linear-system choice and the solver benchmark helpers
// (registered into weft._solver by bindings.cpp).
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bench_support.h"
#include "bindings.h"
#include "weft/common/timer.h"
#include "weft/integrator.h"
#include "weft/linear_system/fast_linear_system.h"
#include "weft/linear_system/linear_system.h"

namespace py = pybind11;
using namespace weft;

namespace {

template <class F>
auto with_fast_system(LinearSystemPath& path, F&& f) {
  if (auto* p = dynamic_cast<FastLinearSystem<float>*>(&path)) return f(*p);
  if (auto* p = dynamic_cast<FastLinearSystem<double>*>(&path)) return f(*p);
  throw std::invalid_argument("this needs the fast linear system");
}

struct LastSolve {
  PcgStats stats;
  double seconds = 0.0;
  VectorX dv;
};

LastSolve solve_last_system(LinearSystemPath& path, const ConstraintFilter& filter, Preconditioner preconditioner,
                            const PcgSettings& pcg) {
  return with_fast_system(path, [&](auto& fast) {
    LastSolve out;
    out.dv = VectorX::Zero(3 * static_cast<Eigen::Index>(fast.order().size()));
    const Timer timer;
    out.stats = fast.solve_with(filter, out.dv, pcg, preconditioner);
    out.seconds = timer.seconds();
    return out;
  });
}

struct FilteredSystem {
  SparseMatrix matrix;
  VectorX rhs;
};

FilteredSystem filtered_system(LinearSystemPath& path, const ConstraintFilter& filter) {
  return with_fast_system(path, [&](auto& fast) {
    FilteredSystem out;
    form_prefiltered(fast.to_sparse_original(), fast.rhs_original(), filter, out.matrix, out.rhs);
    return out;
  });
}

}  // namespace

void bind_linear_system(py::module_& m) {
  py::enum_<LinearSystemKind>(m, "LinearSystemKind")
      .value("FAST", LinearSystemKind::kFast)
      .value("REFERENCE", LinearSystemKind::kReference);
  py::enum_<MatrixPrecision>(m, "MatrixPrecision")
      .value("FLOAT32", MatrixPrecision::kFloat32)
      .value("FLOAT64", MatrixPrecision::kFloat64);

  py::enum_<Preconditioner>(m, "Preconditioner")
      .value("AUTO", Preconditioner::kAuto)
      .value("BLOCK_JACOBI", Preconditioner::kBlockJacobi)
      .value("MULTIGRID", Preconditioner::kMultigrid);
  m.attr("MULTIGRID_AUTO_VERTICES") = kMultigridAutoVertices;
  m.attr("AUTO_BLOCK_JACOBI_ITERATIONS") = kAutoBlockJacobiIterations;

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
      .def_readonly("bytes_per_multiply", &LinearSystemInfo::bytes_per_multiply)
      .def_readonly("preconditioner", &LinearSystemInfo::preconditioner)
      .def_readonly("multigrid_rows", &LinearSystemInfo::multigrid_rows)
      .def_readonly("multigrid_operator_complexity", &LinearSystemInfo::multigrid_operator_complexity)
      .def_readonly("multigrid_structure_seconds", &LinearSystemInfo::multigrid_structure_seconds)
      .def_readonly("multigrid_setup_seconds", &LinearSystemInfo::multigrid_setup_seconds)
      .def_readonly("multigrid_refreshes", &LinearSystemInfo::multigrid_refreshes)
      .def_readonly("solves", &LinearSystemInfo::solves);

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
      "solve_last_system",
      [](Simulation& s, Preconditioner preconditioner, double tolerance, int max_iterations) {
        LastSolve r;
        {
          py::gil_scoped_release release;
          r = solve_last_system(s.linear_system(), s.constraint_filter(), preconditioner,
                                PcgSettings{tolerance, max_iterations});
        }
        py::dict d;
        d["iterations"] = r.stats.iterations;
        d["relative_residual"] = r.stats.relative_residual;
        d["converged"] = r.stats.converged;
        d["setup_seconds"] = r.stats.preconditioner_setup_seconds;
        d["seconds"] = r.seconds;
        d["dv"] = r.dv;
        return d;
      },
      py::arg("simulation"), py::arg("preconditioner"), py::arg("tolerance"), py::arg("max_iterations") = 5000,
      "The last step's system (its constraint filter) solved from zero by the fast PCG with the given preconditioner: "
      "iterations, relative_residual, converged, setup_seconds (multigrid values), seconds (setup included), dv.");
  m.def(
      "filtered_system",
      [](Simulation& s) {
        const FilteredSystem f = filtered_system(s.linear_system(), s.constraint_filter());
        return py::make_tuple(f.matrix, f.rhs, s.constraint_filter().prescribed);
      },
      py::arg("simulation"),
      "(S A S + I - S as a scipy CSR matrix, S (b - A z), z) of the last step, original vertex order, double: the "
      "system the pre-filtered PCG solves for y = dv - z.");
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
