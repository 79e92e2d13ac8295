// Block compressed rows with 3x3 blocks (values column-major: a[3 j + i] = A_ij; float32 or
// float64) in the RCM-ordered numbering of the fast linear system.
//
// Fixed part: the pattern built once from the mesh connectivity. Its column indices are stored
// as 16-bit signed offsets from the diagonal when the bandwidth allows (|offset| <= 32767),
// otherwise as 32-bit columns (the fallback; `narrow_columns()` says which is in use).
// Transient part: extra blocks (contacts, toggled springs) that fall outside the fixed pattern,
// with 32-bit columns, rebuilt every step. The SpMV runs rows without transient entries with a
// fixed-only routine and the others with one that also walks the transient blocks; which rows
// are which is decided once per step (set_transient). Rows are unrolled four blocks per
// iteration with the quotient/remainder precomputed per row. With float32 values the multiply
// first rounds x to float32 and each block is three 4-wide SSE products of its columns, summed
// pairwise within each group of four blocks (separate multiply and add, no FMA; per-row
// accumulation in a fixed order), so the product is bitwise reproducible for any thread count.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <type_traits>
#include <xmmintrin.h>

#include "weft/common/ordered_sum.h"
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

namespace weft {

template <class Scalar>
class BcrsMatrix {
 public:
  BcrsMatrix() = default;

  // row_start (rows + 1) and sorted absolute block columns per row.
  void set_pattern(std::vector<int> row_start, const std::vector<int>& columns) {
    rows_ = static_cast<int>(row_start.size()) - 1;
    row_start_ = std::move(row_start);
    int width = 0;
    for (int r = 0; r < rows_; ++r)
      for (int k = row_start_[r]; k < row_start_[r + 1]; ++k) width = std::max(width, std::abs(columns[k] - r));
    bandwidth_ = width;
    narrow_ = width <= std::numeric_limits<std::int16_t>::max();
    offsets16_.clear();
    columns32_.clear();
    if (narrow_) {
      offsets16_.resize(columns.size());
      for (int r = 0; r < rows_; ++r)
        for (int k = row_start_[r]; k < row_start_[r + 1]; ++k)
          offsets16_[k] = static_cast<std::int16_t>(columns[k] - r);
    } else {
      columns32_.assign(columns.begin(), columns.end());
    }
    quads_.resize(rows_);
    remainders_.resize(rows_);
    for (int r = 0; r < rows_; ++r) {
      const int count = row_start_[r + 1] - row_start_[r];
      quads_[r] = count / 4;
      remainders_[r] = static_cast<std::uint8_t>(count % 4);
    }
    values_.assign(9 * columns.size() + 3, Scalar(0));
    set_transient({}, {}, {}, {});
  }

  // Transient blocks for this step: rows (sorted, unique), per such row a range into columns and
  // values (9 per block). Rows not listed have none.
  void set_transient(std::vector<int> rows, std::vector<int> row_start, std::vector<std::int32_t> columns,
                     std::vector<Scalar> values) {
    transient_rows_ = std::move(rows);
    transient_start_ = std::move(row_start);
    transient_columns_ = std::move(columns);
    transient_values_ = std::move(values);
    transient_slot_.assign(transient_rows_.empty() ? 0 : rows_, -1);
    for (size_t k = 0; k < transient_rows_.size(); ++k) transient_slot_[transient_rows_[k]] = static_cast<int>(k);
  }

  int rows() const { return rows_; }
  int row_begin(int r) const { return row_start_[r]; }
  int row_end(int r) const { return row_start_[r + 1]; }
  int column(int k, int r) const { return narrow_ ? r + offsets16_[k] : columns32_[k]; }
  Scalar* block(int k) { return values_.data() + 9 * static_cast<size_t>(k); }
  const Scalar* block(int k) const { return values_.data() + 9 * static_cast<size_t>(k); }
  size_t block_count() const { return row_start_.empty() ? 0 : static_cast<size_t>(row_start_.back()); }
  size_t transient_block_count() const { return transient_columns_.size(); }
  bool narrow_columns() const { return narrow_; }
  int bandwidth() const { return bandwidth_; }

  // Bytes one multiply streams from memory at best (every value, index and row pointer once,
  // x and y once each): the numerator of the effective bandwidth.
  double bytes_per_multiply() const {
    const double blocks = static_cast<double>(block_count()), t = static_cast<double>(transient_block_count());
    const double index = narrow_ ? 2.0 : 4.0;
    return blocks * (9.0 * sizeof(Scalar) + index) + t * (9.0 * sizeof(Scalar) + 4.0) +
           rows_ * (2.0 * sizeof(int) + sizeof(std::uint8_t)) + 2.0 * 3.0 * sizeof(double) * rows_;
  }

  // y = A x (x, y of length 3 rows, double). With chunk_dots (size: chunks of kReductionChunk
  // rows), also chunk_dots[c] = sum over the chunk's rows r of x_r . y_r in row order: the fixed
  // order of ordered_sum.h, fused into the same pass.
  void multiply(const double* x, double* y, int threads, double* chunk_dots = nullptr) const {
    if (narrow_)
      multiply_with(offsets16_.data(), x, y, threads, chunk_dots);
    else
      multiply_with(columns32_.data(), x, y, threads, chunk_dots);
  }

  // y = A x row by row, handed to epilogue(r, y0, y1, y2) instead of stored: an SpMV fused with
  // the vector update that consumes it (the multigrid smoother). float32 values and no transient
  // part only: x is rounded to float32 before any product, so the epilogue may overwrite row r
  // of x (and of anything else) in place. The same bits as multiply().
  template <class Epilogue>
  void multiply_rows(const double* x, int threads, Epilogue&& epilogue) const {
    static_assert(std::is_same_v<Scalar, float>, "multiply_rows reads x through its float32 copy");
    if (!transient_rows_.empty()) throw std::logic_error("multiply_rows: the matrix has transient blocks");
    round_x(x, threads);
    multiply_rows_rounded(x_float_.data(), threads, epilogue);
  }
  // multiply_rows of an x the caller rounded to float32 itself, 4 lanes per row (x0, x1, x2, 0;
  // store_rounded), typically in the pass that computed it: the same bits as multiply_rows of
  // that x, one pass over the vector less. xf must not be written while the product runs.
  template <class Epilogue>
  void multiply_rows_rounded(const float* xf, int threads, Epilogue&& epilogue) const {
    static_assert(std::is_same_v<Scalar, float>, "multiply_rows_rounded reads a float32 x");
    if (!transient_rows_.empty()) throw std::logic_error("multiply_rows: the matrix has transient blocks");
    if (narrow_)
      rows_with(offsets16_.data(), xf, threads, epilogue);
    else
      rows_with(columns32_.data(), xf, threads, epilogue);
  }
  // Row r of an x rounded for multiply_rows_rounded, into xf (4 floats per row), as round_x does.
  static inline void store_rounded(float* xf, int r, double x0, double x1, double x2) {
    float* out = xf + 4 * static_cast<size_t>(r);
    out[0] = static_cast<float>(x0);
    out[1] = static_cast<float>(x1);
    out[2] = static_cast<float>(x2);
    out[3] = 0.0f;
  }
  struct TransientEntry {
    int row, col;
    const Scalar* values;
  };
  std::vector<TransientEntry> transient_entries() const {
    std::vector<TransientEntry> out;
    for (size_t s = 0; s < transient_rows_.size(); ++s)
      for (int k = transient_start_[s]; k < transient_start_[s + 1]; ++k)
        out.push_back({transient_rows_[s], transient_columns_[k], transient_values_.data() + 9 * static_cast<size_t>(k)});
    return out;
  }

  // Dense copy (tests).
  Eigen::MatrixXd to_dense() const {
    Eigen::MatrixXd d = Eigen::MatrixXd::Zero(3 * rows_, 3 * rows_);
    for (int r = 0; r < rows_; ++r) {
      for (int k = row_start_[r]; k < row_start_[r + 1]; ++k) add_dense(d, r, column(k, r), block(k));
      if (!transient_slot_.empty() && transient_slot_[r] >= 0) {
        const int s = transient_slot_[r];
        for (int k = transient_start_[s]; k < transient_start_[s + 1]; ++k)
          add_dense(d, r, transient_columns_[k], transient_values_.data() + 9 * static_cast<size_t>(k));
      }
    }
    return d;
  }

 private:
  static void add_dense(Eigen::MatrixXd& d, int r, int c, const Scalar* a) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) d(3 * r + i, 3 * c + j) += static_cast<double>(a[3 * j + i]);
  }

  // Adds one 3x3 block times x[c] into (y0, y1, y2).
  static inline void accumulate(const Scalar* a, const double* xc, double& y0, double& y1, double& y2) {
    const double x0 = xc[0], x1 = xc[1], x2 = xc[2];
    y0 += static_cast<double>(a[0]) * x0 + static_cast<double>(a[3]) * x1 + static_cast<double>(a[6]) * x2;
    y1 += static_cast<double>(a[1]) * x0 + static_cast<double>(a[4]) * x1 + static_cast<double>(a[7]) * x2;
    y2 += static_cast<double>(a[2]) * x0 + static_cast<double>(a[5]) * x1 + static_cast<double>(a[8]) * x2;
  }

  template <class Index>
  static inline int column_of(const Index* idx, int k, int r) {
    if constexpr (sizeof(Index) == 2)
      return r + idx[k];
    else
      return idx[k];
  }

  // float32: a * x (4 lanes, the 4th ignored) for a column-major block; xc: the column's x
  // rounded to float32, 4 lanes (x_float_). Reads one float past the block's last column
  // (values_ is padded). The three column products are summed as (c0 + c1) + c2.
  static inline __m128 block_product4(const float* a, const float* xc) {
    const __m128 xv = _mm_loadu_ps(xc);
    const __m128 c0 = _mm_mul_ps(_mm_loadu_ps(a), _mm_shuffle_ps(xv, xv, 0x00));
    const __m128 c1 = _mm_mul_ps(_mm_loadu_ps(a + 3), _mm_shuffle_ps(xv, xv, 0x55));
    const __m128 c2 = _mm_mul_ps(_mm_loadu_ps(a + 6), _mm_shuffle_ps(xv, xv, 0xAA));
    return _mm_add_ps(_mm_add_ps(c0, c1), c2);
  }

  // One row of the fixed part, four blocks per iteration, then the precomputed remainder. With
  // float32 values the four block products of an iteration are summed pairwise before they
  // join the row's sum ((b0 + b1) + (b2 + b3)), so the row's dependency chain is one add per
  // four blocks instead of three per block; the order is fixed per row (any thread count).
  template <class Index>
  inline void fixed_row(const Index* idx, int r, const double* x, const float* xf, double& y0, double& y1,
                        double& y2) const {
    int k = row_start_[r];
    const Scalar* a = values_.data() + 9 * static_cast<size_t>(k);
    if constexpr (std::is_same_v<Scalar, float>) {
      __m128 y = _mm_setzero_ps();
      for (int q = quads_[r]; q > 0; --q, k += 4, a += 36) {
        const __m128 b01 = _mm_add_ps(block_product4(a, xf + 4 * column_of(idx, k, r)),
                                      block_product4(a + 9, xf + 4 * column_of(idx, k + 1, r)));
        const __m128 b23 = _mm_add_ps(block_product4(a + 18, xf + 4 * column_of(idx, k + 2, r)),
                                      block_product4(a + 27, xf + 4 * column_of(idx, k + 3, r)));
        y = _mm_add_ps(y, _mm_add_ps(b01, b23));
      }
      switch (remainders_[r]) {
        case 3: y = _mm_add_ps(y, block_product4(a + 18, xf + 4 * column_of(idx, k + 2, r))); [[fallthrough]];
        case 2: y = _mm_add_ps(y, block_product4(a + 9, xf + 4 * column_of(idx, k + 1, r))); [[fallthrough]];
        case 1: y = _mm_add_ps(y, block_product4(a, xf + 4 * column_of(idx, k, r))); break;
        default: break;
      }
      alignas(16) float lanes[4];
      _mm_store_ps(lanes, y);
      y0 = lanes[0];
      y1 = lanes[1];
      y2 = lanes[2];
    } else {
      for (int q = quads_[r]; q > 0; --q, k += 4, a += 36) {
        accumulate(a, x + 3 * column_of(idx, k, r), y0, y1, y2);
        accumulate(a + 9, x + 3 * column_of(idx, k + 1, r), y0, y1, y2);
        accumulate(a + 18, x + 3 * column_of(idx, k + 2, r), y0, y1, y2);
        accumulate(a + 27, x + 3 * column_of(idx, k + 3, r), y0, y1, y2);
      }
      switch (remainders_[r]) {
        case 3: accumulate(a + 18, x + 3 * column_of(idx, k + 2, r), y0, y1, y2); [[fallthrough]];
        case 2: accumulate(a + 9, x + 3 * column_of(idx, k + 1, r), y0, y1, y2); [[fallthrough]];
        case 1: accumulate(a, x + 3 * column_of(idx, k, r), y0, y1, y2); break;
        default: break;
      }
    }
  }

  template <bool WithTransient, class Index>
  inline void row_product(const Index* idx, int r, const double* x, double* y) const {
    double y0 = 0.0, y1 = 0.0, y2 = 0.0;
    fixed_row(idx, r, x, x_float_.data(), y0, y1, y2);
    if constexpr (WithTransient) {
      const int s = transient_slot_[r];
      if (s >= 0)
        for (int k = transient_start_[s]; k < transient_start_[s + 1]; ++k)
          accumulate(transient_values_.data() + 9 * static_cast<size_t>(k), x + 3 * transient_columns_[k], y0, y1, y2);
    }
    y[3 * r] = y0;
    y[3 * r + 1] = y1;
    y[3 * r + 2] = y2;
  }

  // The row routine (with or without transient blocks) is chosen once per call from the step's
  // transient rows; rows are processed in chunks of kReductionChunk for the fused dot.
  template <class Index>
  void multiply_with(const Index* idx, const double* x, double* y, int threads, double* chunk_dots) const {
    const bool with_transient = !transient_rows_.empty();
    const int chunks = static_cast<int>((rows_ + kReductionChunk - 1) / kReductionChunk);
    if constexpr (std::is_same_v<Scalar, float>) round_x(x, threads);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int c = 0; c < chunks; ++c) {
      const int begin = static_cast<int>(c * kReductionChunk);
      const int end = std::min<int>(rows_, static_cast<int>(begin + kReductionChunk));
      if (with_transient)
        for (int r = begin; r < end; ++r) row_product<true>(idx, r, x, y);
      else
        for (int r = begin; r < end; ++r) row_product<false>(idx, r, x, y);
      if (chunk_dots) {
        double dot = 0.0;
        for (int i = 3 * begin; i < 3 * end; i += 3) dot += x[i] * y[i] + x[i + 1] * y[i + 1] + x[i + 2] * y[i + 2];
        chunk_dots[c] = dot;
      }
    }
  }

  // float32: x rounded once per product (not once per block that reads it), 4 lanes per vertex
  // for one load per block: the same roundings, the same bits.
  void round_x(const double* x, int threads) const {
    x_float_.resize(4 * static_cast<size_t>(rows_));
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int r = 0; r < rows_; ++r) store_rounded(x_float_.data(), r, x[3 * r], x[3 * r + 1], x[3 * r + 2]);
  }
  template <class Index, class Epilogue>
  void rows_with(const Index* idx, const float* xf, int threads, Epilogue& epilogue) const {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int r = 0; r < rows_; ++r) {
      double y0 = 0.0, y1 = 0.0, y2 = 0.0;
      fixed_row(idx, r, nullptr, xf, y0, y1, y2);
      epilogue(r, y0, y1, y2);
    }
  }

  int rows_ = 0;
  int bandwidth_ = 0;
  bool narrow_ = true;
  std::vector<int> row_start_;
  std::vector<std::int16_t> offsets16_;
  std::vector<std::int32_t> columns32_;
  std::vector<int> quads_;
  std::vector<std::uint8_t> remainders_;
  std::vector<Scalar> values_;  // 9 per block, plus 3 of padding (4-wide loads)
  mutable std::vector<float> x_float_;  // float32: the multiplied x, 4 lanes per vertex (scratch)
  std::vector<int> transient_rows_, transient_start_, transient_slot_;
  std::vector<std::int32_t> transient_columns_;
  std::vector<Scalar> transient_values_;
};

}  // namespace weft
